"""A policy's fingerprint for the leaderboard's ``policy_hash``: a digest of what determines its actions.

* an exported agent: its ``weights_hash``;
* a baseline: its class and frozen config dataclass (every preset or tuned config its own);
* an SB3 algorithm (a ``predict`` method and a torch ``policy`` module): its class, the module's architecture and
  weights;
* observations normalised by SB3 ``VecNormalize`` statistics: the inner policy's digest and the statistics;
* any other object: its class and ALL of its state, at any depth: numbers, strings, bytes, numpy arrays, torch
  modules and tensors, containers (dict and set order does not matter), nested objects (their ``__dict__`` and
  ``__slots__``, or what they hand to pickle), functions (code, defaults and closure values) and classes.
  Environments, random generators, loggers and modules are left out (not parameters). Shared and cyclic references
  are read once and recorded as back-references.

The digest is the same in every process and under every hash seed (no ``id``, ``hash`` or memory address enters
it). Reading is bounded by bytes (``MAX_STATE_BYTES``), not by depth or length: a policy whose state is larger, or
holds an object that cannot be read (an open file, a lock, an extension object that pickle refuses), raises
:class:`IncompleteFingerprint` naming where; ``evaluate`` then refuses to store it unless it is given a
``policy_id`` (see :func:`named_policy_hash`). Two policies whose digests differ are never merged on the
leaderboard; two objects of one class with the same state are one policy. A policy whose behaviour lives outside
its state (a global, a file it reads) cannot be told apart from another of its class: pass ``policy_id``.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import random
import sys
import types
from typing import Any

import numpy as np

MAX_STATE_BYTES = 256 * 2**20
"""Bytes of state read for one fingerprint (the sum of what is fed to the digest)."""
_ATOMS = (type(None), bool, int, float, complex, str, bytes, bytearray)


class IncompleteFingerprint(ValueError):
    """The policy's state cannot be read completely (too large, or an unreadable object); the message says where."""


def policy_hash(policy: Any) -> str:
    """Short (12 hex digits) digest of what determines ``policy``'s actions (see the module docstring).

    ``IncompleteFingerprint`` if its state cannot be read completely.
    """
    weights = getattr(policy, "weights_hash", None)
    if isinstance(weights, str) and weights:
        return weights[:12]
    cfg = getattr(policy, "config", None)
    if dataclasses.is_dataclass(cfg) and not isinstance(cfg, type):
        try:   # plain JSON configs keep their historical digest
            text = type(policy).__name__ + ":" + json.dumps(dataclasses.asdict(cfg), sort_keys=True)
            return hashlib.sha256(text.encode()).hexdigest()[:12]
        except (TypeError, ValueError):
            pass
    special = sb3_or_normalised_digest(policy)
    return (special or state_digest(policy, "policy"))[:12]


def named_policy_hash(policy: Any, policy_id: str) -> str:
    """``policy_hash``, or, when the state cannot be read completely, a digest of its class and the user's
    ``policy_id`` (the name then identifies the policy)."""
    try:
        return policy_hash(policy)
    except IncompleteFingerprint:
        cls = type(policy)
        text = f"named:{cls.__module__}.{cls.__qualname__}:{policy_id}"
        return hashlib.sha256(text.encode()).hexdigest()[:12]


def state_digest(obj: Any, name: str = "value", budget: int = MAX_STATE_BYTES) -> str:
    """Full SHA-256 hex digest of ``obj``'s state (see the module docstring); ``IncompleteFingerprint`` beyond
    ``budget`` bytes or at an unreadable object (``name``: how the message calls ``obj``)."""
    walker = _Walker(budget)
    walker.walk(obj, name)
    return walker.hexdigest()


