"""Both sides of the behaviour pins' tolerance (``tests/env_fingerprint.py``): last-bit noise in the plant passes,
a relative 1e-6 change of any vehicle parameter or speed-loop gain the pinned episodes exercise fails."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator

import numpy as np
import pytest
from env_fingerprint import mismatches, record

from vtrack_gym.envs.pdflc import PDFLCConfig
from vtrack_gym.envs.sim import BatchSim
from vtrack_gym.vehicle.params import VehicleParams

NOISE_IDS = ("LateralTracking-v0", "DLC120-v0", "vtrack/Slalom-v1", "vtrack/ISO4138-Circle-v0",
             "vtrack/TrainingMix-v0")
"""Ids the noise side runs on: a long follow, cone gates, a planned line, circle metrics, a bank of tracks."""
CHANGE_IDS = ("LateralTracking-v0", "DLC120-v0")
"""Ids the change side runs on: between them they exercise every parameter but ``NOT_EXERCISED``."""
NOT_EXERCISED = {"vehicle.chassis.body_width_m", "vehicle.chassis.body_length_m",
                 "vehicle.chassis.cg_to_front_end_m", "vehicle.brakes.max_pedal_force_n"}
"""Parameters whose 1e-6 change moves these pinned episodes by less than the noise (the body outline only judges
gates; the pedal force never reaches its clip): no pin can tell them, and none should."""
CHANGE = 1e-6


def _perturbed_kernel(original, relative: float, every_step: bool):
    """``BatchSim._run_kernel`` followed by a perturbation of every plant state entry by ``relative`` with a fixed
    pseudo-random sign per entry: after the first step of an episode only, or after every step."""
    rng = np.random.default_rng(12)

    def run(self: BatchSim) -> None:
        original(self)
        if every_step or self.steps[0] == 0:
            state = self.plant.state
            state *= 1.0 + relative * rng.choice((-1.0, 1.0), state.shape)

    return run


@pytest.mark.parametrize(("relative", "every_step"),
                         [(1e-12, False), pytest.param(1e-15, True, marks=pytest.mark.slow)])
@pytest.mark.parametrize("env_id", NOISE_IDS)
def test_last_bit_noise_in_the_plant_passes(env_id: str, relative: float, every_step: bool,
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    """A relative 1e-12 error of the plant's output at the first step; 1e-15 (about five units in the last place)
    of every state entry at every step."""
    exact = record(env_id)
    monkeypatch.setattr(BatchSim, "_run_kernel", _perturbed_kernel(BatchSim._run_kernel, relative, every_step))
    noisy = record(env_id)
    assert any(not np.array_equal(a.sums, b.sums) for a, b in zip(exact, noisy, strict=True)), "no noise applied"
    assert mismatches(env_id, noisy) == []


def _changes() -> Iterator[tuple[str, dict]]:
    """(name, gym.make keyword) for every non-zero float field of the vehicle and the PD-FLC, times 1 + 1e-6
    (a field at its upper bound is changed by 1 - 1e-6)."""
    vehicle, speed = VehicleParams(), PDFLCConfig()
    for group in (f.name for f in dataclasses.fields(vehicle) if dataclasses.is_dataclass(getattr(vehicle, f.name))):
        part = getattr(vehicle, group)
        for name, changed in _changed_fields(part):
            yield f"vehicle.{group}.{name}", {"vehicle": dataclasses.replace(vehicle, **{group: changed})}
    for name, changed in _changed_fields(speed):
        yield f"speed_controller.{name}", {"speed_controller": changed}


def _changed_fields(obj) -> Iterator[tuple[str, object]]:
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if isinstance(value, float) and value != 0.0:
            try:
                yield f.name, dataclasses.replace(obj, **{f.name: value * (1.0 + CHANGE)})
            except ValueError:  # at its upper bound
                yield f.name, dataclasses.replace(obj, **{f.name: value * (1.0 - CHANGE)})


CHANGES = dict(_changes())
FAST_CHANGES = {"vehicle.chassis.mass_kg", "vehicle.tyres.front_cornering_stiffness_npr",
                "vehicle.steering.steering_ratio", "vehicle.low_speed.load_transfer_lag_s", "speed_controller.g4",
                "speed_controller.tau_f_s", "vehicle.chassis.body_length_m"}
"""The changes the fast tier tries (the weakest-coupled ones among them); the slow tier tries every one."""


def test_the_change_side_covers_every_parameter() -> None:
    assert len(CHANGES) >= 45, sorted(CHANGES)
    assert NOT_EXERCISED <= set(CHANGES) and FAST_CHANGES <= set(CHANGES)


@pytest.mark.parametrize("name", [n if n in FAST_CHANGES else pytest.param(n, marks=pytest.mark.slow)
                                  for n in sorted(CHANGES)])
def test_a_1e_6_change_of_a_parameter_fails(name: str) -> None:
    caught = [env_id for env_id in CHANGE_IDS if mismatches(env_id, record(env_id, **CHANGES[name]))]
    if name in NOT_EXERCISED:
        assert not caught, f"{name} is exercised now: take it off NOT_EXERCISED"
    else:
        assert caught, f"a relative {CHANGE} change of {name} passes the pins of {CHANGE_IDS}"


def test_a_signal_added_later_is_not_pinned_and_a_missing_one_fails() -> None:
    episodes = record("DLC120-v0")
    grown = [dataclasses.replace(ep, signals=[*ep.signals, "new_signal"], float32=np.append(ep.float32, False),
                                 sums=np.column_stack((ep.sums, ep.sums[:, 0])),
                                 abs_sums=np.column_stack((ep.abs_sums, ep.abs_sums[:, 0]))) for ep in episodes]
    assert mismatches("DLC120-v0", grown) == []
    shrunk = [dataclasses.replace(ep, signals=ep.signals[:-1], float32=ep.float32[:-1], sums=ep.sums[:, :-1],
                                  abs_sums=ep.abs_sums[:, :-1]) for ep in episodes]
    assert any("pinned signals missing" in m for m in mismatches("DLC120-v0", shrunk))


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_a_non_finite_sum_on_one_side_fails(bad: float) -> None:
    """A block sum that became NaN or infinite where the pin is finite is a mismatch (the relative excess is NaN
    there and must not pass as 'not above the tolerance'); the same infinity on both sides matches."""
    episodes = record("DLC120-v0")
    broken = [dataclasses.replace(ep, sums=ep.sums.copy()) for ep in episodes]
    broken[0].sums[0, 0] = bad
    assert any(broken[0].signals[0] in m for m in mismatches("DLC120-v0", broken))
    from pin_compare import block_mismatches
    both = dataclasses.replace(episodes[0], sums=episodes[0].sums.copy())
    both.sums[0, 0] = np.inf
    assert block_mismatches(both, both.sums.copy()) == []
