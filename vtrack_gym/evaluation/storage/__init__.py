"""The leaderboard store: one SQLite file that persists rows (it produces none)."""
