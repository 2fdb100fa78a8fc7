"""Regenerates the table of ``docs/performance.md``: every row measured in one run, as CPU time.

Each row is a rate of ours and, where there is one, of a peer measured in the same run (highway-env, Gymnasium,
the numpy reference path). Rates are work per second of the process's CPU time (all its threads), so they hold on
a loaded machine; ours and the peer alternate (ours first, then the peer first) for ``--rounds`` rounds, so a
change of load hits both alike. The page gives the median over the rounds with their range, and the range of the
1-minute load average read after each measurement. Rows whose kernels run on several threads (N >= 128 cars, the GA
rollout) also give the wall-clock rate, marked: that figure needs a free core per thread.
The section on worker processes (``benchmarks/bench_workers.py``) is kept as it is.

    PYTHONPATH=. python benchmarks/performance_page.py [--rounds 3] [--seconds 0.5] [--out docs/performance.md]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

PAGE = Path(__file__).resolve().parents[1] / "docs" / "performance.md"
KEPT_SECTION = "## Episodes in worker processes"
POPULATION_STEPS = 1000


@dataclass(frozen=True)
class Rate:
    """One measurement: work per CPU second and per wall second, and the 1-minute load average after it."""

    cpu: float
    wall: float
    load: float


@dataclass
class Row:
    """A page row: what is measured, ours and the peer (None: no peer), the unit, whether the figure is threaded."""

    what: str
    unit: str
    ours: Callable[[], Rate]
    peer_name: str = ""
    peer: Callable[[], Rate] | None = None
    threaded: bool = False
    lower_is_better: bool = False
    results: list[tuple[Rate, Rate | None]] = field(default_factory=list)


def measure(fn: Callable[[], object], work: float, seconds: float) -> Rate:
    """Call ``fn`` (after one warm-up call) until it has used ``seconds`` of CPU time; its work per CPU second and
    per wall second."""
    fn()
    calls, cpu0, wall0 = 0, time.process_time(), time.perf_counter()
    while True:
        fn()
        calls += 1
        cpu = time.process_time() - cpu0
        if cpu >= seconds:
            break
    wall = time.perf_counter() - wall0
    return Rate(calls * work / cpu, calls * work / wall, os.getloadavg()[0])


def import_cpu_s(module: str) -> Rate:
    """CPU seconds of ``import module`` in a fresh interpreter (best of 3), as a Rate (cpu = wall = seconds)."""
    code = f"import time; t = time.process_time(); import {module}; print(time.process_time() - t)"
    best = min(float(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout)
               for _ in range(3))
    return Rate(best, best, os.getloadavg()[0])


def single_env(env_id: str, seconds: float, module: str = "vtrack_gym") -> Callable[[], Rate]:
    """Steps of one env ``env_id`` (registered by importing ``module``) with small random steering actions."""

    def run() -> Rate:
        import importlib

        import gymnasium as gym

        importlib.import_module(module)
        env = gym.make(env_id)
        env.reset(seed=0)
        actions = np.random.default_rng(0).uniform(-0.05, 0.05, (4096, 1)).astype(np.float32)
        k = [0]

        def one() -> None:
            _, _, term, trunc, _ = env.step(actions[k[0] % 4096])
            k[0] += 1
            if term or trunc:
                env.reset()

        return measure(one, 1, seconds)

    return run


def vector_env(env_id: str, n: int, seconds: float) -> Callable[[], Rate]:
    def run() -> Rate:
        import gymnasium as gym

        import vtrack_gym  # noqa: F401

        envs = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point")
        envs.reset(seed=0)
        actions = envs.action_space.sample()
        actions = actions * 0.05 if actions.dtype.kind == "f" else actions
        return measure(lambda: envs.step(actions), n, seconds)

    return run


def plant(n: int, seconds: float) -> Callable[[], Rate]:
    def run() -> Rate:
        from vtrack_gym.vehicle.plant import Plant

        p = Plant(n=n)
        rng = np.random.default_rng(0)
        p.state[:, 3] = rng.uniform(5.0, 30.0, n)
        inputs = np.column_stack([rng.uniform(-0.05, 0.05, n), np.full(n, 0.2), np.zeros(n)])
        return measure(lambda: p.step(inputs, 5), n * 5, seconds)

    return run


def highway_bicycle(seconds: float) -> Rate:
    from highway_env.road.road import Road, RoadNetwork
    from highway_env.vehicle.dynamics import BicycleVehicle

    road = Road(RoadNetwork.straight_road_network(), np_random=np.random.default_rng(0))
    vehicle = BicycleVehicle(road, [0.0, 0.0], speed=10.0)
    vehicle.act({"steering": 0.01, "acceleration": 0.0})
    return measure(lambda: vehicle.step(0.002), 1, seconds)


def population(controller: str, size: int, compiled: bool, seconds: float) -> Callable[[], Rate]:
    def run() -> Rate:
        from vtrack_gym.tuning.population import PopulationEvaluator
        from vtrack_gym.tuning.spaces import search_space

        space = search_space(controller, {"smc": "steering", "mpc": "paper"}[controller])
        x = np.random.default_rng(0).uniform(space.lower, space.upper, size=(size, len(space.params)))
        ev = PopulationEvaluator(space, max_steps=POPULATION_STEPS, compiled=compiled)
        ev(x[:2])
        before, cpu0, wall0 = ev.car_steps, time.process_time(), time.perf_counter()
        while time.process_time() - cpu0 < seconds:
            ev(x)
        cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
        return Rate((ev.car_steps - before) / cpu, (ev.car_steps - before) / wall, os.getloadavg()[0])

    return run


def nmpc_decisions(preset: str, seconds: float) -> Callable[[], Rate]:
    """The NMPC's decisions per CPU second (feedback and preparation) over the first 300 observations of a
    closed-loop DLC120-v0 episode, replayed in order with the policy's own memory."""
    def run() -> Rate:
        import gymnasium as gym

        from vtrack_gym.baselines.nmpc import NMPC

        env = gym.make("DLC120-v0")
        driver = NMPC.from_env(env)
        obs, _ = env.reset(seed=0)
        observations = []
        for _ in range(300):
            observations.append(obs)
            obs, *_ = env.step(driver.predict(obs)[0])
        policy = NMPC.from_env(env, preset)

        def episode() -> None:
            policy.reset()
            for o in observations:
                policy.predict(o)

        return measure(episode, len(observations), seconds)

    return run


