"""Evaluation: policies scored on episodes, the leaderboard and its store, figures; one subpackage per job.

``scoring`` (trace, metrics, the row), ``identity`` (who drove where), ``leaderboard`` (the board of rows and its
output formats), ``rollouts`` (driving episodes, where they run), ``suite`` (the suite registry), ``storage`` (the
SQLite store), ``figures``, ``benchmarking`` (suites and track files scored) and ``reproduction``; ``api`` is the
Python entry (``evaluate``, ``leaderboard``).
"""