class _Walker:
    """Feeds a value and everything it holds into one SHA-256, iteratively (no recursion limit)."""

    def __init__(self, budget: int) -> None:
        self.budget = budget
        self.fed = 0
        self.digest = hashlib.sha256()
        self.memo: dict[int, int] = {}
        self.alive: list[Any] = []    # keeps memoised temporaries alive, so their ids are never reused

    def hexdigest(self) -> str:
        return self.digest.hexdigest()

    def _reserve(self, size: int, where: str) -> None:
        """Count ``size`` bytes against the budget before reading them."""
        if self.fed + size > self.budget:
            raise IncompleteFingerprint(f"{where}: the state is larger than {self.budget} bytes; pass policy_id "
                                        "to name this policy")

    def feed(self, data: bytes, where: str) -> None:
        self._reserve(len(data) + 8, where)
        self.fed += len(data) + 8
        self.digest.update(len(data).to_bytes(8, "little"))
        self.digest.update(data)

    def walk(self, root: Any, name: str) -> None:
        stack: list[tuple[Any, str, bool]] = [(root, name, False)]
        while stack:
            value, where, is_token = stack.pop()
            if is_token:
                self.feed(value, where)
            else:
                children = self._visit(value, where)
                stack.extend(reversed(children))

    def _visit(self, value: Any, where: str) -> list[tuple[Any, str, bool]]:
        """Feed ``value``'s own bytes; return what it holds (values and tokens) to walk next, in order."""
        if isinstance(value, _ATOMS) or isinstance(value, np.generic):
            self.feed(_atom_bytes(value), where)
            return []
        if isinstance(value, np.ndarray) and value.dtype != object:
            self._reserve(value.nbytes, where)
            arr = np.ascontiguousarray(value)
            self.feed(f"ndarray{arr.dtype.str}{arr.shape}".encode(), where)
            self.feed(arr.tobytes(), where)
            return []
        if id(value) in self.memo:
            self.feed(f"ref{self.memo[id(value)]}".encode(), where)
            return []
        self.memo[id(value)] = len(self.memo)
        self.alive.append(value)
        return self._children(value, where)

    def _children(self, value: Any, where: str) -> list[tuple[Any, str, bool]]:
        tag = _qualname(type(value))
        if isinstance(value, np.ndarray):       # object arrays: their elements
            self.feed(f"{tag}{value.shape}".encode(), where)
            return _items(value.ravel().tolist(), where)
        torch_items = _torch_children(value, where)
        if torch_items is not None:
            self.feed(tag.encode(), where)
            return torch_items
        if isinstance(value, (list, tuple)):
            self.feed(f"{tag}[{len(value)}".encode(), where)
            return [*_items(value, where), (b"]", where, True)]
        if isinstance(value, (dict, types.MappingProxyType)):
            self.feed(f"{tag}{{{len(value)}".encode(), where)
            return [*self._mapping_items(value, where), (b"}", where, True)]
        if isinstance(value, (set, frozenset)):
            self.feed(f"{tag}{{{len(value)}".encode(), where)
            subs = sorted(self._sub_digest(v, f"{where} element") for v in value)
            return [(s.encode(), where, True) for s in subs]
        if _is_left_out(value):
            self.feed(f"<left out {tag}>".encode(), where)
            return []
        if isinstance(value, type):
            self.feed(f"class {_qualname(value)}".encode(), where)
            return []
        if isinstance(value, (types.FunctionType, types.MethodType, types.BuiltinFunctionType,
                              types.CodeType, types.CellType)):
            return self._callable_children(value, where)
        self.feed(f"<{tag}>".encode(), where)
        return _object_state(value, where)

    def _mapping_items(self, mapping: Any, where: str) -> list[tuple[Any, str, bool]]:
        keyed = []
        for key, item in mapping.items():
            kdigest = key.encode("utf-8", "surrogatepass") if isinstance(key, str) else \
                self._sub_digest(key, f"{where} key").encode()
            keyed.append((kdigest, isinstance(key, str), key, item))
        keyed.sort(key=lambda k: (k[1], k[0]))
        out: list[tuple[Any, str, bool]] = []
        for kdigest, _, key, item in keyed:
            label = f"{where}[{key!r}]" if isinstance(key, str) and len(key) < 80 else f"{where}[...]"
            out += [(b"k" + kdigest, where, True), (item, label, False)]
        return out

    def _sub_digest(self, value: Any, where: str) -> str:
        """Digest of one element of an unordered container (its order comes from these digests)."""
        sub = _Walker(self.budget - self.fed)
        sub.walk(value, where)
        self.fed += sub.fed
        return sub.hexdigest()

    def _callable_children(self, value: Any, where: str) -> list[tuple[Any, str, bool]]:
        if isinstance(value, types.MethodType):
            self.feed(b"method", where)
            return [(value.__func__, f"{where}.__func__", False), (value.__self__, f"{where}.__self__", False)]
        if isinstance(value, types.BuiltinFunctionType):
            self.feed(f"builtin {getattr(value, '__module__', '')}.{value.__qualname__}".encode(), where)
            owner = getattr(value, "__self__", None)
            return [] if owner is None or isinstance(owner, types.ModuleType) else [(owner, f"{where}.__self__",
                                                                                       False)]
        if isinstance(value, types.CellType):
            self.feed(b"cell", where)
            try:
                return [(value.cell_contents, f"{where} (closure)", False)]
            except ValueError:       # an empty cell
                return []
        if isinstance(value, types.CodeType):
            self.feed(f"code {value.co_name}".encode() + value.co_code, where)
            return [(value.co_consts, f"{where} constants", False), (value.co_names, where, False)]
        self.feed(f"function {value.__module__}.{value.__qualname__}".encode(), where)
        return [(value.__code__, where, False), (value.__defaults__, f"{where} defaults", False),
                (value.__kwdefaults__, f"{where} defaults", False), (value.__closure__ or (), where, False)]


def _items(values: Any, where: str) -> list[tuple[Any, str, bool]]:
    return [(v, f"{where}[{i}]", False) for i, v in enumerate(values)]


