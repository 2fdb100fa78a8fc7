"""Evaluation: rollout -> trace -> metrics (paper metrics, ISO 2631-1 comfort), the leaderboard store, plots."""
