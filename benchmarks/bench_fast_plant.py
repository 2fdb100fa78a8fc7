"""The ``fast`` plant against the default one: ns per car-step (CPU time) at N = 1, 64, 1024, 4096 on one thread,
and the fast kernel's fraction of its all-SIMD bound.

Timing: both plants step the same cars (speeds 5..30 m/s, steering +-0.05 rad, a fifth braking) in alternating
rounds (A, B, A, B, ...), each round at least ``--seconds`` of CPU time; the median over rounds is reported, CPU
time (``time.process_time``) beside wall time, with the load average. One thread: batches of every size use the
single-threaded kernels (``VTRACK_PARALLEL_MIN_N`` is set above the largest N before the plant is imported).

The all-SIMD bound (``simd_bound``): the fast kernel's stage loops are compiled afresh and their machine code
read; in each vector loop body the instructions are counted by kind (FMA, mul, add, compare, min/max, blend,
logic, move, round, div, sqrt, loads including memory operands, stores) and divided by the cars one pass
advances (8 per 512-bit pass, 4 per 256-bit). Each kind is charged its reciprocal throughput on this CPU
(``ZEN4_THROUGHPUT``: the whole core's cycles per 256-bit instruction, a 512-bit one counts as two; published
Zen 4 figures, which ``bench_simd_ops.py`` measures on this machine): the bound is the largest of each FP group's
cycles (FMA/mul on 2 pipes, add/compare/min/max on 2), the four FP pipes' occupancy (everything else issues on
any of them), the divider's (div, sqrt), the loads' and the stores', per car-step (the four stage loops), in ns
at the core clock measured by a chain of dependent float64 adds (3 cycles each). It assumes every instruction
issues at full throughput with no latency stall and no scalar remainder: a bound, not a prediction.

Run: ``python benchmarks/bench_fast_plant.py`` (``--seconds 0.3 --rounds 5`` by default).
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import time
from collections import Counter

import numpy as np

SIZES = (1, 64, 1024, 4096)
N_SUB = 5  # physics steps per call (one 10 ms control period at 500 Hz)
ZEN4_THROUGHPUT = {  # cycles per 256-bit instruction (reciprocal throughput), and the pipe group it issues to
    "fma": (0.5, "mul"), "mul": (0.5, "mul"), "add": (0.5, "add"), "compare": (0.5, "add"),
    "minmax": (0.5, "add"), "blend": (0.25, "any"), "logic": (0.25, "any"), "move": (0.25, "any"),
    "round": (0.5, "any"), "div": (5.0, "div"), "sqrt": (9.0, "div"), "load": (0.5, "load"), "store": (1.0, "store"),
}
_KINDS = (  # mnemonic prefix -> kind (first match); a memory source operand also counts as a load
    ("vfmadd", "fma"), ("vfmsub", "fma"), ("vfnmadd", "fma"), ("vfnmsub", "fma"), ("vmulpd", "mul"),
    ("vaddpd", "add"), ("vsubpd", "add"), ("vcmppd", "compare"), ("vmaxpd", "minmax"), ("vminpd", "minmax"),
    ("vblendm", "blend"), ("vdivpd", "div"), ("vsqrtpd", "sqrt"), ("vrndscalepd", "round"), ("vroundpd", "round"),
    ("vandpd", "logic"), ("vandnpd", "logic"), ("vorpd", "logic"), ("vxorpd", "logic"), ("vpternlog", "logic"),
    ("vmovapd", "move"), ("vmovupd", "move"), ("vbroadcastsd", "load"),
)
FADD_LATENCY_CYCLES = 3


def cpu_clock_ghz(adds: int = 50_000_000) -> float:
    """The core clock [GHz] from a chain of dependent float64 additions (``FADD_LATENCY_CYCLES`` each)."""
    import numba

    @numba.njit
    def chain(n: int) -> float:
        x = 0.0
        for _ in range(n):
            x = x + 1e-9
        return x

    chain(10)
    best = float("inf")
    for _ in range(3):
        start = time.process_time()
        chain(adds)
        best = min(best, time.process_time() - start)
    return FADD_LATENCY_CYCLES * adds / best / 1e9


def _loop_bodies(asm: str) -> list[list[str]]:
    """The instruction lines of each loop of ``asm`` that uses 512- or 256-bit registers (a label, then the lines
    up to a conditional jump back to it)."""
    lines = asm.splitlines()
    bodies = []
    for k, line in enumerate(lines):
        label = re.match(r"^(\.LBB\w+):", line)
        if label is None:
            continue
        for j in range(k + 1, len(lines)):
            jump = re.match(r"^\s+j\w+\s+(\.LBB\w+)", lines[j])
            if jump and jump.group(1) == label.group(1):
                body = [x for x in lines[k + 1:j] if x.startswith("\t") and not x.strip().startswith(".")]
                if sum("zmm" in x or "ymm" in x for x in body) > 100:
                    bodies.append(body)
                break
    return bodies


def _classify(body: list[str]) -> Counter:
    """256-bit instructions of one loop body by kind (a 512-bit one counts as two)."""
    ops: Counter = Counter()
    for line in body:
        parts = line.split(None, 1)
        if len(parts) < 2 or not ("zmm" in parts[1] or "ymm" in parts[1]):
            continue
        units = 2 if "zmm" in parts[1] else 1
        mnemonic = parts[0]
        kind = next((k for prefix, k in _KINDS if mnemonic.startswith(prefix)), None)
        memory = "(" in parts[1]
        if kind == "move" and memory:   # a load or a store
            kind = "store" if parts[1].rstrip().endswith(")") else "load"
        elif memory and kind not in (None, "load"):
            ops["load"] += units
        if kind is not None:
            ops[kind] += units
    return ops


PIPES = {"mul": 2, "add": 2, "any": 4}
"""FP pipes of each issue group (Zen 4: two FMA/multiply pipes, two add pipes; the rest on any of the four)."""


def simd_bound(ghz: float, table: dict[str, tuple[float, str]] | None = None) -> tuple[float, Counter, int]:
    """(ns per car-step of the all-SIMD bound, 256-bit instructions per car-step by kind, vector loops found).

    Counted in the machine code of the four stage loops (``rk4_block``): each pass of a 512-bit loop advances 8
    cars (``VECTOR_CARS``). ``table``: cycles per 256-bit instruction (the whole core's reciprocal throughput, all
    pipes of its group together) and issue group of each kind (default ``ZEN4_THROUGHPUT``;
    ``bench_simd_ops.py`` passes the ones it measured). The bound is the largest of: each group's cycles, the
    four FP pipes' occupancy (an instruction holds one pipe of its group for its throughput times the group's
    pipes), the divider's, the loads' and the stores' cycles."""
    table = ZEN4_THROUGHPUT if table is None else table
    import numba

    from vtrack_gym.vehicle import fast_kernels as fk

    # a fresh, uncached compilation with the kernel's own options (numba cannot inspect code loaded from its cache)
    options = {k: v for k, v in fk.rk4_block.targetoptions.items() if k not in ("nopython", "boundscheck")}
    fresh = numba.njit(**options)(fk.rk4_block.py_func)
    fresh(np.zeros(fk.ROWS * fk.BLOCK), 1, 0.002)
    bodies = _loop_bodies("\n".join(fresh.inspect_asm().values()))
    per_car: Counter = Counter()
    for body in bodies:
        cars = 8 if any("zmm" in x for x in body) else 4
        for kind, units in _classify(body).items():
            per_car[kind] += units / cars
    return bound_cycles(per_car, table) / ghz, per_car, len(bodies)


