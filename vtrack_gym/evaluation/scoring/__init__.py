"""One episode measured: its trace, metrics, laps, comfort, and its row with the row's value rule."""
