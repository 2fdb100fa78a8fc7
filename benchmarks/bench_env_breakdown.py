"""What an env step costs beyond a plant step, part by part: CPU time per car and control period, one thread.

Each part of ``BatchSim.step`` on the handling course (the cars at its target speed, as in
``bench_env_vs_plant.py``) is timed alone over all N cars on the state the env's first step left: the plant
(``step_vehicle``, 5 physics steps), the speed loop (PD-FLC), the projection onto the path (coarse search and
refinement), the rest of the observation (row at the projection, scalar fields, curvature preview, speed and time
errors, road inputs), termination, reward and the info signals, and the Python around the compiled step. The
parts run the env's own compiled functions on copies of its arrays (the state is not advanced, so every repeat
does the same work); their sum is set beside the whole step, and the difference is the interaction (caches, the
compiler's choices across the fused loop). CPU time (``time.process_time``) and the load average are printed.
Run: ``python benchmarks/bench_env_breakdown.py [N ...]`` (default N = 256 4096).
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable

import numpy as np

MIN_CPU_S = 0.3
REPEATS = 3


def cpu_ns(fn: Callable[[], object]) -> float:
    """Median over ``REPEATS`` of the CPU time of one call of ``fn`` [ns] (each over >= ``MIN_CPU_S``)."""
    out = []
    for _ in range(REPEATS):
        calls, start = 0, time.process_time()
        while True:
            fn()
            calls += 1
            spent = time.process_time() - start
            if spent >= MIN_CPU_S:
                break
        out.append(1e9 * spent / calls)
    return float(np.median(out))


def part_kernels() -> dict[str, Callable]:
    """The parts as compiled loops over all cars (the env's own inline functions, compiled as the env step is:
    without array reference counting)."""
    import math

    import numba

    from vtrack_gym.envs import kernels as k
    from vtrack_gym.envs.pdflc_kernel import pdflc_step
    from vtrack_gym.tracks.kernels import _locate as locate
    from vtrack_gym.tracks.kernels import curvature_preview, height_columns, lerp_column, plane_at, project_point
    from vtrack_gym.vehicle import layout as L
    from vtrack_gym.vehicle.kernels import step_vehicle

    @numba.njit(_nrt=False)
    def plant(a):
        dt, n_sub = a.cfg[k.CFG_DT], int(a.cfg[k.CFG_NSUB])
        for i in range(a.states.shape[0]):
            step_vehicle(a.states[i], a.inputs[i], a.road[i], a.params[i], a.models[i], dt, n_sub, a.outputs[i],
                         a.work[i])

    @numba.njit(_nrt=False)
    def pedals(a):
        for i in range(a.states.shape[0]):
            t, b = pdflc_step(a.states[i, L.S_VX], a.car[i, k.CAR_V_REF], a.pd_mem[i], a.pd_gains[i],
                              a.pd_surface, a.cfg[k.CFG_KINKS] != 0.0)
            a.inputs[i, L.U_THROTTLE] = t
            a.inputs[i, L.U_BRAKE] = b

    @numba.njit(_nrt=False)
    def projection(a):
        n_sub = int(a.cfg[k.CFG_NSUB])
        for i in range(a.states.shape[0]):
            tr = a.veh_track[i]
            start = int(a.tmeta[tr, k.TM_START])
            table = a.tables[start:start + int(a.tmeta[tr, k.TM_N])]
            window = 5.0 + 3.0 * abs(a.states[i, L.S_VX]) * a.cfg[k.CFG_DT] * n_sub
            a.err[i, k.E_S] = project_point(table, a.tmeta[tr, k.TM_DS], a.tmeta[tr, k.TM_LEN],
                                            a.tmeta[tr, k.TM_CLOSED] != 0.0, a.states[i, L.S_X], a.states[i, L.S_Y],
                                            a.car[i, k.CAR_S_PREV], window, k.C_COS)

    @numba.njit(_nrt=False)
    def row_at(a):
        for i in range(a.states.shape[0]):
            tr = a.veh_track[i]
            start = int(a.tmeta[tr, k.TM_START])
            table = a.tables[start:start + int(a.tmeta[tr, k.TM_N])]
            ds, length, closed = a.tmeta[tr, k.TM_DS], a.tmeta[tr, k.TM_LEN], a.tmeta[tr, k.TM_CLOSED] != 0.0
            j, t = locate(table.shape[0], ds, length, closed, a.car[i, k.CAR_S_PREV])
            x_r, y_r, psi_r, kappa = plane_at(table, j, t, ds, k.C_COS)
            dkappa, z, grade, zpp = height_columns(table, j, t, ds)
            a.err[i, k.E_EY] = x_r + y_r + psi_r + kappa + dkappa + z + grade + zpp
            a.err[i, k.E_WL] = lerp_column(table, j, t, k.C_WL)
            a.err[i, k.E_WR] = lerp_column(table, j, t, k.C_WR)

    @numba.njit(_nrt=False)
    def preview(a):
        n_prev, dt_prev = int(a.cfg[k.CFG_NPREV]), a.cfg[k.CFG_PREV_DT]
        for i in range(a.states.shape[0]):
            tr = a.veh_track[i]
            start = int(a.tmeta[tr, k.TM_START])
            table = a.tables[start:start + int(a.tmeta[tr, k.TM_N])]
            ds, length, closed = a.tmeta[tr, k.TM_DS], a.tmeta[tr, k.TM_LEN], a.tmeta[tr, k.TM_CLOSED] != 0.0
            s = a.car[i, k.CAR_S_PREV]
            v = max(a.states[i, L.S_VX], a.cfg[k.CFG_PREV_VMIN])
            curvature_preview(table, ds, length, closed, s, v, dt_prev, a.obs[i, k.O_PREVIEW:k.O_PREVIEW + n_prev],
                              a.scratch[i])

    @numba.njit(_nrt=False)
    def observe(a):
        n_sub = int(a.cfg[k.CFG_NSUB])
        for i in range(a.states.shape[0]):
            window = 5.0 + 3.0 * abs(a.states[i, L.S_VX]) * a.cfg[k.CFG_DT] * n_sub
            k.observe_one(i, a, a.outputs[i, n_sub - 1, L.O_AX], window, False)

    @numba.njit(_nrt=False)
    def time_err(a):
        for i in range(a.states.shape[0]):
            tr = a.veh_track[i]
            start = int(a.tmeta[tr, k.TM_START])
            table = a.tables[start:start + int(a.tmeta[tr, k.TM_N])]
            a.err[i, k.E_ET] = k.time_error(i, a, table, a.tmeta[tr, k.TM_DS], a.tmeta[tr, k.TM_LEN],
                                            a.tmeta[tr, k.TM_CLOSED] != 0.0)

    @numba.njit(_nrt=False)
    def termination(a):
        for i in range(a.states.shape[0]):
            a.term[i] = k.termination_one(i, a)

    @numba.njit(_nrt=False)
    def reward_signals(a):
        rw = a.cfg[k.CFG_REWARD:k.CFG_REWARD + k.N_RW]
        for i in range(a.states.shape[0]):
            a.car[i, k.CAR_REWARD] = k.reward_one(a.term[i], a.err[i, k.E_EY], a.err[i, k.E_EPHI], a.actions[i],
                                                  a.car[i, k.CAR_PREV_ACTION], rw,
                                                  a.sig[i, k.SIG_REWARD:k.SIG_REWARD + k.N_TERMS], False,
                                                  a.err[i, k.E_EV])
            k.write_signals(i, a)

    del math
    return {"plant": plant, "speed loop": pedals, "projection": projection, "row, widths": row_at,
            "curv. preview": preview, "time error": time_err, "observe (all)": observe, "termination": termination,
            "reward+signals": reward_signals}


def copy_bundle(a):
    """A deep copy of a ``SimArrays`` bundle (every array copied)."""
    return type(a)(*(np.array(x, copy=True) for x in a))


def run(n: int, parts: dict[str, Callable]) -> None:
    """Print the parts' CPU time per car at ``n`` cars."""
    sys.path.insert(0, os.path.dirname(__file__))
    from bench_env_vs_plant import handling_course

    step = handling_course(n)
    step()
    sim = step.sim  # type: ignore[attr-defined]
    whole = cpu_ns(step) / n
    kernel = cpu_ns(sim._run_kernel) / n
    print(f"N = {n}: whole env step {whole:.0f} ns, its compiled step {kernel:.0f} ns "
          f"(Python around it {whole - kernel:.0f} ns); load {os.getloadavg()[0]:.1f}")
    total = 0.0
    for name, fn in parts.items():
        a = copy_bundle(sim.arrays)
        fn(a)
        t = cpu_ns(lambda fn=fn, a=a: fn(a)) / n
        if name not in ("projection", "row, widths", "curv. preview", "time error"):
            total += t
        print(f"  {name:<16} {t:7.0f} ns")
    print(f"  {'sum of parts':<16} {total:7.0f} ns (sub-parts of observe not counted twice); "
          f"interaction {kernel - total:.0f} ns")


def main(sizes: list[int]) -> None:
    import numba

    numba.set_num_threads(1)
    parts = part_kernels()
    print("one thread; CPU time per car and control period (5 physics steps)")
    for n in sizes:
        run(n, parts)


if __name__ == "__main__":
    main([int(a) for a in sys.argv[1:]] or [256, 4096])
