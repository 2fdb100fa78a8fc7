"""RL agents: training with stable-baselines3 (``train``, ``export``, ``sb3_vec_env``: the only modules that import
SB3/torch) and the weights-only agent format (``numpy_policy``, ``shipped``: numpy and json only)."""