def rows(seconds: float) -> list[Row]:
    """The page's rows, in its order."""
    return [
        Row("single env `LateralTracking-v0`, gym.make, random actions", "steps/s",
            single_env("LateralTracking-v0", seconds), "highway-env `lane-keeping-v0`",
            single_env("lane-keeping-v0", seconds, "highway_env")),
        Row("plant, N = 1 (physics steps/s)", "steps/s", plant(1, seconds), "highway-env `BicycleVehicle.step`",
            lambda: highway_bicycle(seconds)),
        Row("plant, N = 4096 (vehicle-steps/s)", "steps/s", plant(4096, seconds), threaded=True),
        Row("vector env N = 4096 (env-steps/s)", "steps/s", vector_env("LateralTracking-v0", 4096, seconds),
            "Gymnasium vector CartPole", vector_env("CartPole-v1", 4096, seconds), threaded=True),
        Row("`import vtrack_gym` (CPU seconds, fresh interpreter)", "s", lambda: import_cpu_s("vtrack_gym"),
            "`import highway_env`", lambda: import_cpu_s("highway_env"), lower_is_better=True),
        Row(f"GA population rollout, SMC, 10 cars, {POPULATION_STEPS} steps (car-steps/s)", "steps/s",
            population("smc", 10, True, seconds), "step-by-step numpy reference path",
            population("smc", 10, False, seconds), threaded=True),
        Row(f"GA population rollout, MPC, 20 cars, {POPULATION_STEPS} steps (car-steps/s)", "steps/s",
            population("mpc", 20, True, seconds), "step-by-step numpy reference path",
            population("mpc", 20, False, seconds), threaded=True),
        Row("`nmpc` decisions, DLC120-v0 observations (decisions/s, feedback and preparation)", "decisions/s",
            nmpc_decisions("default", seconds), "`nmpc` preset `casadi` (CasADi, qpOASES)",
            nmpc_decisions("casadi", seconds)),
    ]


def fmt(value: float, unit: str) -> str:
    """``49.9k`` / ``1.08M`` for a rate, ``0.13 s`` for seconds."""
    if unit == "s":
        return f"{value:.2f} s"
    for scale, suffix in ((1e6, "M"), (1e3, "k")):
        if value >= scale:
            return f"{value / scale:.3g}{suffix}"
    return f"{value:.3g}"


