"""This machine's vector throughputs, measured, and the fast plant's all-SIMD bound recomputed from them.

Each operation kind of the bound (``bench_fast_plant.simd_bound``) is timed in a compiled loop over N = 4096 float64
elements that LLVM vectorises (no fast-math, as the kernels): per element, 8 independent chains of ``ROUNDS``
operations (mul: y * m, add: y + m, div: m / y, sqrt: sqrt(y); min/max: (y if y > m else m) + m, less the
add's time), so the vector units, not latency or memory, set the pace; loads: ``PASSES`` passes of the sum of 8
arrays plus the pass number, less its 8 adds; stores: ``PASSES`` copies plus the pass number, less its load and
add (the arrays stay in the L1 cache). CPU time per element-operation (``time.process_time``, median of
``REPEATS``) is converted to cycles per 256-bit instruction (4 doubles) at the clock measured by a chain of
dependent adds
(``bench_fast_plant.cpu_clock_ghz``). Blend, logic, move and round are not timed (they issue on any of the 4 FP
pipes; their table value is kept). The maths library's exp, sin, cos, atan2 (what the default plant calls) are
timed per element alone, for reference.

The bound is then recomputed with these throughputs from the fast kernel's machine code, and the fast plant is timed
at N = 4096 beside it (``bench_fast_plant``'s rounds, alternating with nothing: CPU time, median), with the load
average. Run: ``python benchmarks/bench_simd_ops.py``.
"""

from __future__ import annotations

import os
import statistics
import sys
import time
from collections.abc import Callable

import numpy as np

N = 4096
ROUNDS = 16
CHAINS = 8
REPEATS = 5
PASSES = 32   # of the load and store loops per call
MIN_CPU_S = 0.2


def _chains(op: Callable[[float, float], float]) -> Callable:
    """A compiled loop applying ``op(y, m)`` ``ROUNDS`` times to ``CHAINS`` independent values per element."""
    import numba

    op = numba.njit(inline="always")(op)

    @numba.njit(inline="always")
    def rounds(y: float, m: float) -> float:   # ROUNDS = 16 applications, written out (no inner loop to vectorise)
        for_4 = op(op(op(op(y, m), m), m), m)
        for_8 = op(op(op(op(for_4, m), m), m), m)
        for_12 = op(op(op(op(for_8, m), m), m), m)
        return op(op(op(op(for_12, m), m), m), m)

    @numba.njit(error_model="numpy", _nrt=False)
    def loop(a: np.ndarray, out: np.ndarray) -> None:
        for i in range(a.shape[0]):
            m = a[i]
            y0, y1, y2, y3 = rounds(m + 0.1, m), rounds(m + 0.2, m), rounds(m + 0.3, m), rounds(m + 0.4, m)
            y4, y5, y6, y7 = rounds(m + 0.5, m), rounds(m + 0.6, m), rounds(m + 0.7, m), rounds(m + 0.8, m)
            out[i] = ((y0 + y1) + (y2 + y3)) + ((y4 + y5) + (y6 + y7))
    return loop


def _kernels() -> dict[str, tuple[Callable, int]]:
    """name -> (compiled loop(arrays, out), operations of that name per element)."""
    import math

    import numba

    @numba.njit(error_model="numpy", _nrt=False)
    def load8(a, b, c, d, e, f, g, h, out):
        for p in range(PASSES):   # passes over the same arrays: the call's overhead spread over them
            for i in range(out.shape[0]):
                out[i] = ((a[i] + b[i]) + (c[i] + d[i])) + ((e[i] + f[i]) + (g[i] + h[i])) + p

    @numba.njit(error_model="numpy", _nrt=False)
    def copy(a, out):
        for p in range(PASSES):
            for i in range(out.shape[0]):
                out[i] = a[i] + p

    def lib(fn):
        @numba.njit(error_model="numpy", _nrt=False)
        def loop(a, out):
            for i in range(out.shape[0]):
                out[i] = fn(a[i])
        return loop

    @numba.njit(error_model="numpy", _nrt=False)
    def atan2(a, out):
        for i in range(out.shape[0]):
            out[i] = math.atan2(a[i], 1.5 - a[i])

    ops = CHAINS * ROUNDS
    return {
        "mul": (_chains(lambda y, m: y * m), ops), "add": (_chains(lambda y, m: y + m), ops),
        "max+add": (_chains(lambda y, m: (y if y > m else m) + m), ops), "div": (_chains(lambda y, m: m / y), ops),
        "sqrt": (_chains(lambda y, m: math.sqrt(y)), ops), "load8": (load8, 8 * PASSES), "copy": (copy, PASSES),
        "exp": (lib(math.exp), 1), "sin": (lib(math.sin), 1), "cos": (lib(math.cos), 1), "atan2": (atan2, 1),
    }


