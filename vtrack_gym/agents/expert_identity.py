"""Which expert labelled a DAgger run, by content: its ``policy_hash`` on the training env and the package version.

A registry name and preset (``lqr[default]``) do not pin an expert: a preset's pairing can change between package
versions (the longitudinal modes' speed law became ``pdflc_ff``), and two runs "of lqr[default]" then imitated
different controllers. The ``policy_hash`` (``evaluation.identity.fingerprint``) digests the expert's class,
config, state and actions on fixed probe observations in the training env's layout, so two experts that act
differently never share it; the package version says which code built the expert.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class ExpertIdentity:
    """A DAgger expert as a run records it (``as_dict`` in ``config.json``, ``text`` in the agent's description)."""

    label: str             # what the run asked for: registry name and preset, e.g. "lqr[default]"
    policy_hash: str       # policy_hash(expert, training env): 12 hex digits
    package_version: str   # vtrack_gym version that built the expert

    def as_dict(self) -> dict[str, str]:
        return dataclasses.asdict(self)

    def text(self) -> str:
        """``lqr[default] (policy_hash 0123456789ab, vtrack_gym 0.2.0)``: the expert in a description."""
        return f"{self.label} (policy_hash {self.policy_hash}, vtrack_gym {self.package_version})"


def expert_identity(expert: Any, env: Any, label: str) -> ExpertIdentity:
    """The identity of ``expert`` (the policy object that labels the states) taken on ``env``, the training env:
    a gym env or the native vector env (``TrackingSB3VecEnv.venv``), one with a vtrack observation layout, so the
    hash is the one ``policy_hash(make_policy(...), gym.make(env_id, ...))`` gives. ``label`` names what was asked
    for (``"lqr[default]"``). ``ValueError`` for an env without a vtrack observation layout (its probes would be
    sampled from the observation space of whatever wraps it)."""
    from vtrack_gym._version import __version__
    from vtrack_gym.evaluation.identity.fingerprint import policy_hash
    from vtrack_gym.evaluation.identity.probes import layout_names

    if env is None or layout_names(env) is None:
        raise ValueError(f"expert_identity needs the training env with its vtrack observation layout (got "
                         f"{type(env).__name__}; for a TrackingSB3VecEnv pass its .venv)")
    return ExpertIdentity(label=str(label), policy_hash=policy_hash(expert, env), package_version=__version__)
