"""Single-env and vector-env steps/s of two checkouts of the package, alternating, as a ratio (after / before).

    python benchmarks/bench_env_ab.py BEFORE_CHECKOUT [AFTER_CHECKOUT] [--rounds 4]

e.g. ``git worktree add /tmp/before <commit>`` then ``python benchmarks/bench_env_ab.py /tmp/before .``. Each
measurement is a fresh interpreter with ``PYTHONPATH`` set to the checkout (``bench_env.single_env_rate`` and
``vector_rate`` of ``LateralTracking-v0``, N = 4096); one warm-up run per checkout compiles its kernels first, then
the rounds alternate the order so that a change in the machine's load hits both alike. Prints every run, the
medians, their ratios and the load average.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

MEASURE = """
import sys
sys.path.insert(0, "benchmarks")
import bench_env
print(bench_env.single_env_rate("LateralTracking-v0"), bench_env.vector_rate("LateralTracking-v0", 4096))
"""


def measure(checkout: Path) -> tuple[float, float]:
    """(single env steps/s, vector env-steps/s) of the package in ``checkout``, in a fresh interpreter."""
    env = dict(os.environ, PYTHONPATH=str(checkout))
    out = subprocess.run([sys.executable, "-c", MEASURE], cwd=checkout, env=env, capture_output=True, text=True,
                         check=True).stdout.split()
    return float(out[-2]), float(out[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("before", type=Path, help="checkout of the earlier code")
    parser.add_argument("after", type=Path, nargs="?", default=Path.cwd(), help="checkout of the new code (default: .)")
    parser.add_argument("--rounds", type=int, default=4, help="alternating rounds (default: 4)")
    args = parser.parse_args(argv)
    trees = {"before": args.before.resolve(), "after": args.after.resolve()}
    print("load average before:", " ".join(f"{x:.2f}" for x in os.getloadavg()))
    for tree in trees.values():
        measure(tree)   # compiles the checkout's kernels into its cache
    runs: dict[str, list[tuple[float, float]]] = {name: [] for name in trees}
    for r in range(args.rounds):
        for name in (("before", "after") if r % 2 == 0 else ("after", "before")):
            runs[name].append(measure(trees[name]))
            print(f"round {r + 1} {name:>6}: single {runs[name][-1][0]:>10,.0f}  vector {runs[name][-1][1]:>12,.0f}")
    for i, what in enumerate(("single env steps/s", "vector env-steps/s N=4096")):
        before = statistics.median(run[i] for run in runs["before"])
        after = statistics.median(run[i] for run in runs["after"])
        print(f"{what:<26} before {before:>12,.0f}  after {after:>12,.0f}  after/before {after / before:.3f}")
    print("load average after:", " ".join(f"{x:.2f}" for x in os.getloadavg()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
