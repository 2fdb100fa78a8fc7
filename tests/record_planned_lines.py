"""Write the shipped planned lines (``vtrack_gym/data/planned_lines_v1.npz``, ``tracks.planned_line_store``): the
lines ``plan_line`` plans, here and now, for the env ids given with their default car. An entry already stored is
never rewritten (a different table for the same inputs is an error).

    python tests/record_planned_lines.py vtrack/ISO3888-1-v1 vtrack/ISO3888-2-v1
"""

from __future__ import annotations

import argparse
from typing import Any
from unittest import mock

import numpy as np


def planned_lines(env_ids: list[str]) -> list[tuple[str, np.ndarray, float]]:
    """(inputs, table, ds) of every line ``plan_line`` plans (not read from the store) while each id is made."""
    import gymnasium as gym

    import vtrack_gym  # noqa: F401  (registers the ids)
    from vtrack_gym.tracks import feasibility, maneuvers, planned_line

    found: list[tuple[str, np.ndarray, float]] = []

    def planning(*args: Any, **kwargs: Any) -> Any:
        line = planned_line.plan_line(*args, **{**kwargs, "stored": False})
        found.append((planned_line.plan_inputs(*args, **kwargs), line.path.table, line.path.ds_m))
        return line

    feasibility.planned_maneuver.cache_clear()          # plan here, not from a line built before
    try:
        with mock.patch.object(maneuvers, "plan_line", planning):
            for env_id in env_ids:
                gym.make(env_id).close()
    finally:
        feasibility.planned_maneuver.cache_clear()      # keep no planned line from the cache's later callers
    return found


def main(argv: list[str] | None = None) -> int:
    from vtrack_gym.tracks import planned_line_store

    parser = argparse.ArgumentParser(description="Ship the planned lines of env ids (default car).")
    parser.add_argument("env_ids", nargs="+")
    args = parser.parse_args(argv)
    lines = planned_lines(args.env_ids)
    added = planned_line_store.write_entries(lines)
    print(f"{len(lines)} line(s) planned, {added} new; {planned_line_store.STORE_FILE} is "
          f"{planned_line_store.STORE_FILE.stat().st_size} bytes")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
