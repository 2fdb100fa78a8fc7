"""RL agents: training with stable-baselines3 (``train``, ``export``, ``imitation``, ``regularised_sac``,
``sb3_vec_env``). The only subpackage that imports SB3/torch; the trained agents it writes are evaluated by
``vtrack_gym.baselines.numpy_policy`` (numpy and json only)."""
