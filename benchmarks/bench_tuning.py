"""GA tuning cost: the full paper budgets, measured, and the population rollout against its reference path.

For each controller this runs the exact search of the shipped preset (``vtrack_gym/baselines/presets/
<controller>_tuned.json``: SMC ``steering`` space, 100 generations x 10; MPC ``paper`` space, 200 x 20; both
with ``--also-complete DLC120-v0``, the seed its provenance records), prints wall time, episodes/s and
car-steps/s, and says whether the best parameters equal the shipped preset's (same seed, same result). Then, as
a peer measured in the same run, it evaluates one population on the first 3000 steps of Case 1 with the compiled
whole-episode rollout and with the reference path (the same compiled laws called through ``Policy.act``,
stepping ``BatchSim.step`` one control period at a time) and prints the ratio.
Run: ``python benchmarks/bench_tuning.py [--controllers smc,mpc] [--generations N]`` (N: a shorter run, which
then cannot reproduce the shipped preset).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from vtrack_gym.baselines.preset_files import load_preset, packaged_preset_path
from vtrack_gym.tuning.ga import tune
from vtrack_gym.tuning.population import PopulationEvaluator
from vtrack_gym.tuning.spaces import Budget, budget, search_space

SHIPPED_SPACE = {"smc": "steering", "mpc": "paper"}
ALSO_COMPLETE = ("DLC120-v0",)
PEER_STEPS = 3000


def _peer_ratio(controller: str, pop_size: int) -> str:
    space = search_space(controller, SHIPPED_SPACE[controller])
    X = np.random.default_rng(0).uniform(space.lower, space.upper, size=(pop_size, len(space.params)))
    rates = {}
    for compiled in (True, False):
        ev = PopulationEvaluator(space, max_steps=PEER_STEPS, compiled=compiled)
        ev(X[:2])  # compile / warm up
        before = ev.car_steps
        start = time.perf_counter()
        res = ev(X)
        wall = time.perf_counter() - start
        rates[compiled] = (ev.car_steps - before) / wall, res
    fast, ref = rates[True], rates[False]
    same = np.array_equal(fast[1].completed, ref[1].completed)
    return (f"  peer, same run ({pop_size} individuals x first {PEER_STEPS} steps of Case 1): compiled rollout "
            f"{fast[0]:,.0f} car-steps/s vs reference step-by-step path {ref[0]:,.0f} car-steps/s = "
            f"{fast[0] / ref[0]:.1f}x (same completions: {same})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--controllers", default="smc,mpc")
    parser.add_argument("--generations", type=int, default=None, help="shorter run (default: the paper budget)")
    args = parser.parse_args()
    for controller in args.controllers.split(","):
        paper = budget(controller, "paper")
        run_budget = paper if args.generations is None else Budget("short", args.generations, paper.pop_size)
        space = search_space(controller, SHIPPED_SPACE[controller])
        path = packaged_preset_path(controller)
        shipped = load_preset(path) if path.is_file() else None
        seed = int(shipped.get("provenance", {}).get("seed", 0)) if shipped else 0
        start = time.perf_counter()
        result = tune(space, run_budget, seed=seed, also_complete=ALSO_COMPLETE, progress=False)
        wall = time.perf_counter() - start
        print(f"{controller}: {run_budget.generations} generations x {run_budget.pop_size} ({result.episodes} "
              f"episodes: Case 1 + DLC120-v0 per individual) in {wall:.1f} s = {result.episodes / wall:.2f} "
              f"episodes/s, {result.car_steps / wall:,.0f} car-steps/s; best fitness (Case-1 ITAE) "
              f"{result.best_fitness:.4g} (seed {seed})")
        if shipped is not None:
            print(f"  best parameters equal the shipped {path.name}: {result.best_config == shipped['config']}")
        print(_peer_ratio(controller, paper.pop_size))


if __name__ == "__main__":
    main()
