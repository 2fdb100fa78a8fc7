"""The built-in leaderboard suites, one file each (``evaluation.suite.suites._REGISTRY`` lists them in board order)."""
