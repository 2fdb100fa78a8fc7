"""The built-in leaderboard suites, one file each (``evaluation.suite.suites.BUILT_IN`` lists them in board order)."""
