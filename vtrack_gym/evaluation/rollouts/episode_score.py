"""Scoring one episode of a policy as the leaderboard does: its row (metrics, the env's verdict, the car, the track
content driven, the policy's fingerprint and preset) and its trace; and the policy factories of the baselines.

Used by ``benchmark`` (suites), ``entry_speed`` (the ISO 3888 search: each probe judged exactly as a row) and
``api.evaluate``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym

from vtrack_gym.evaluation.identity.env_identity import vehicle_label
from vtrack_gym.evaluation.identity.fingerprint import policy_hash
from vtrack_gym.evaluation.leaderboard.board import failure_reason
from vtrack_gym.evaluation.rollouts.episodes import Episode
from vtrack_gym.evaluation.rollouts.rollout import rollout
from vtrack_gym.evaluation.scoring.metrics import evaluate_trace
from vtrack_gym.evaluation.scoring.rows import ResultRow
from vtrack_gym.evaluation.scoring.trace import Trace
from vtrack_gym.tracks.sources import source_digest


def policy_preset(policy: Any) -> str:
    """Name of the baseline preset whose config ``policy`` runs ("default" first), "custom" for another config,
    "" for a policy without presets (an agent: its identity is the weights hash)."""
    cfg = getattr(policy, "config", None)
    names = getattr(type(policy), "preset_names", None)
    if cfg is None or names is None:
        return ""
    ordered = sorted(names(), key=lambda n: n != "default")
    for name in ordered:
        try:
            if type(policy).make_config(name) == cfg:
                return name
        except ValueError:  # a file preset that is missing or invalid
            continue
    return "custom"


def success_metrics(env: gym.Env) -> dict[str, float]:
    """The leaderboard figures of ``env``'s last episode computed by its scenario's success criterion
    (``envs.criteria``: ``cones_hit`` on a gated course, the ISO 4138 figures on the circle); empty for an env
    without criteria (another package's)."""
    figures = getattr(env.unwrapped, "success_metrics", None)
    return dict(figures()) if callable(figures) else {}


def latency_metrics(env: gym.Env) -> dict[str, float]:
    """Under compute latency (``envs.latency``), the episode's ``late_decision_share`` (0..1: decisions whose
    compute exceeded the control period) and ``max_latency_ms`` [ms]; empty when latency is off."""
    stats = getattr(env.unwrapped, "latency_stats", None)
    if not callable(stats):
        return {}
    found = stats()
    if found["latency"] == "off":
        return {}
    return {"late_decision_share": float(found["late_share"]), "max_latency_ms": 1e3 * found["max_latency_s"]}


def score_episode(name: str, policy: Any, env: gym.Env, ep: Episode, suite: str,
                  digest: str | None = None) -> tuple[ResultRow, Trace]:
    """Run ``policy`` for one episode on ``env`` (reset with ``ep``'s seed and options); its row and trace.

    The row's ``success`` is the env's verdict (the last info's ``"success"``; a row of an env without one is
    judged by completion, ``ResultRow.verdict``) and its metrics carry the success criterion's own figures
    (``success_metrics``).
    The row's ``options`` carry ``ep``'s reset options and the car (``vehicle_label(ep.vehicle)``, when not the
    default car), a control mode other than ``steer`` (``control``) and a plant numerics mode other than
    ``default`` (``env_config``), so cars and modes never mix on the
    leaderboard, and on a track file the SHA-256 of the bytes this env read
    and drove (``track_sha256``). Its ``policy_hash`` is ``digest`` if given, else the policy's fingerprint
    (``fingerprint.policy_hash`` in this env's observation layout) taken before the rollout (a policy that
    changes its attributes while driving keeps one
    hash)."""
    digest = digest or policy_hash(policy, env)
    trace = rollout(policy, env, seed=ep.seed, options=ep.options)
    trace.policy_id = name
    metrics = evaluate_trace(trace)
    metrics.update(success_metrics(env))
    metrics.update(latency_metrics(env))
    label = vehicle_label(ep.vehicle)
    options = dict(ep.options) if label is None else {**ep.options, "vehicle": label}
    if getattr(ep, "control", "steer") != "steer":   # control modes are different set-ups; steer rows unchanged
        options["control"] = ep.control
    if getattr(ep, "launch", "step") != "step":   # another reference from rest (envs.launch): ranked apart
        options["protocol"] = {**options.get("protocol", {}), "launch": ep.launch}
    if getattr(ep, "numerics", "default") != "default":   # the other plant kernel: recorded as env_identity does
        options["env_config"] = {**options.get("env_config", {}), "numerics": ep.numerics}
    driven = source_digest(tuple(getattr(env.unwrapped, "paths", ())))
    if driven is not None:   # a track file: the content this env read and drove (never the file's later state)
        options["track_sha256"] = driven
    row = ResultRow(suite=suite, env_id=ep.env_id, policy_id=name, policy_hash=digest, seed=ep.seed,
                    metrics=metrics, termination=trace.termination,
                    wall_time_per_step_s=trace.wall_time_per_step_s, options=options,
                    policy_preset=policy_preset(policy),
                    success=trace.success)
    if not row.verdict():  # the figures' legends name the reason
        trace.meta["failure_reason"] = failure_reason(trace.termination, metrics)
    return row, trace


@dataclass
class FactoryScorer:
    """``score_episode`` for the episodes of one policy factory in one run: the policy hash is taken once per
    identity (``fingerprint.policy_hash``'s ``seen``: a policy of the same class, declared identity, completely
    read state and observation layout as one fingerprinted before is not probed again). The rows are those of
    ``score_episode``."""

    seen: dict[str, str] = field(default_factory=dict)

    def __call__(self, name: str, policy: Any, env: gym.Env, ep: Episode, suite: str,
                 digest: str | None = None) -> tuple[ResultRow, Trace]:
        return score_episode(name, policy, env, ep, suite, digest or policy_hash(policy, env, self.seen))


def policy_factories(names: Sequence[str] | dict[str, Any] | None = None,
                     controls: set[str] | frozenset[str] = frozenset({"steer"}),
                     env_ids: Sequence[str] | None = None) -> dict[str, Any]:
    """``{policy id: make(env) -> policy}`` for every baseline (default presets) and shipped agent that drives
    episodes in the control modes ``controls`` of the envs ``env_ids`` (``resolve.default_policy_names``), or for
    ``names`` (policy specs, see ``vtrack_gym.baselines.resolve``; all checked before any is returned; a dict of
    factories built already, e.g. of user code, is returned as is).

    Ids are canonical (``resolve.canonical_spec``: ``lqr:default`` is ``lqr``); one policy named twice (also one
    agent file by two paths) is scored once, two different agents with one stem are two policies
    (``resolve.named_factories``)."""
    from vtrack_gym.baselines.resolve import canonical_spec, default_policy_names, named_factories, policy_factory

    if isinstance(names, dict):  # factories already built: {policy id: make(env) -> policy}
        return dict(names)
    specs = [str(n).strip() for n in names] if names else list(default_policy_names(controls, env_ids))
    return named_factories([(canonical_spec(spec), spec, policy_factory(spec)) for spec in specs])
