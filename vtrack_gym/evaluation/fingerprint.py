"""A policy's fingerprint for the leaderboard's ``policy_hash``: a digest of what determines its actions.

* an exported agent: its ``weights_hash``;
* a baseline: its class and frozen config dataclass (every preset or tuned config its own);
* an SB3 algorithm (a ``predict`` method and a torch ``policy`` module): its class and the module's weights;
* observations normalised by SB3 ``VecNormalize`` statistics: the inner policy's digest and the statistics;
* any other object: its class and its state, read from its attributes (numbers, strings, numpy arrays, torch
  modules and tensors, dataclasses, lists, tuples and dicts of them, nested objects two levels deep); callables,
  environments, random generators and other objects are left out.

Two policies whose digests differ are never merged on the leaderboard; two objects of one class with the same
attribute values are one policy. A policy whose behaviour lives outside its attributes (a global, a file it
reads) cannot be told apart from another of its class: pass ``policy_id`` to name it.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import numbers
import sys
from typing import Any

import numpy as np

MAX_DEPTH = 2
"""Nested objects read below the policy itself."""
MAX_ITEMS = 100_000
"""Elements of one list, tuple or dict read (a longer container is read up to this many)."""


def policy_hash(policy: Any) -> str:
    """Short (12 hex digits) digest of what determines ``policy``'s actions (see the module docstring)."""
    weights = getattr(policy, "weights_hash", None)
    if isinstance(weights, str) and weights:
        return weights[:12]
    cfg = getattr(policy, "config", None)
    if dataclasses.is_dataclass(cfg) and not isinstance(cfg, type):
        text = type(policy).__name__ + ":" + json.dumps(dataclasses.asdict(cfg), sort_keys=True, default=repr)
        return hashlib.sha256(text.encode()).hexdigest()[:12]
    digest = hashlib.sha256()
    _feed_policy(digest, policy, 0)
    return digest.hexdigest()[:12]


def _feed_policy(digest: Any, policy: Any, depth: int) -> None:
    cls = type(policy)
    digest.update(f"<{cls.__module__}.{cls.__qualname__}>".encode())
    module = getattr(policy, "policy", None)
    if hasattr(policy, "predict") and _is_torch_module(module):       # an SB3 algorithm: its network's weights
        _feed_torch_module(digest, module)
        return
    stats = getattr(getattr(policy, "vecnormalize", None), "obs_rms", None)
    if stats is not None and hasattr(policy, "policy"):               # NormalisedPolicy: inner policy + statistics
        _feed_policy(digest, policy.policy, depth + 1)
        vn = policy.vecnormalize
        for value in (stats.mean, stats.var, getattr(vn, "clip_obs", None), getattr(vn, "epsilon", None),
                      getattr(vn, "norm_obs", None)):
            _feed_value(digest, value, MAX_DEPTH)
        return
    _feed_attributes(digest, policy, depth)


def _feed_attributes(digest: Any, obj: Any, depth: int, path: frozenset[int] = frozenset()) -> None:
    try:
        attrs = vars(obj)
    except TypeError:   # no __dict__ (slots or a builtin)
        attrs = {name: getattr(obj, name) for name in getattr(type(obj), "__slots__", ()) if hasattr(obj, name)}
    for name in sorted(attrs):
        digest.update(f"|{name}=".encode())
        _feed_value(digest, attrs[name], depth, path | {id(obj)})


def _feed_value(digest: Any, value: Any, depth: int, path: frozenset[int] = frozenset()) -> None:
    if id(value) in path:                     # a cycle (a list holding itself, an object pointing back)
        digest.update(f"<cycle {type(value).__qualname__}>".encode())
        return
    path = path | {id(value)}
    if value is None or isinstance(value, (bool, str, bytes, numbers.Number)):
        digest.update(repr(value).encode())
    elif isinstance(value, np.ndarray):
        arr = np.ascontiguousarray(value)
        digest.update(f"array{arr.dtype.str}{arr.shape}".encode())
        digest.update(arr.tobytes() if arr.dtype != object else repr(arr.tolist()).encode())
    elif _is_torch_module(value):
        _feed_torch_module(digest, value)
    elif _torch() is not None and isinstance(value, _torch().Tensor):
        _feed_value(digest, value.detach().cpu().numpy(), depth)
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        digest.update(f"<{type(value).__qualname__}>".encode())
        _feed_value(digest, {f.name: getattr(value, f.name) for f in dataclasses.fields(value)}, depth, path)
    elif isinstance(value, (list, tuple)):
        digest.update(f"{type(value).__name__}{len(value)}[".encode())
        for item in value[:MAX_ITEMS]:
            _feed_value(digest, item, depth, path)
        digest.update(b"]")
    elif isinstance(value, dict):
        digest.update(f"dict{len(value)}{{".encode())
        for key in sorted(value, key=repr)[:MAX_ITEMS]:
            digest.update(repr(key).encode())
            _feed_value(digest, value[key], depth, path)
        digest.update(b"}")
    elif _is_left_out(value) or depth >= MAX_DEPTH:
        digest.update(f"<{type(value).__qualname__}>".encode())
    else:
        digest.update(f"<{type(value).__qualname__}>{{".encode())
        _feed_attributes(digest, value, depth + 1, path)
        digest.update(b"}")


def _is_left_out(value: Any) -> bool:
    """Callables, environments, random generators and modules: not a policy's parameters."""
    import types

    return (callable(value) or isinstance(value, (types.ModuleType, np.random.Generator, np.random.RandomState))
            or (hasattr(value, "reset") and hasattr(value, "step")))


def _torch() -> Any:
    """The torch module if something already imported it (a torch object cannot exist otherwise), else None."""
    return sys.modules.get("torch")


def _is_torch_module(value: Any) -> bool:
    torch = _torch()
    return torch is not None and isinstance(value, torch.nn.Module)


def _feed_torch_module(digest: Any, module: Any) -> None:
    for key, tensor in sorted(module.state_dict().items()):
        digest.update(key.encode())
        arr = tensor.detach().cpu().numpy()
        digest.update(f"{arr.dtype.str}{arr.shape}".encode())
        digest.update(np.ascontiguousarray(arr).tobytes())