def bound_cycles(per_car: Counter, table: dict[str, tuple[float, str]]) -> float:
    """Cycles per car-step of the all-SIMD bound of ``per_car`` (256-bit instructions by kind) at ``table``'s
    throughputs (see ``simd_bound``)."""
    groups: Counter = Counter()
    for kind, units in per_car.items():
        cycles, group = table[kind]
        groups[group] += units * cycles
    fp = max(groups["mul"], groups["add"], sum(groups[g] * pipes for g, pipes in PIPES.items()) / 4)
    return max(fp, groups["div"], groups["load"], groups["store"])


def _plant(n: int, numerics: str):
    from vtrack_gym.vehicle.plant import Plant

    plant = Plant(n=n, numerics=numerics)
    rng = np.random.default_rng(0)
    plant.state[:, 3] = rng.uniform(5.0, 30.0, n)
    inputs = np.column_stack([rng.uniform(-0.05, 0.05, n), np.full(n, 0.2), np.zeros(n)])
    inputs[::5, 2] = 100.0
    return plant, inputs


def _round(plant, inputs, seconds: float) -> tuple[float, float]:
    """(CPU ns, wall ns) per car-step of ``plant`` over at least ``seconds`` of CPU time."""
    calls = 0
    cpu0, wall0 = time.process_time(), time.perf_counter()
    while time.process_time() - cpu0 < seconds:
        plant.step(inputs, N_SUB)
        calls += 1
    work = calls * plant.n * N_SUB
    return (time.process_time() - cpu0) / work * 1e9, (time.perf_counter() - wall0) / work * 1e9


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=0.3, help="CPU seconds per round and plant")
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    os.environ["VTRACK_PARALLEL_MIN_N"] = str(10 * max(SIZES))
    print(f"load average (1, 5, 15 min): {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    rows = []
    for n in SIZES:
        pair = {mode: _plant(n, mode) for mode in ("default", "fast")}
        for plant, inputs in pair.values():
            plant.step(inputs, N_SUB)  # compile / load the kernels
        times: dict[str, list[tuple[float, float]]] = {"default": [], "fast": []}
        for _ in range(args.rounds):
            for mode, (plant, inputs) in pair.items():
                times[mode].append(_round(plant, inputs, args.seconds))
        cpu = {m: statistics.median(t[0] for t in v) for m, v in times.items()}
        wall = {m: statistics.median(t[1] for t in v) for m, v in times.items()}
        rows.append((n, cpu, wall))
        print(f"N={n}: default {cpu['default']:.1f} ns, fast {cpu['fast']:.1f} ns (CPU, median)", flush=True)
    print(f"load average after the timing: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    ghz = cpu_clock_ghz()
    bound, per_car, loops = simd_bound(ghz)
    print(f"{'N':>5} {'default CPU ns':>15} {'fast CPU ns':>12} {'speed-up':>9} {'default wall':>13} "
          f"{'fast wall':>10} {'bound/fast':>11}")
    for n, cpu, wall in rows:
        print(f"{n:>5} {cpu['default']:>15.1f} {cpu['fast']:>12.1f} {cpu['default'] / cpu['fast']:>8.2f}x "
              f"{wall['default']:>13.1f} {wall['fast']:>10.1f} {bound / cpu['fast']:>10.0%}")
    print(f"core clock (dependent-add chain): {ghz:.2f} GHz")
    print(f"all-SIMD bound of the fast kernel: {bound:.1f} ns per car-step ({loops} vector loops in its machine code)")
    print("256-bit vector instructions per car-step: "
          + ", ".join(f"{k} {v:.1f}" for k, v in sorted(per_car.items(), key=lambda kv: -kv[1])))
    os.environ["VTRACK_PARALLEL_MIN_N"] = ""


if __name__ == "__main__":
    main()
