"""From ``--policy``/``--policies`` values to policy factories: the package's resolver, user code with
``--trust-code`` (``vtrack_gym.baselines.user_code``'s rule), keyword arguments from ``--policy-kwargs``."""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Sequence
from typing import Any

from vtrack_gym.cli._terminal import err

MAX_POLICY_KWARGS_CHARS = 4096
"""Longest ``--policy-kwargs`` value [characters]."""


def parse_policy_kwargs(text: str | None) -> dict[str, Any]:
    """The keyword arguments of ``--policy-kwargs`` (a JSON object with string keys); ``ValueError`` naming the
    option otherwise."""
    from vtrack_gym.baselines.user_code import check_policy_kwargs

    if text is None:
        return {}
    if len(text) > MAX_POLICY_KWARGS_CHARS:
        raise ValueError(f"--policy-kwargs is longer than {MAX_POLICY_KWARGS_CHARS} characters")
    try:
        value = json.loads(text, parse_constant=_refuse_constant)
    except (json.JSONDecodeError, RecursionError, ValueError) as exc:
        raise ValueError(f"--policy-kwargs must be a JSON object, e.g. '{{\"k_y\": 0.2}}' ({exc})"[:300]) from None
    return check_policy_kwargs(value, "--policy-kwargs")


def _refuse_constant(name: str) -> float:
    raise ValueError(f"{name} is not a finite number")


def policy_factory(name: str, preset: str = "default", trust_code: bool = False,
                   kwargs: dict[str, Any] | None = None) -> Any:
    """``make(env) -> policy`` for one ``--policy`` value (errors name the options)."""
    from vtrack_gym.baselines.resolve import is_user_spec
    from vtrack_gym.baselines.resolve import policy_factory as resolve

    if is_user_spec(name):
        if not trust_code:
            raise ValueError(f"--policy {name!r} names Python code (MODULE:NAME); importing it runs that code, so "
                             "vtrack does it only with --trust-code")
        if preset != "default":
            raise ValueError("--preset applies to the baselines, not to MODULE:NAME")
        module, _, attr = name.partition(":")
        err(f"--trust-code: importing and running your module {module!r} (policy {attr})")
        if os.getcwd() not in sys.path:
            sys.path.insert(0, os.getcwd())
        return resolve(name, trust_code=True, policy_kwargs=kwargs)
    if trust_code:
        raise ValueError("--trust-code applies to --policy MODULE:NAME only")
    if kwargs:
        raise ValueError("--policy-kwargs applies to a --policy MODULE:NAME of your own code (with --trust-code)")
    return resolve(name, preset)


def policy_makers(names: Sequence[str], preset: str = "default", trust_code: bool = False,
                  kwargs_text: str | None = None) -> list[tuple[str, Any]]:
    """``(name, make(env))`` for each ``--policies`` name, in order, every one checked before any rollout;
    ``--trust-code`` and ``--policy-kwargs`` apply to the MODULE:NAME ones and need at least one."""
    from vtrack_gym.baselines.resolve import is_user_spec

    kwargs = parse_policy_kwargs(kwargs_text)
    users = [is_user_spec(n) for n in names]
    if trust_code and not any(users):
        raise ValueError("--trust-code applies to --policy MODULE:NAME only")
    if kwargs and not any(users):
        raise ValueError("--policy-kwargs applies to a --policy MODULE:NAME of your own code (with --trust-code)")
    return [(name, policy_factory(name, preset, trust_code and user, kwargs if user else None))
            for name, user in zip(names, users, strict=True)]


def policy_factories(names: Sequence[str], preset: str = "default", trust_code: bool = False,
                     kwargs_text: str | None = None) -> dict[str, Any]:
    """``{policy id: make(env)}`` for ``--policies`` names (``policy_makers``: each built once, checked before any
    rollout); ids are canonical (``lqr:default`` is ``lqr``; a class of your own is named by its class and
    arguments, ``policy_names.class_label``, as from Python; an agent file by its stem). One policy given twice
    (also one agent file by two paths) is scored once; two different agents with one stem are two policies
    (``resolve.named_factories``)."""
    from vtrack_gym.baselines.resolve import canonical_spec, is_user_spec, named_factories
    from vtrack_gym.evaluation.identity.policy_names import user_spec_label

    kwargs = parse_policy_kwargs(kwargs_text)
    makers = policy_makers([n.strip() for n in names], preset, trust_code, kwargs_text)
    return named_factories([(user_spec_label(spec, kwargs) if is_user_spec(spec) else canonical_spec(spec), spec, make)
                            for spec, make in makers])
