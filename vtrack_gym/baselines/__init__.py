"""Policies that read the env's observation and steer: the scripted baselines (SMC, MPC, LQR, Stanley, pure
pursuit, constrained MPC), their preset files, and the torch-free weights-only agent policy (``numpy_policy``,
``shipped``) that evaluates trained agents with numpy alone."""