def span(values: list[float], show: Callable[[float], str]) -> str:
    """The median of ``values`` and their range, as shown: ``median (lo-hi)`` (one figure when all show alike)."""
    mid, lo, hi = show(float(np.median(values))), show(min(values)), show(max(values))
    return mid if lo == hi else f"{mid} ({lo}-{hi})"


def table_line(row: Row) -> str:
    """The markdown line of a measured row."""
    ours = [r for r, _ in row.results]
    cell = span([r.cpu for r in ours], lambda v: fmt(v, row.unit))
    if row.threaded:
        cell += f"; wall {span([r.wall for r in ours], lambda v: fmt(v, row.unit))} (needs free cores)"
    loads = [r.load for r, _ in row.results] + [p.load for _, p in row.results if p is not None]
    load = f"{min(loads):.1f}-{max(loads):.1f}"
    if row.peer is None:
        return f"| {row.what} | {cell} | | | {load} |"
    peers = [p.cpu for _, p in row.results if p is not None]
    ratios = [(p.cpu / r.cpu if row.lower_is_better else r.cpu / p.cpu) for r, p in row.results if p is not None]
    peer = f"{row.peer_name} {span(peers, lambda v: fmt(v, row.unit))}"
    ratio = span(ratios, lambda v: f"{v:.2g}x")
    return f"| {row.what} | {cell} | {peer} | {ratio} | {load} |"


def page(measured: list[Row], rounds: int, seconds: float, kept: str) -> str:
    """The whole page: the measured table, how it was measured, and the kept section."""
    lines = [
        "# Performance (benchmarks/, ratios against a peer measured in the same run)", "",
        "Rates are work per second of CPU time (all the process's threads), ours and the peer alternating in one run,",
        "so they hold on a shared machine; each cell is the median over the rounds with their range in brackets, and",
        "the last column the range of the 1-minute load average read after each measurement. A ratio compares ours",
        "with the peer of the same round. Rows whose kernels run",
        "on several threads (N >= 128 cars, the GA rollout) also give their wall-clock rate: that figure needs a free",
        "core per thread and is only as good as the machine was idle.", "",
        "| what | ours, per CPU second | peer, same run | ratio | load average |", "|---|---|---|---|---|",
        *(table_line(row) for row in measured), "",
        f"Made with `PYTHONPATH=. python benchmarks/performance_page.py --rounds {rounds} --seconds {seconds:g}` "
        f"({rounds} rounds, {seconds:g} s of CPU time per figure) on a {os.cpu_count()}-core machine with Python "
        f"{sys.version.split()[0]}. The import row is CPU seconds of `import` in a fresh interpreter (best of three; "
        "lower is better, the ratio is the peer's time over ours). The GA rows run one population on the first "
        f"{POPULATION_STEPS} steps of Case 1 with the compiled whole-episode rollout and with the reference path "
        "(the same compiled laws through `Policy.act`, one control period at a time). Longer runs: "
        "`python benchmarks/bench_tuning.py` (the paper budgets end to end), `python benchmarks/bench_policies.py` "
        "(predict cost per policy), `python benchmarks/bench_evaluation.py` (a full 215 s `LateralTracking-v0` lap).",
        "",
    ]
    return "\n".join(lines) + "\n" + kept


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3, help="alternating rounds (default: 3)")
    parser.add_argument("--seconds", type=float, default=0.5, help="CPU seconds per figure (default: 0.5)")
    parser.add_argument("--out", type=Path, default=PAGE, help="the page to write (default: docs/performance.md)")
    args = parser.parse_args(argv)
    text = PAGE.read_text(encoding="utf-8")
    kept = text[text.index(KEPT_SECTION):] if KEPT_SECTION in text else ""
    measured = rows(args.seconds)
    for k in range(args.rounds):
        for row in measured:
            if k % 2 and row.peer is not None:  # odd rounds measure the peer first
                peer, ours = row.peer(), row.ours()
            else:
                ours, peer = row.ours(), row.peer() if row.peer is not None else None
            row.results.append((ours, peer))
            print(f"round {k + 1}: {row.what}: {ours}; peer {peer}", flush=True)
    args.out.write_text(page(measured, args.rounds, args.seconds, kept), encoding="utf-8")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
