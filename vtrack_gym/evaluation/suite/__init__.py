"""Leaderboard suites: the ``Suite`` object, its registry, the built-in suites and seed sets."""
