"""CPU time of reading a large leaderboard store: opening it, ``rows()``, ``board_rows`` and ``vtrack leaderboard``.

Writes a store of N rows shaped like a benchmark's (about 30 metrics, a track's provenance in the options) in one
``add``, then measures the CPU time of each read step in this process (``time.process_time``). Every read checks
each row against its SHA-256, the row rule (``row_validation``, as every write does) and the row count and digest;
a second read of an unchanged store by the same ``ResultStore`` reuses the first one's checked rows.
``vtrack leaderboard`` reads the store as one ``ResultStore`` (suites, board, older versions) and then aggregates
the board (bootstrap intervals per policy and env: not a store cost). Run:
``python benchmarks/bench_store_read.py [N]`` (default 100000).
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

from vtrack_gym.evaluation.benchmarking.benchmark import LEADERBOARD_COLUMNS
from vtrack_gym.evaluation.storage.store import ResultRow, ResultStore

METRICS = {**{f"max_{k}": 0.25 for k in ("e_y_m", "e_phi_deg", "a_y_mps2", "hand_wheel_deg", "roll_deg",
                                         "yaw_rate_degps", "beta_deg", "jerk_mps3")},
           **{f"rms_{k}": 0.1 for k in ("e_y_m", "e_phi_deg", "a_y_mps2", "hand_wheel_deg", "roll_deg",
                                        "yaw_rate_degps", "beta_deg", "jerk_mps3")},
           "itae": 1.5, "duration_s": 12.0, "progress_m": 120.0, "remaining_m": 0.0, "cones_hit": 0,
           "steering_reversals_per_s": 0.4, "comfort_a_v_mps2": 0.3, "comfort_band": "not uncomfortable",
           "wall_time_per_step_s": 1e-4, "wall_time_s": 0.1, "termination": "completed"}
OPTIONS = {"vehicle": "paper", "track_file": "road.csv", "track_sha256": "ab" * 32, "speed_profile": "constant"}


def rows(n: int) -> list[ResultRow]:
    """``n`` rows of 10 policies on 10 envs."""
    return [ResultRow("bulk", f"DLC{100 + i % 10}-v0", f"policy{i // 10 % 10}", f"{i // 10 % 10:012x}", i // 100,
                      {**METRICS, "max_e_y_m": 0.2 + 1e-6 * i}, "completed", 1e-4, options=dict(OPTIONS))
            for i in range(n)]


def cpu(label: str, fn):

    start = time.process_time()
    result = fn()
    print(f"{label:<36} {time.process_time() - start:7.2f} s CPU", file=sys.__stdout__, flush=True)
    return result


COMMAND = textwrap.dedent("""
    import contextlib, io, sys, time
    from vtrack_gym.cli import main
    start = time.process_time()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        code = main(["leaderboard", "--store", sys.argv[1], "--suite", "bulk", "--format", "csv"])
    assert code == 0, code
    print(time.process_time() - start)
""")


def leaderboard_cpu(path: Path) -> float:
    """CPU time [s] of ``vtrack leaderboard --suite bulk`` on ``path`` in a fresh process (no cache of this one)."""
    done = subprocess.run([sys.executable, "-c", COMMAND, str(path)], capture_output=True, text=True, check=True)
    return float(done.stdout.strip().splitlines()[-1])


def main(n: int = 100_000) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "big.sqlite"
        batch = rows(n)
        cpu(f"add {n} rows (one batch)", lambda: ResultStore(path).add(batch))
        store = cpu("open read-only (verify)", lambda: ResultStore(path, read_only=True))
        got = cpu("rows() (first read)", store.rows)
        assert len(got) == n
        cpu("rows('bulk') again", lambda: store.rows("bulk"))
        cpu("board_rows('bulk') again", lambda: store.board_rows("bulk"))
        cpu("suites() on a new ResultStore", ResultStore(path, read_only=True).suites)
        cpu("leaderboard() on a new ResultStore", lambda: ResultStore(path, read_only=True).leaderboard(
            "bulk", LEADERBOARD_COLUMNS))
        print(f"{'vtrack leaderboard (fresh process)':<36} {leaderboard_cpu(path):7.2f} s CPU (imports excluded)")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 100_000)