def _ns_per_op(fn: Callable, args: tuple, per_element: int) -> float:
    """CPU ns per element-operation of ``fn(*args)`` (median of ``REPEATS``, each over >= ``MIN_CPU_S``)."""
    fn(*args)
    out = []
    for _ in range(REPEATS):
        calls, start = 0, time.process_time()
        while time.process_time() - start < MIN_CPU_S:
            fn(*args)
            calls += 1
        out.append(1e9 * (time.process_time() - start) / (calls * N * per_element))
    return statistics.median(out)


def measured_throughputs(ghz: float) -> tuple[dict[str, float], dict[str, float]]:
    """(cycles per 256-bit instruction of each timed kind, ns per element of every loop)."""
    rng = np.random.default_rng(0)
    arrays = [rng.uniform(0.999, 1.001, N) for _ in range(8)]
    out = np.empty(N)
    ns = {}
    for name, (fn, per) in _kernels().items():
        args = (*arrays, out) if name == "load8" else (arrays[0], out)
        ns[name] = _ns_per_op(fn, args, per)
    cyc = {k: 4.0 * v * ghz for k, v in ns.items()}   # 4 doubles per 256-bit instruction
    load = max(cyc["load8"] - cyc["add"], 0.0)   # per load: 8 adds per 8 loads
    cycles = {"mul": cyc["mul"], "fma": cyc["mul"], "add": cyc["add"], "compare": cyc["max+add"] - cyc["add"],
              "minmax": cyc["max+add"] - cyc["add"], "div": cyc["div"], "sqrt": cyc["sqrt"], "load": load,
              "store": max(cyc["copy"] - load - cyc["add"], 0.0)}
    return cycles, ns


def main() -> None:
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import numba
    from bench_fast_plant import N_SUB, ZEN4_THROUGHPUT, _plant, _round, bound_cycles, cpu_clock_ghz, simd_bound

    numba.set_num_threads(1)
    print(f"load average (1, 5, 15 min): {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    ghz = cpu_clock_ghz()
    cycles, ns = measured_throughputs(ghz)
    print(f"core clock (dependent-add chain): {ghz:.2f} GHz; N = {N}, one thread, CPU time")
    print("ns per element and operation: " + ", ".join(f"{k} {v:.3f}" for k, v in ns.items()))
    print(f"{'kind':>8} {'measured':>9} {'table':>6}  (cycles per 256-bit instruction)")
    for kind, c in cycles.items():
        print(f"{kind:>8} {c:>9.2f} {ZEN4_THROUGHPUT[kind][0]:>6.2f}")
    table = {k: (cycles.get(k, c), group) for k, (c, group) in ZEN4_THROUGHPUT.items()}
    bound, per_car, loops = simd_bound(ghz, table)
    os.environ["VTRACK_PARALLEL_MIN_N"] = str(10 * N)
    plant, inputs = _plant(N, "fast")
    plant.step(inputs, N_SUB)
    fast = statistics.median(_round(plant, inputs, 0.3)[0] for _ in range(5))
    print(f"all-SIMD bound from the measured throughputs: {bound:.1f} ns per car-step ({bound * ghz:.0f} cycles; "
          f"{loops} vector loops); table values: {bound_cycles(per_car, ZEN4_THROUGHPUT) / ghz:.1f} ns")
    print("256-bit vector instructions per car-step: "
          + ", ".join(f"{k} {v:.1f}" for k, v in sorted(per_car.items(), key=lambda kv: -kv[1])))
    print(f"fast plant at N = {N}: {fast:.1f} ns per car-step (CPU, median of 5); bound / fast = {bound / fast:.0%}")
    print(f"load average after: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")


if __name__ == "__main__":
    main()
