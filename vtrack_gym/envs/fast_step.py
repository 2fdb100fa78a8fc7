"""The env step of ``numerics="fast"``: the per-car env code of ``envs.kernels.step_car`` around the SIMD plant.

``step_car`` steps one car at a time (speed loop, physics, projection, ...). Here the control period runs in three
passes: the pedals of every car (the speed loop or the longitudinal demand), the physics of all cars by
``vehicle.fast_kernels`` (blocks of cars, vectorised), then the projection, observation, termination, reward and
signals of every car by ``envs.kernels``'s own functions. The first and last passes do what ``step_car`` does
before and after its ``step_vehicle`` call, in the same order, so a fast env differs from the default one only
by the plant's numerics (``tests/test_fast_numerics.py`` bounds the difference over closed-loop episodes).
"""

from __future__ import annotations

from vtrack_gym._jit import kernel, prange
from vtrack_gym.envs.kernels import (
    CAR_PREV_ACTION,
    CAR_REWARD,
    CAR_SCHEDULED,
    CAR_STEPS,
    CAR_V_REF,
    CFG_CONTROL,
    CFG_DT,
    CFG_NSUB,
    CFG_REWARD,
    E_EPHI,
    E_EV,
    E_EY,
    N_RW,
    N_TERMS,
    SIG_REWARD,
    SimArrays,
    is_released,
    observe_one,
    reward_one,
    set_pedals,
    termination_one,
    write_signals,
)
from vtrack_gym.vehicle import layout as L
from vtrack_gym.vehicle.fast_kernels import BLOCK, advance_block


@kernel(refcount=False)
def after_physics(i: int, a: SimArrays, released: bool) -> None:
    """Car ``i`` after its physics: target speed of a released car, step count, observation, termination, reward,
    signals (``released``: as before the physics)."""
    cfg, car, states = a.cfg, a.car, a.states
    n_sub = int(cfg[CFG_NSUB])
    if released:
        car[i, CAR_V_REF] = states[i, L.S_VX]
    car[i, CAR_STEPS] += 1.0
    travel = abs(states[i, L.S_VX]) * cfg[CFG_DT] * n_sub
    observe_one(i, a, a.outputs[i, n_sub - 1, L.O_AX], 5.0 + 3.0 * travel, False)
    code = termination_one(i, a)
    a.term[i] = code
    action = a.actions[i]
    car[i, CAR_REWARD] = reward_one(code, a.err[i, E_EY], a.err[i, E_EPHI], action, car[i, CAR_PREV_ACTION],
                                    cfg[CFG_REWARD:CFG_REWARD + N_RW], a.sig[i, SIG_REWARD:SIG_REWARD + N_TERMS],
                                    cfg[CFG_CONTROL] != 0.0, a.err[i, E_EV])
    car[i, CAR_PREV_ACTION] = action
    write_signals(i, a)


@kernel(refcount=False)
def physics_block(a: SimArrays, block: int) -> None:
    """The fast plant on block ``block`` of the cars (``vehicle.fast_kernels.advance_block``)."""
    advance_block(a.states, a.inputs, a.road, a.params, a.models, a.cfg[CFG_DT], int(a.cfg[CFG_NSUB]), a.outputs,
                  a.work, a.cmds, a.car, CAR_SCHEDULED, block)


@kernel(refcount=False)
def step_serial(a: SimArrays) -> None:
    """One control period for every car, single-threaded."""
    n = a.states.shape[0]
    for i in range(n):
        set_pedals(i, a)
    for b in range(-(-n // BLOCK)):
        physics_block(a, b)
    for i in range(n):
        after_physics(i, a, is_released(i, a))


@kernel(parallel=True, refcount=False)
def step_parallel(a: SimArrays) -> None:
    """One control period for every car, cars (and blocks of cars) spread over threads (same per-car code)."""
    n = a.states.shape[0]
    for i in prange(n):
        set_pedals(i, a)
    for b in prange(-(-n // BLOCK)):
        physics_block(a, b)
    for i in prange(n):
        after_physics(i, a, is_released(i, a))
