"""One resolver from a policy spec to a policy: what ``vtrack_gym.make_policy`` and the ``vtrack`` CLI use.

A spec is, in this order (names always win over files, so a file or directory in the working directory named
like a policy never shadows it):

* a baseline name (``registry.known_policies()``: the steering baselines and the race ones), default preset;
* ``name:preset`` for a baseline (``smc:paper``, ``mpc:hand``);
* a shipped agent name (``shipped.shipped_agents()``: the agent files in ``vtrack_gym/baselines/shipped``);
* a weights-only agent file path (``agent.json`` or ``agent.npz``; JSON + ``np.load(allow_pickle=False)``,
  no code runs);
* with ``trust_code=True`` only, ``module:Name`` of your own code (``vtrack_gym.baselines.user_code``): a class is
  built as ``Name.from_env(env, **policy_kwargs)`` when it defines ``from_env``, else ``Name(**policy_kwargs)``.

Anything else raises ``ValueError`` listing every valid name. Without ``trust_code`` user code is never imported:
pass your object to ``vtrack_gym.evaluate``, or ``trust_code=True`` (``vtrack eval --trust-code``).
"""

from __future__ import annotations

import logging
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vtrack_gym.baselines.registry import available_policies, known_policies
from vtrack_gym.baselines.registry import make_policy as make_baseline

AGENT_SUFFIXES = (".json", ".npz")
UNSAFE_SUFFIXES = (".zip", ".pkl", ".pickle", ".pt", ".pth")
_USER_SPEC = re.compile(r"[A-Za-z_][\w.]*:[A-Za-z_]\w*")
log = logging.getLogger(__name__)


def shipped_names() -> tuple[str, ...]:
    """Names of the shipped RL agents (trained and loadable)."""
    from vtrack_gym.baselines.shipped import shipped_agent_factories

    return tuple(shipped_agent_factories())


def policy_names() -> tuple[str, ...]:
    """Every policy name a spec may be: the baselines, then the shipped agents."""
    return (*known_policies(), *shipped_names())


def default_policy_names(controls: set[str] | frozenset[str] = frozenset({"steer"})) -> tuple[str, ...]:
    """The policies a run without a policy list scores on episodes in the control modes ``controls``: every
    baseline (each drives every mode) and every shipped agent that can drive all of them. A steering agent (one
    output) drives every mode (paired with the PD-FLC in the longitudinal ones); an agent that drives the pedals too
    (two outputs, e.g. ``bc_accel``) reads the speed error and cannot drive a ``steer`` episode."""
    from vtrack_gym.baselines.shipped import shipped_agent_factories

    agents = shipped_agent_factories()
    steer_only = [n for n, make in agents.items() if getattr(make(None), "action_dim", 1) == 1]
    both = [n for n in agents if n not in steer_only and "steer" not in controls]
    return (*available_policies(), *[n for n in agents if n in steer_only or n in both])


def _valid_text() -> str:
    return (f"valid: {', '.join(policy_names())} (a baseline may take :PRESET, e.g. smc:paper), or an agent file "
            "path (agent.json)")


def policy_factory(spec: str, preset: str | None = None, *, trust_code: bool = False,
                   policy_kwargs: Mapping[str, Any] | None = None) -> Callable[[Any], Any]:
    """``make(env) -> policy`` for ``spec`` (see the module docstring), checked now, before any env exists.

    ``preset`` (a baseline's preset) may also be given inside the spec as ``name:preset``, not both.
    ``trust_code``: allow ``module:Name`` (imports and runs that module); ``policy_kwargs``: keyword arguments of
    such a class or function (a user spec only).
    Raises ``ValueError`` for unknown names, presets, refused files, invalid agent files and user code without
    ``trust_code``.
    """
    if not isinstance(spec, str) or not spec.strip():
        raise ValueError(f"policy spec must be a non-empty string (got {spec!r}); {_valid_text()}")
    if is_user_spec(spec):
        if not trust_code:
            raise ValueError(f"policy {spec!r} names Python code (module:Name); importing it runs that code, so it "
                             "is done only with trust_code=True (CLI: --trust-code); or pass your policy object "
                             "to vtrack_gym.evaluate")
        if preset not in (None, "default"):
            raise ValueError(f"preset {preset!r} applies to the baselines, not to module:Name {spec!r}")
        from vtrack_gym.baselines.user_code import user_policy_factory

        return user_policy_factory(spec, policy_kwargs)
    if policy_kwargs:
        raise ValueError(f"policy_kwargs apply to a module:Name policy of your own code, not to {spec!r}")
    name, sep, spec_preset = spec.partition(":")
    baselines = known_policies()
    if sep and name in baselines:
        if preset not in (None, "default"):
            raise ValueError(f"policy {spec!r} names a preset; do not also pass preset={preset!r}")
        preset = spec_preset
    if name in baselines and (sep or spec in baselines):
        chosen = preset or "default"
        if chosen != "default" and chosen not in _presets(name):
            raise ValueError(f"unknown preset {chosen!r} of policy {name!r}; valid: {', '.join(_presets(name))}")
        return lambda env: make_baseline(name, env, preset=chosen)
    if preset not in (None, "default"):
        raise ValueError(f"preset {preset!r} applies to the baselines ({', '.join(baselines)}), not to {spec!r}")
    from vtrack_gym.baselines.shipped import shipped_agent_factories

    shipped = shipped_agent_factories()
    if spec in shipped:
        agent = shipped[spec](None)
        return lambda env: bind_agent(agent, env)
    if sep and not Path(spec).exists():
        raise ValueError(f"unknown policy {spec!r}; {_valid_text()}. A module:Class spec imports your code: pass "
                         "your policy object to vtrack_gym.evaluate, or use `vtrack eval --policy module:Class "
                         "--trust-code`")
    return _file_factory(spec)


