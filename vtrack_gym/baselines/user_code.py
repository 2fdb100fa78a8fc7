"""Policies of the user's own code, named ``module:Name`` (only ever imported when the caller trusts the code).

How ``Name`` becomes a policy for an env (the one rule ``make_policy``, ``vtrack eval``, ``benchmark``, ``plot``
and ``video`` share):

* a class that defines ``from_env``: ``Name.from_env(env, **policy_kwargs)``;
* another class: ``Name(**policy_kwargs)``; the env is never passed as a positional argument, so
  ``__init__(self, k_y=0.1)`` keeps its default. A class whose ``__init__`` *requires* one positional argument
  (no default) gets the env as it (``Name(env, **policy_kwargs)``);
* a function: ``Name(env, **policy_kwargs)`` if it takes a positional argument, else ``Name(**policy_kwargs)``;
* an object with ``predict``: used as is (no ``policy_kwargs``).
"""

from __future__ import annotations

import importlib
import inspect
import logging
from collections.abc import Callable, Mapping
from typing import Any

log = logging.getLogger(__name__)

MAX_POLICY_KWARGS = 64
"""Most keyword arguments ``policy_kwargs`` holds."""


def check_policy_kwargs(kwargs: Any, name: str = "policy_kwargs") -> dict[str, Any]:
    """``kwargs`` as a dict if it is a mapping of identifier strings to values (at most ``MAX_POLICY_KWARGS``);
    ``ValueError`` naming ``name`` (how the caller's user spells it, e.g. ``--policy-kwargs``) otherwise."""
    if not isinstance(kwargs, Mapping):
        raise ValueError(f"{name} must be an object of keyword arguments, e.g. {{\"k_y\": 0.2}} "
                         f"(got a {type(kwargs).__name__})")
    if len(kwargs) > MAX_POLICY_KWARGS:
        raise ValueError(f"{name} takes at most {MAX_POLICY_KWARGS} keyword arguments (got {len(kwargs)})")
    for key in kwargs:
        if not isinstance(key, str) or not key.isidentifier():
            raise ValueError(f"{name}: every key must be a Python argument name, e.g. \"k_y\" (got {str(key)[:40]!r})")
    return dict(kwargs)


def _required_positional(cls: type) -> int:
    """How many positional parameters of ``cls.__init__`` have no default (``self`` excluded)."""
    try:
        params = list(inspect.signature(cls).parameters.values())
    except (TypeError, ValueError):
        return 0
    return sum(1 for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) and p.default is p.empty)


def _takes_positional(func: Callable[..., Any]) -> bool:
    try:
        params = inspect.signature(func).parameters.values()
    except (TypeError, ValueError):
        return False
    return any(p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) for p in params)


def _checked(func: Callable[..., Any], with_env: bool, spec: str, kwargs: Mapping[str, Any]) -> Callable[[Any], Any]:
    """``make(env)`` calling ``func(env, **kwargs)`` or ``func(**kwargs)``, the arguments checked against
    ``func``'s signature now (``ValueError`` naming the keyword that does not fit)."""
    try:
        signature = inspect.signature(func)
    except (TypeError, ValueError):
        signature = None
    if signature is not None:
        try:
            signature.bind(*((None,) if with_env else ()), **kwargs)
        except TypeError as exc:
            raise ValueError(f"policy {spec!r} cannot be built with policy_kwargs {sorted(kwargs)}: {exc}") from None
    if with_env:
        return lambda env: func(env, **kwargs)
    return lambda env: func(**kwargs)


def builder(obj: Any, spec: str, kwargs: Mapping[str, Any]) -> Callable[[Any], Any]:
    """``make(env) -> policy`` for the object ``spec`` named (see the module docstring for the rule)."""
    if inspect.isclass(obj):
        from_env = getattr(obj, "from_env", None)
        if callable(from_env):
            return _checked(from_env, True, spec, kwargs)
        return _checked(obj, _required_positional(obj) == 1, spec, kwargs)
    if hasattr(obj, "predict"):
        if kwargs:
            raise ValueError(f"policy {spec!r} is an object with predict, already built: it takes no policy_kwargs")
        return lambda env: obj
    if not callable(obj):
        raise ValueError(f"policy {spec!r}: {spec.partition(':')[2]} is neither a class, a function nor an object "
                         "with predict")
    return _checked(obj, _takes_positional(obj), spec, kwargs)


def user_policy_factory(spec: str, policy_kwargs: Mapping[str, Any] | None = None) -> Callable[[Any], Any]:
    """Import ``module`` of ``spec`` = ``module:Name`` (runs its code) and return ``make(env) -> policy``.

    ``ValueError`` when the module cannot be imported, has no ``Name``, or ``policy_kwargs`` is not a mapping of
    argument names."""
    kwargs = check_policy_kwargs(policy_kwargs or {})
    module_name, _, attr = spec.partition(":")
    log.debug("importing and running your module %r (policy %s)", module_name, attr)
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise ValueError(f"policy {spec!r}: cannot import module {module_name!r} ({exc})") from None
    obj = getattr(module, attr, None)
    if obj is None:
        raise ValueError(f"policy {spec!r}: module {module_name!r} has no attribute {attr!r}")
    return builder(obj, spec, kwargs)