def _qualname(cls: type) -> str:
    return f"{cls.__module__}.{cls.__qualname__}"


def _atom_bytes(value: Any) -> bytes:
    """Type-tagged bytes of a scalar (no ``str(int)``: a 4000-digit int is fine)."""
    if isinstance(value, np.generic):
        return f"np{value.dtype.str}".encode() + (value.tobytes() if value.dtype != object else repr(value).encode())
    if isinstance(value, bool) or value is None:
        return repr(value).encode()
    if isinstance(value, int):
        return b"int" + value.to_bytes((value.bit_length() + 8) // 8, "little", signed=True)
    if isinstance(value, float):
        return b"float" + value.hex().encode()
    if isinstance(value, complex):
        return b"complex" + value.real.hex().encode() + b"," + value.imag.hex().encode()
    if isinstance(value, str):
        return b"str" + value.encode("utf-8", "surrogatepass")
    return type(value).__name__.encode() + bytes(value)


def _is_left_out(value: Any) -> bool:
    """Environments, random generators, loggers and modules: not a policy's parameters."""
    return (isinstance(value, (types.ModuleType, np.random.Generator, np.random.RandomState, random.Random,
                               np.random.BitGenerator, logging.Logger))
            or (hasattr(value, "reset") and hasattr(value, "step") and hasattr(value, "action_space")))


def _object_state(value: Any, where: str) -> list[tuple[Any, str, bool]]:
    """What an object holds: its ``__dict__`` and ``__slots__``, or (for a class with its own pickling, such as an
    extension type) the parts of ``__reduce_ex__``; ``IncompleteFingerprint`` when neither is available."""
    cls = type(value)
    plain = cls.__reduce_ex__ is object.__reduce_ex__ and cls.__reduce__ is object.__reduce__
    state: dict[str, Any] = {}
    if plain and hasattr(value, "__dict__"):
        state.update(vars(value))
    slots = [s for klass in cls.__mro__ for s in _slot_names(klass)]
    for name in slots:
        if name not in ("__dict__", "__weakref__") and hasattr(value, name):
            state[f"slot {name}"] = getattr(value, name)
    if plain and (hasattr(value, "__dict__") or slots):
        return _named_state(state, where)
    try:
        reduced = value.__reduce_ex__(4)
    except Exception as exc:  # any refusal of pickle means: unreadable
        raise IncompleteFingerprint(f"{where} (a {cls.__qualname__}) cannot be read ({type(exc).__name__}: "
                                    f"{str(exc)[:120]}); pass policy_id to name this policy") from None
    if isinstance(reduced, str):      # a global singleton
        return [(reduced, where, False)]
    parts = list(reduced[1:3])
    parts += [list(p) if p is not None else None for p in reduced[3:5]]
    return [(reduced[0], f"{where} constructor", False), *_items(parts, where)]


def _named_state(state: dict[str, Any], where: str) -> list[tuple[Any, str, bool]]:
    out: list[tuple[Any, str, bool]] = []
    for name in sorted(state):
        out += [(f"|{name}=".encode(), where, True), (state[name], f"{where}.{name.removeprefix('slot ')}", False)]
    return out


def _slot_names(klass: type) -> tuple[str, ...]:
    slots = klass.__dict__.get("__slots__", ())
    return (slots,) if isinstance(slots, str) else tuple(slots)


def _torch() -> Any:
    """The torch module if something already imported it (a torch object cannot exist otherwise), else None."""
    return sys.modules.get("torch")


def _torch_children(value: Any, where: str) -> list[tuple[Any, str, bool]] | None:
    """A torch module (architecture text and state dict as arrays) or tensor (its array); None for other values."""
    torch = _torch()
    if torch is None:
        return None
    if isinstance(value, torch.Tensor):
        return [(value.detach().cpu().numpy(), where, False)]
    if isinstance(value, torch.nn.Module):
        arrays = {k: t.detach().cpu().numpy() for k, t in value.state_dict().items()}
        return [(repr(value), f"{where} architecture", False), (arrays, f"{where} weights", False)]
    return None


def sb3_or_normalised_digest(policy: Any) -> str | None:
    """Digest of an SB3 algorithm (its ``policy`` module) or a ``NormalisedPolicy`` (inner policy and statistics);
    None for other policies."""
    module = getattr(policy, "policy", None)
    torch = _torch()
    cls = _qualname(type(policy))
    if hasattr(policy, "predict") and torch is not None and isinstance(module, torch.nn.Module):
        return state_digest({"class": cls, "policy": module}, "policy")
    stats = getattr(getattr(policy, "vecnormalize", None), "obs_rms", None)
    if stats is not None and module is not None:
        vn = policy.vecnormalize
        return state_digest({"class": cls, "inner": policy_hash(module),
                             "stats": [stats.mean, stats.var, getattr(vn, "clip_obs", None),
                                       getattr(vn, "epsilon", None), getattr(vn, "norm_obs", None)]}, "policy")
    return None