def is_user_spec(spec: str) -> bool:
    """``spec`` has the form ``module:Name`` of user code: not a baseline with a preset, not an existing file."""
    module, sep, _ = spec.partition(":")
    return bool(sep) and module not in known_policies() and _USER_SPEC.fullmatch(spec) is not None \
        and not Path(spec).exists()


def canonical_spec(spec: str, preset: str | None = None) -> str:
    """The one policy id of a spec (what rows record): a baseline with its default preset is its bare name
    (``smc``, ``smc:``, ``smc:default`` and ``smc`` with ``preset="default"`` are all ``smc``), another preset is
    ``name:preset`` (``smc:paper`` and ``smc`` with ``preset="paper"``); an agent file is its stem (a relative or
    absolute path, a symlink or a copy elsewhere: one name, and one row, since the row's policy hash is read from
    the content); any other spec is returned stripped."""
    text = spec.strip()
    if Path(text).suffix in AGENT_SUFFIXES and Path(text).stem:
        return Path(text).stem    # an agent file: shown by its stem, identified by its content (weights hash)
    name, sep, spec_preset = text.partition(":")
    if name not in known_policies():
        return text
    chosen = (spec_preset.strip() if sep else "") or (preset or "default")
    return name if chosen == "default" else f"{name}:{chosen}"


def recorded_policy_id(spec: str, preset: str | None = None) -> str:
    """The policy id ``vtrack evaluate`` records: an agent file's stem (the file is identified by its weights hash,
    so a relative and an absolute path to one file are one policy), else ``canonical_spec``."""
    return canonical_spec(spec, preset)


def named_factories(entries: Sequence[tuple[str, str, Callable[[Any], Any]]]) -> dict[str, Callable[[Any], Any]]:
    """``{name: make(env)}`` of ``(canonical id, spec, make)`` entries, in order, one per policy: a policy's identity
    is its id and, for an agent file, its content (``AgentFactory.content``, the weights hash), so the same policy
    given twice (``lqr`` and ``lqr:default``; one agent by a relative and an absolute path, a symlink or a copy) is
    scored once (a warning says so), and two different agents with one stem are two policies, named apart as
    ``stem@<first 12 digits of the weights hash>`` (their rows record the stem: ``recorded_id``)."""
    chosen: dict[tuple[str, str | None], tuple[str, Callable[[Any], Any]]] = {}
    for key, spec, make in entries:
        identity = (key, getattr(make, "content", None))
        if identity in chosen:
            log.warning("%r and %r are the same policy %r: scored once", chosen[identity][0], spec, key)
            continue
        chosen[identity] = (spec, make)
    keys = [key for key, _ in chosen]
    return {(key if keys.count(key) == 1 or content is None else f"{key}@{content[:12]}"): make
            for (key, content), (_, make) in chosen.items()}


def recorded_id(name: str, make: Callable[[Any], Any]) -> str:
    """The policy id the rows of ``make`` under ``name`` record: an agent file's stem when ``name`` is the
    ``stem@hash`` label ``named_factories`` gave it (two agents with one stem in one run), else ``name``."""
    if isinstance(make, AgentFactory) and name == f"{make.policy_id}@{make.content[:12]}":
        return make.policy_id
    return name


@dataclass(frozen=True)
class AgentFactory:
    """``make(env)`` of a weights-only agent file read once: ``agent`` bound to each env (``bind_agent``);
    ``policy_id`` its file's stem, ``content`` its weights hash (its identity)."""

    agent: Any
    policy_id: str

    @property
    def content(self) -> str:
        return str(self.agent.weights_hash)

    def __call__(self, env: Any) -> Any:
        return bind_agent(self.agent, env)


def _presets(name: str) -> tuple[str, ...]:
    from vtrack_gym.baselines.registry import available_presets

    return available_presets(name)


def _file_factory(spec: str) -> Callable[[Any], Any]:
    path = Path(spec)
    if path.suffix in AGENT_SUFFIXES:
        from vtrack_gym.baselines.numpy_policy import load_agent

        try:
            agent = load_agent(path)
        except (ValueError, OSError) as exc:
            raise ValueError(f"{spec!r} looks like an agent file but is not a valid weights-only vtrack agent: "
                             f"{exc}") from None
        return AgentFactory(agent, path.stem)
    if path.suffix in UNSAFE_SUFFIXES or path.is_file():
        raise ValueError(f"{spec!r} looks like an agent file; only weights-only vtrack agents (agent.json + "
                         "agent.npz, written by `vtrack train` / `vtrack export`) are loaded: SB3 zips and "
                         "pickles can run code (turn an SB3 model into an agent file with `vtrack export --model`)")
    raise ValueError(f"unknown policy {spec!r}; {_valid_text()}")


def bind_agent(agent: Any, env: Any) -> Any:
    """``agent`` after checking it against ``env`` (``NumpyPolicy.check_env``); ``env=None`` skips the check. In a
    longitudinal control mode the steering agent is paired with the PD-FLC (``baselines.decoupled``)."""
    if env is None:
        return agent
    from vtrack_gym.baselines.decoupled import for_control

    agent.check_env(env)
    return for_control(agent, env)


def resolve_policy(spec: str, env: Any, preset: str | None = None, *, trust_code: bool = False,
                   policy_kwargs: Mapping[str, Any] | None = None) -> Any:
    """The policy ``spec`` names, built for ``env`` (see the module docstring and ``policy_factory``)."""
    return policy_factory(spec, preset, trust_code=trust_code, policy_kwargs=policy_kwargs)(env)
