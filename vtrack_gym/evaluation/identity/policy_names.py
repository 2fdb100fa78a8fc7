"""The name a row shows for a class of your own: the class and the arguments it was built with.

One rule from Python and from the CLI: ``Name(arg=value, ...)`` with the constructor's keyword arguments that
differ from their defaults, sorted by name, scalars only (numbers as numbers: ``k_y=0.2``, ``k=1`` for ``1`` and
``1.0`` alike; strings as JSON; a list or dict argument is left to the policy hash); the bare class name when
every argument has its default. From Python an instance is named by its attributes that carry a constructor
parameter's name (``self.k_y = k_y``, the usual pattern; an argument stored under another name is not shown, and
the policy hash still tells such policies apart). From the CLI, ``--policy MODULE:Name --policy-kwargs JSON``
names it by the arguments given. A policy with a ``policy_id`` attribute is named by it.
"""

from __future__ import annotations

import inspect
import json
import math
from collections.abc import Mapping
from typing import Any

_SKIPPED = frozenset({"self", "env"})
"""Constructor parameters that are not settings (the env a ``from_env`` classmethod receives)."""


def instance_label(policy: Any) -> str:
    """``Name(arg=value, ...)`` of an instance: its constructor parameters read back from same-named attributes."""
    cls = type(policy)
    attrs = getattr(policy, "__dict__", None)
    if not isinstance(attrs, dict):
        return cls.__name__
    given = {name: attrs[name] for name in _parameters(cls) if name in attrs and _is_scalar(attrs[name])}
    return class_label(cls, given)


def class_label(cls: type, kwargs: Mapping[str, Any]) -> str:
    """``Name(arg=value, ...)`` of ``cls`` built with ``kwargs``: the scalar ones that differ from their default."""
    defaults = _parameters(cls)
    shown = []
    for name in sorted(kwargs):
        value = kwargs[name]
        default = defaults.get(name, inspect.Parameter.empty)
        if not _is_scalar(value) or (_is_scalar(default) and _text(default) == _text(value)):
            continue
        shown.append(f"{name}={_text(value)}")
    return f"{cls.__name__}({', '.join(shown)})" if shown else cls.__name__


def user_spec_label(spec: str, kwargs: Mapping[str, Any] | None) -> str:
    """``class_label`` of a ``module:Name`` spec whose module is already imported (by its policy factory); the
    spec itself when it is not."""
    import sys

    module_name, _, attr = spec.partition(":")
    cls = getattr(sys.modules.get(module_name), attr, None)
    return class_label(cls, dict(kwargs or {})) if isinstance(cls, type) else spec


def _parameters(cls: type) -> dict[str, Any]:
    """{name: default (``Parameter.empty`` when none)} of the keyword parameters of ``cls``'s constructor and of
    its ``from_env`` classmethod (the CLI's two ways to build it)."""
    out: dict[str, Any] = {}
    for fn in (getattr(cls, "from_env", None), cls.__init__):
        try:
            params = inspect.signature(fn).parameters.values() if fn is not None else ()
        except (TypeError, ValueError):
            continue
        for p in params:
            if p.name not in _SKIPPED and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY):
                out.setdefault(p.name, p.default)
    return out


def _is_scalar(value: Any) -> bool:
    """A value a name shows: None, a bool, a finite number or a short string (containers are left to the hash)."""
    if isinstance(value, float):
        return math.isfinite(value)
    return value is None or isinstance(value, (bool, int)) or (isinstance(value, str) and len(value) <= 64)


def _text(value: Any) -> str:
    """A scalar as the name shows it: numbers as numbers (``1``, ``1.0`` -> ``1``; ``0.2``), others as JSON."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        number = float(value) if abs(value) <= 2**53 else value
        return str(int(number)) if float(number).is_integer() else repr(number)
    return json.dumps(value)
