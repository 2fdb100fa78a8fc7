"""Everything that imports stable-baselines3 / torch: the SB3 VecEnv adapter, training, export."""
