"""The NMPC configs share their common fields (``baselines.nmpc_params``) and are still what they were: the same
fields in the same order with the same types, defaults and ranges, the same docstring and ``repr`` of every
preset, and the same declared identity that ``policy_hash`` reads (class and config values).
``tests/data/nmpc_config_identity.json`` was recorded from the configs as they were before they shared their
fields."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import gymnasium as gym
import pytest

import vtrack_gym
from vtrack_gym._ranges import describe
from vtrack_gym.baselines.nmpc import NMPC_PRESETS, NMPCConfig
from vtrack_gym.baselines.nmpc_coupled import CoupledNMPC, CoupledNMPCConfig
from vtrack_gym.baselines.nmpc_params import HorizonFields, PlantModelFields

RECORDED = json.loads((Path(__file__).parent / "data" / "nmpc_config_identity.json").read_text())
CONFIGS = {"NMPCConfig": (NMPCConfig, NMPC_PRESETS),
           "CoupledNMPCConfig": (CoupledNMPCConfig, CoupledNMPC.PRESETS)}


def _spec(cls: Any, presets: dict[str, Any]) -> dict[str, Any]:
    ranges = describe(cls)
    return {"fields": [[f.name, str(f.type), repr(f.default), ranges.get(f.name, "")]
                       for f in dataclasses.fields(cls)],
            "doc": cls.__doc__, "repr": {name: repr(cfg) for name, cfg in presets.items()}}


@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_fields_docstring_and_repr_are_the_recorded_ones(name: str) -> None:
    cls, presets = CONFIGS[name]
    assert _spec(cls, presets) == RECORDED["configs"][name]
    assert issubclass(cls, HorizonFields) and issubclass(cls, PlantModelFields)


def test_shared_fields_are_declared_once_and_checked_in_both() -> None:
    shared = {f.name for f in dataclasses.fields(NMPCConfig)} & {f.name for f in dataclasses.fields(CoupledNMPCConfig)}
    assert len(shared) == 17
    for name in shared:
        owners = {cls for cls in NMPCConfig.__mro__ + CoupledNMPCConfig.__mro__ if name in vars(cls).get(
            "__annotations__", {})}
        assert len(owners) == 1, name   # one group declares it
    for cls in (NMPCConfig, CoupledNMPCConfig):
        with pytest.raises(ValueError, match="horizon_steps"):
            cls(horizon_steps=4)
        assert cls(horizon_steps=20, stage_time_s=0.1).horizon_s == pytest.approx(2.0)


@pytest.mark.parametrize(("policy", "control"), [("nmpc", "steer"), ("nmpc_coupled", "steer_accel")])
def test_the_declared_identity_the_fingerprint_reads_is_the_recorded_one(policy: str, control: str) -> None:
    """What ``policy_hash`` reads of the config (the class and the config's values) is what it read before the
    fields were shared. The whole hash is not pinned: its probed actions come from an iterative solver whose last
    bits may differ on another machine (docs/GUARANTEES.md, policy identity)."""
    from vtrack_gym.evaluation.identity.fingerprint import identity_parts

    env = gym.make("DLC120-v0", control=control)
    parts = identity_parts(vtrack_gym.make_policy(policy, env))
    assert {"class": parts["class"], "config": parts["config"]} == RECORDED["identity_parts"][policy]
