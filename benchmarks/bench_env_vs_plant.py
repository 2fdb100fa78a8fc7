"""An env step against a plant step, on one thread, in the same units: CPU time per car and control period.

The env step is ``BatchSim.step`` (what the vector env and the single env call: speed loop, plant, projection,
observation, termination, reward); the plant step is ``Plant.step`` alone over the same physics steps (5 of 2 ms)
at the same operating point: the env's cars start on the handling course at its target speed (11.1 m/s; the course
itself starts them at rest, and the tyre model costs more near standstill, which would charge the env for other
physics) and the plant steps copies of those cars (states, inputs, road) as the env has left them after its first
step. Both run on one numba thread and are timed with ``time.process_time`` (CPU time, so a loaded machine slows
both alike), alternating env and plant per repeat; the median of the repeats is shown with the load average.
Run: ``python benchmarks/bench_env_vs_plant.py [N ...]`` (default N = 256 4096). ``--against DIR [--runs R]``: this
checkout and the one at ``DIR`` (its own copy of this script) in fresh processes, alternating, R runs each (default
5); the median over the runs of each one's medians is printed with the load average.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time
from collections.abc import Callable

import numpy as np

REPEATS = 5
RUNS = 5          # runs of each checkout with --against
MIN_CPU_S = 0.4   # CPU time per repeat and side


def cpu_ns_per_call(fn: Callable[[], object]) -> float:
    """CPU time of one call of ``fn`` [ns] over at least ``MIN_CPU_S`` of CPU."""
    calls = 0
    start = time.process_time()
    while True:
        fn()
        calls += 1
        spent = time.process_time() - start
        if spent >= MIN_CPU_S:
            return 1e9 * spent / calls


def handling_course(n: int, at_speed: bool = True) -> Callable[[], object]:
    """One control period of ``n`` cars on the handling course (steering 0.01; a car whose episode ended keeps
    being stepped, as the compiled step does, so no Python-side reset is timed). ``at_speed``: the cars start at the
    course's target speed instead of at rest."""
    from vtrack_gym.envs.config import EnvConfig, ResetOptions
    from vtrack_gym.envs.scenarios import resolve_scenario
    from vtrack_gym.envs.sim import BatchSim
    from vtrack_gym.vehicle import layout as L

    sim = BatchSim(resolve_scenario("LateralTracking-v0"), EnvConfig(), n)
    for i in range(n):
        sim.seed(i, i)
        sim.reset_car(i, ResetOptions())
    if at_speed:
        sim.plant.state[:, L.S_VX] = sim.v_ref
    sim.observe_after_reset(np.arange(n))
    actions = np.full(n, 0.01)

    def step() -> object:
        return sim.step(actions)

    step.sim = sim   # type: ignore[attr-defined]  # for plant_like
    return step


def plant_like(env_step: Callable[[], object]) -> Callable[[], object]:
    """The plant alone over one control period (5 physics steps) of copies of ``env_step``'s cars: their states,
    inputs (steering, throttle, brake) and road as the env has left them."""
    from vtrack_gym.vehicle.plant import Plant

    sim = env_step.sim   # type: ignore[attr-defined]
    plant = Plant(sim.config.vehicle, n=sim.n, model=sim.config.model, physics_dt_s=sim.config.physics_dt_s)
    plant.state[:] = sim.plant.state
    inputs, road = sim.inputs.copy(), sim.road.copy()
    n_sub = sim.n_sub
    return lambda: plant.step(inputs, n_sub, road)


def main(sizes: list[int]) -> None:
    import numba

    numba.set_num_threads(1)
    print(f"one thread; CPU time per car and control period (5 physics steps); load average "
          f"{os.getloadavg()[0]:.1f} at start")
    print(f"{'N':>6} {'env ns':>9} {'plant ns':>9} {'env/plant':>10} {'load':>5}")
    for n in sizes:
        env = handling_course(n)
        env()   # compile and warm; the plant copies the cars after this step
        plant = plant_like(env)
        plant()
        ratios, envs, plants = [], [], []
        for _ in range(REPEATS):
            e = cpu_ns_per_call(env) / n
            p = cpu_ns_per_call(plant) / n
            envs.append(e)
            plants.append(p)
            ratios.append(e / p)
        print(f"{n:>6} {np.median(envs):>9.0f} {np.median(plants):>9.0f} {np.median(ratios):>9.2f}x "
              f"{os.getloadavg()[0]:>5.1f}")
    print("target: env/plant <= 1.25x (median of the per-repeat ratios)")


def run_checkout(root: str, sizes: list[int]) -> dict[int, tuple[float, float, float]]:
    """One run of the checkout at ``root``'s copy of this script in a fresh process: N -> (env ns, plant ns,
    env/plant)."""
    script = os.path.join(root, "benchmarks", os.path.basename(__file__))
    env = {**os.environ, "PYTHONPATH": root}
    out = subprocess.run([sys.executable, script, *map(str, sizes)], env=env, cwd=root, capture_output=True,
                         text=True, check=True).stdout
    rows = re.findall(r"^\s*(\d+)\s+(\d+)\s+(\d+)\s+([\d.]+)x", out, re.MULTILINE)
    return {int(n): (float(e), float(p), float(r)) for n, e, p, r in rows}


def compare(other: str, sizes: list[int], runs: int) -> None:
    """This checkout against the one at ``other``: alternating fresh runs, medians over the runs."""
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    results: dict[str, list[dict[int, tuple[float, float, float]]]] = {here: [], other: []}
    for _ in range(runs):
        for root in (other, here):
            results[root].append(run_checkout(root, sizes))
    print(f"{runs} alternating runs each; load average {os.getloadavg()[0]:.1f} at the end")
    print(f"{'N':>6} {'checkout':<40} {'env ns':>9} {'plant ns':>9} {'env/plant':>10} {'per run':<30}")
    for n in sizes:
        for root in (other, here):
            e, p, r = (np.median([run[n][c] for run in results[root]]) for c in range(3))
            each = " ".join(f"{run[n][2]:.2f}" for run in results[root])
            print(f"{n:>6} {root[-40:]:<40} {e:>9.0f} {p:>9.0f} {r:>9.2f}x {each}")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line: car counts, and optionally another checkout to compare with."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("sizes", nargs="*", type=int, default=[256, 4096], help="car counts N (default 256 4096)")
    parser.add_argument("--against", metavar="DIR", help="another checkout, run alternating with this one")
    parser.add_argument("--runs", type=int, default=RUNS, help=f"fresh runs of each checkout with --against "
                                                               f"(default {RUNS})")
    return parser.parse_args(argv)


if __name__ == "__main__":
    options = parse_args()
    if options.against:
        compare(os.path.abspath(options.against), options.sizes, options.runs)
    else:
        main(options.sizes)
