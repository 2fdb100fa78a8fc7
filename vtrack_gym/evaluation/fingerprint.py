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
MAX_DEPTH = 200_000
"""Containers open at once (a list in a list in ...): a state nested deeper is refused, not read."""
MAX_OBJECTS = 1_000_000
"""Objects (containers, instances, functions; not numbers or strings) read for one fingerprint."""
MAX_UNORDERED_NESTING = 64
"""Sets (or dicts with non-text keys) inside sets read: each level is digested on its own."""
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
    ``budget`` bytes, ``MAX_DEPTH`` levels, ``MAX_OBJECTS`` objects or at an unreadable object (``name``: how the
    message calls ``obj``). Time and memory are linear in the size and depth of the state."""
    walker = _Walker(budget, [0], 0)
    walker.walk(obj, name)
    return walker.hexdigest()


_VALUE, _TOKEN = 0, 1
Item = tuple[int, Any, Any]
"""(kind, value or token bytes, location): what the walker reads next."""
Frame = list[Any]
"""[values, next index, location, trailer]: an open container on the walker's stack. With a location, ``values``
are the container's elements (element i is at (location, i)); without, ``values`` are ``Item``s. ``trailer``:
``Item``s read after the values (a closing token, a subclass's attributes), or None."""


def _where(loc: Any) -> str:
    """The readable path of a location: a root name, or (parent location, label) pairs; long paths are shortened."""
    labels: list[str] = []
    while isinstance(loc, tuple):
        loc, label = loc
        labels.append(f"[{label}]" if isinstance(label, int) else label)
    labels.append(str(loc))
    labels.reverse()
    if len(labels) > 12:
        labels = [*labels[:4], f"...({len(labels) - 10} levels)...", *labels[-6:]]
    return "".join(labels)


def _frame(items: list[Item]) -> Frame | None:
    return [items, 0, None, None] if items else None


class _Walker:
    """Feeds a value and everything it holds into one SHA-256, iteratively: a stack of frames, one per open
    container (a container's elements are read in place, never copied), and locations kept as (parent, label)
    pairs (a path is spelled out only in an error message): time and memory linear in size and depth."""

    def __init__(self, budget: int, objects: list[int], nesting: int) -> None:
        self.budget = budget
        self.fed = 0
        self.digest = hashlib.sha256()
        self.memo: dict[int, int] = {}
        self.alive: list[Any] = []    # keeps memoised temporaries alive, so their ids are never reused
        self.objects = objects        # objects read, shared with the sub-walkers of unordered containers
        self.nesting = nesting        # sub-walkers this one sits in

    def hexdigest(self) -> str:
        return self.digest.hexdigest()

    def _reserve(self, size: int, loc: Any) -> None:
        """Count ``size`` bytes against the budget before reading them."""
        if self.fed + size > self.budget:
            raise IncompleteFingerprint(f"{_where(loc)}: the state is larger than {self.budget} bytes; pass "
                                        "policy_id to name this policy")

    def feed(self, data: Any, loc: Any) -> None:
        size = len(data) if isinstance(data, bytes) else data.nbytes
        self._reserve(size + 8, loc)
        self.fed += size + 8
        self.digest.update(size.to_bytes(8, "little"))
        self.digest.update(data)

    def walk(self, root: Any, name: Any) -> None:
        stack: list[Frame] = [[[(_VALUE, root, name)], 0, None, None]]
        while stack:
            frame = stack[-1]
            values, i, loc, trailer = frame
            if i == len(values):
                stack.pop()
                if trailer:
                    stack.append([trailer, 0, None, None])
                continue
            frame[1] = i + 1
            if loc is None:
                kind, value, where = values[i]
                if kind == _TOKEN:
                    self.feed(value, where)
                    continue
            else:
                value, where = values[i], (loc, i)
            child = self._visit(value, where)
            if child is not None:
                if len(stack) > MAX_DEPTH:   # the root's frame and MAX_DEPTH open containers
                    raise IncompleteFingerprint(f"{_where(where)}: the state is nested more than {MAX_DEPTH} "
                                                "levels deep; pass policy_id to name this policy")
                stack.append(child)

    def _visit(self, value: Any, loc: Any) -> Frame | None:
        """Feed ``value``'s own bytes; return a frame of what it holds (values and tokens), or None."""
        if isinstance(value, _ATOMS) or isinstance(value, np.generic):
            self.feed(_atom_bytes(value), loc)
            return None
        if isinstance(value, np.ndarray) and value.dtype != object:
            self._reserve(value.nbytes, loc)
            arr = np.ascontiguousarray(value)
            self.feed(f"ndarray{arr.dtype.str}{arr.shape}".encode(), loc)
            self.feed(arr.reshape(-1).view(np.uint8) if arr.size else b"", loc)
            return None
        if id(value) in self.memo:
            self.feed(f"ref{self.memo[id(value)]}".encode(), loc)
            return None
        self.objects[0] += 1
        if self.objects[0] > MAX_OBJECTS:
            raise IncompleteFingerprint(f"{_where(loc)}: the state holds more than {MAX_OBJECTS} objects; pass "
                                        "policy_id to name this policy")
        self.memo[id(value)] = len(self.memo)
        self.alive.append(value)
        return self._children(value, loc)

    def _children(self, value: Any, loc: Any) -> Frame | None:
        tag = _qualname(type(value))
        if isinstance(value, np.ndarray):       # object arrays: their elements
            self.feed(f"{tag}{value.shape}".encode(), loc)
            return [value.ravel().tolist(), 0, loc, None]
        torch_items = _torch_children(value, loc)
        if torch_items is not None:
            self.feed(tag.encode(), loc)
            return _frame(torch_items)
        if isinstance(value, (list, tuple)):
            self.feed(f"{tag}[{len(value)}".encode(), loc)
            return [value, 0, loc, [(_TOKEN, b"]", loc), *_extra_attributes(value, loc)]]
        if isinstance(value, (dict, types.MappingProxyType)):
            self.feed(f"{tag}{{{len(value)}".encode(), loc)
            return [self._mapping_items(value, loc), 0, None, [(_TOKEN, b"}", loc), *_extra_attributes(value, loc)]]
        if isinstance(value, (set, frozenset)):
            self.feed(f"{tag}{{{len(value)}".encode(), loc)
            subs = sorted(self._sub_digest(v, (loc, " element")) for v in value)
            return _frame([*((_TOKEN, s.encode(), loc) for s in subs), *_extra_attributes(value, loc)])
        if _is_left_out(value):
            self.feed(f"<left out {tag}>".encode(), loc)
            return _frame(_extra_attributes(value, loc))     # a subclass's own attributes still count
        if isinstance(value, type):
            self.feed(f"class {_qualname(value)}".encode(), loc)
            return None
        if isinstance(value, (types.FunctionType, types.MethodType, types.BuiltinFunctionType,
                              types.CodeType, types.CellType)):
            return _frame(self._callable_children(value, loc))
        self.feed(f"<{tag}>".encode(), loc)
        return _frame(_object_state(value, loc))

    def _mapping_items(self, mapping: Any, loc: Any) -> list[Item]:
        keyed = []
        for key, item in mapping.items():
            kdigest = key.encode("utf-8", "surrogatepass") if isinstance(key, str) else \
                self._sub_digest(key, (loc, " key")).encode()
            keyed.append((kdigest, isinstance(key, str), key, item))
        keyed.sort(key=lambda k: (k[1], k[0]))
        out: list[Item] = []
        for kdigest, _, key, item in keyed:
            label = f"[{key!r}]" if isinstance(key, str) and len(key) < 80 else "[...]"
            out += [(_TOKEN, b"k" + kdigest, loc), (_VALUE, item, (loc, label))]
        return out

    def _sub_digest(self, value: Any, loc: Any) -> str:
        """Digest of one element of an unordered container (its order comes from these digests)."""
        if self.nesting >= MAX_UNORDERED_NESTING:
            raise IncompleteFingerprint(f"{_where(loc)}: sets or non-text dict keys nested more than "
                                        f"{MAX_UNORDERED_NESTING} levels deep; pass policy_id to name this policy")
        sub = _Walker(self.budget - self.fed, self.objects, self.nesting + 1)
        sub.walk(value, loc)
        self.fed += sub.fed
        return sub.hexdigest()

    def _callable_children(self, value: Any, loc: Any) -> list[Item]:
        if isinstance(value, types.MethodType):
            self.feed(b"method", loc)
            return [(_VALUE, value.__func__, (loc, ".__func__")), (_VALUE, value.__self__, (loc, ".__self__"))]
        if isinstance(value, types.BuiltinFunctionType):
            self.feed(f"builtin {getattr(value, '__module__', '')}.{value.__qualname__}".encode(), loc)
            owner = getattr(value, "__self__", None)
            return [] if owner is None or isinstance(owner, types.ModuleType) else [(_VALUE, owner,
                                                                                       (loc, ".__self__"))]
        if isinstance(value, types.CellType):
            self.feed(b"cell", loc)
            try:
                return [(_VALUE, value.cell_contents, (loc, " (closure)"))]
            except ValueError:       # an empty cell
                return []
        if isinstance(value, types.CodeType):
            self.feed(f"code {value.co_name}".encode() + value.co_code, loc)
            return [(_VALUE, value.co_consts, (loc, " constants")), (_VALUE, value.co_names, loc)]
        self.feed(f"function {value.__module__}.{value.__qualname__}".encode(), loc)
        return [(_VALUE, value.__code__, loc), (_VALUE, value.__defaults__, (loc, " defaults")),
                (_VALUE, value.__kwdefaults__, (loc, " defaults")), (_VALUE, value.__closure__ or (), loc)]


def _extra_attributes(value: Any, loc: Any) -> list[Item]:
    """The instance attributes of a container or left-out subclass (a ``dict`` subclass holding a gain)."""
    attrs = getattr(value, "__dict__", None)
    if not isinstance(attrs, dict) or not attrs:
        return []
    state = {k: v for k, v in attrs.items() if not (isinstance(value, random.Random) and k == "gauss_next")}
    return [(_TOKEN, b"|attributes", loc), *_named_state(state, loc)] if state else []


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


def _object_state(value: Any, loc: Any) -> list[Item]:
    """What an object holds: its ``__dict__`` and ``__slots__``, and, for a class with its own pickling (an
    extension type, or a class whose ``__reduce__`` leaves attributes out), the parts of ``__reduce_ex__`` too;
    ``IncompleteFingerprint`` when neither can be read."""
    cls = type(value)
    plain = cls.__reduce_ex__ is object.__reduce_ex__ and cls.__reduce__ is object.__reduce__
    state: dict[str, Any] = {}
    attrs = getattr(value, "__dict__", None)
    if isinstance(attrs, dict):
        state.update(attrs)
    slots = [s for klass in cls.__mro__ for s in _slot_names(klass)]
    for name in slots:
        if name not in ("__dict__", "__weakref__") and hasattr(value, name):
            state[f"slot {name}"] = getattr(value, name)
    readable = isinstance(attrs, dict) or bool(slots)
    if plain and readable:
        return _named_state(state, loc)
    try:
        reduced = value.__reduce_ex__(4)
    except Exception as exc:  # any refusal of pickle means: unreadable
        raise IncompleteFingerprint(f"{_where(loc)} (a {cls.__qualname__}) cannot be read ({type(exc).__name__}: "
                                    f"{str(exc)[:120]}); pass policy_id to name this policy") from None
    own = _named_state(state, loc) if readable else []   # what its own __reduce__ may leave out
    if isinstance(reduced, str):      # a global singleton
        return [*own, (_VALUE, reduced, loc)]
    parts = list(reduced[1:3])
    parts += [list(p) if p is not None else None for p in reduced[3:5]]
    return [*own, (_VALUE, reduced[0], (loc, " constructor")),
            *((_VALUE, p, (loc, i)) for i, p in enumerate(parts))]


def _named_state(state: dict[str, Any], loc: Any) -> list[Item]:
    out: list[Item] = []
    for name in sorted(state):
        out += [(_TOKEN, f"|{name}=".encode(), loc), (_VALUE, state[name], (loc, f".{name.removeprefix('slot ')}"))]
    return out


def _slot_names(klass: type) -> tuple[str, ...]:
    slots = klass.__dict__.get("__slots__", ())
    return (slots,) if isinstance(slots, str) else tuple(slots)


def _torch() -> Any:
    """The torch module if something already imported it (a torch object cannot exist otherwise), else None."""
    return sys.modules.get("torch")


def _torch_children(value: Any, loc: Any) -> list[Item] | None:
    """A torch module (architecture text, state dict as arrays and every submodule's plain attributes) or tensor
    (its array); None for other values."""
    torch = _torch()
    if torch is None:
        return None
    if isinstance(value, torch.Tensor):
        return [(_VALUE, value.detach().cpu().numpy(), loc)]
    if isinstance(value, torch.nn.Module):
        arrays = {k: t.detach().cpu().numpy() for k, t in value.state_dict().items()}
        plain = {name: {k: v for k, v in vars(module).items() if not k.startswith("_") and k != "training"}
                 for name, module in value.named_modules()}
        plain = {name: attrs for name, attrs in plain.items() if attrs}
        out = [(_VALUE, repr(value), (loc, " architecture")), (_VALUE, arrays, (loc, " weights"))]
        return out + ([(_VALUE, plain, (loc, " attributes"))] if plain else [])
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
