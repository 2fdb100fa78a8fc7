"""GA tuning cost: wall time and episodes/s of a short run, and an EXTRAPOLATION to the paper budgets.

Runs ``vtrack_gym.tuning.ga.tune`` for a few generations of the paper population sizes (SMC 10, MPC 20) on
full Case-1 episodes and extrapolates linearly in generations. This is an extrapolation, not a measurement:
early generations hold more failing individuals (they end early but the batch runs until its slowest car),
and the machine's load changes the figures.
Run: ``python benchmarks/bench_tuning.py [--generations 3] [--controllers smc,mpc]``.
"""

from __future__ import annotations

import argparse
import time

from vtrack_gym.tuning.ga import tune
from vtrack_gym.tuning.spaces import Budget, budget, search_space


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--generations", type=int, default=3)
    parser.add_argument("--controllers", default="smc,mpc")
    args = parser.parse_args()
    for controller in args.controllers.split(","):
        paper = budget(controller, "paper")
        space = search_space(controller, "working")
        short = Budget("bench", args.generations, paper.pop_size)
        start = time.perf_counter()
        result = tune(space, short, seed=0, progress=False)
        wall = time.perf_counter() - start
        per_gen = wall / args.generations
        print(f"{controller}: {args.generations} generations x {paper.pop_size} = {result.episodes} Case-1 episodes "
              f"in {wall:.1f} s ({result.episodes / wall:.2f} episodes/s, {result.car_steps / wall:,.0f} car-steps/s, "
              f"{per_gen:.2f} s/generation); best fitness {result.best_fitness:.4g}")
        total = per_gen * paper.generations
        print(f"  EXTRAPOLATED paper budget {paper.generations} x {paper.pop_size}: ~{total:.0f} s "
              "(linear in generations; not measured)")


if __name__ == "__main__":
    main()
