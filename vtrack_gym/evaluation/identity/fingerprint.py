"""A policy's fingerprint for the leaderboard's ``policy_hash``: what can be read of it exactly, and how it acts.

``policy_hash(policy, env)`` digests, together (no part decides alone):

* its class and its declared identity: a ``weights_hash`` text (an exported agent's content hash), a frozen
  ``config`` dataclass (a baseline's preset or tuned config);
* its state: an SB3 algorithm's torch ``policy`` module (architecture, weights, plain attributes), VecNormalize
  statistics, or for any other object ALL of its state at any depth: numbers, strings, bytes, numpy arrays, torch
  modules and tensors, containers (dict and set order does not matter) with a subclass's own attributes, nested
  objects (their ``__dict__`` and ``__slots__``, and what they hand to pickle when the class pickles itself),
  functions (code, defaults and closure values) and classes. Environments, random generators, loggers and modules
  are left out (not parameters; a subclass's own attributes still count). Shared and cyclic references are read
  once and recorded as back-references;
* its behaviour (``probes.behaviour_digest``): its deterministic actions on fixed probe sequences of observations
  recorded from the package's scenarios, in ``env``'s observation layout. Reading an arbitrary object can never be
  complete (a gain in a global, a file it reads, a class attribute): two policies that act differently on the
  probes are two policies whatever they declare or hold.

The digest is the same in every process and under every hash seed (no ``id``, ``hash`` or memory address enters
it). Reading takes time and memory linear in the state's size and depth, and is bounded: ``MAX_STATE_BYTES`` bytes,
``MAX_DEPTH`` levels of nesting, ``MAX_OBJECTS`` objects, ``MAX_UNORDERED_NESTING`` sets in sets. A policy beyond a
bound, holding an object that cannot be read (an open file, a lock, an extension object that pickle refuses), or
that cannot be probed (cannot be copied, fails on the probes, acts differently twice) raises
:class:`IncompleteFingerprint` naming where; ``evaluate`` then refuses to store it unless it is given a
``policy_id`` (see :func:`named_policy_hash`). Two policies whose digests differ are never merged on the
leaderboard; two objects of one class with the same state and behaviour are one policy.
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

from vtrack_gym.evaluation.identity.probes import ProbeError

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


def policy_hash(policy: Any, env: Any = None, seen: dict[str, str] | None = None) -> str:
    """Short (12 hex digits) digest of what determines ``policy``'s actions (see the module docstring): its class,
    declared identity (``weights_hash``, ``config``), state and behaviour on the probe sequences in ``env``'s
    observation layout (the default layout without an env).

    A policy whose state cannot be read completely needs a declared identity and a probed behaviour; one that
    cannot be probed (cannot be copied, fails on the probes, acts differently twice) needs a completely read
    state; otherwise ``IncompleteFingerprint``.

    ``seen``: the digests already taken for one policy factory's episodes of a run, by class, declared identity,
    completely read state and observation layout; a policy matching one of them is not probed again (its
    digest is that one), as a run takes one fingerprint for all the episodes of a policy. Without it (the
    default) every call probes.
    """
    parts, depth = _parts_and_depth(policy)
    key = _seen_key(parts, env) if seen is not None else None
    if seen is not None and key is not None and key in seen:
        return seen[key]
    digest = _digest(policy, env, parts, depth)
    if seen is not None and key is not None:
        seen[key] = digest
    return digest


def _seen_key(parts: dict[str, Any], env: Any) -> str | None:
    """What ``policy_hash``'s ``seen`` is keyed by: the identity parts and the probes' layout (None, not kept,
    for a state that cannot be read completely or an env without a vtrack observation layout)."""
    from vtrack_gym.evaluation.identity.probes import layout_names

    names = layout_names(env)
    if parts["state"] == UNREADABLE or names is None:
        return None
    return json.dumps([parts, names], sort_keys=True, separators=(",", ":"))


def _digest(policy: Any, env: Any, parts: dict[str, Any], depth: int) -> str:
    """``policy_hash`` from the identity parts read already (``_parts_and_depth``): the behaviour added."""
    state = parts["state"]
    try:
        if depth > MAX_PROBED_DEPTH:
            raise ProbeError(f"it is nested more than {MAX_PROBED_DEPTH} levels deep, too deep to copy safely")
        parts["behaviour"] = _behaviour(policy, env, None if state == UNREADABLE else state)
    except ProbeError as exc:
        if state == UNREADABLE:
            raise IncompleteFingerprint(f"policy: its state cannot be read completely and {exc}; pass policy_id "
                                        "to name this policy") from None
        parts["behaviour"] = "not probed"    # identified by its complete state
    return _short(parts)


UNREADABLE = "unreadable"
"""The state part of a policy whose state cannot be read completely but that declares its identity."""
MAX_PROBED_DEPTH = 200
"""A policy whose state is nested deeper is not probed (copying it would recurse that deep)."""


def identity_parts(policy: Any) -> dict[str, Any]:
    """What can be read of ``policy`` exactly: its class, its declared identity (a ``weights_hash`` text, a
    ``config`` dataclass) and the digest of its state (``UNREADABLE`` for a policy with a declared identity);
    ``IncompleteFingerprint`` if the state cannot be read and nothing is declared."""
    return _parts_and_depth(policy)[0]


def _parts_and_depth(policy: Any) -> tuple[dict[str, Any], int]:
    """``identity_parts`` and the depth of the state read (0 when it could not be read)."""
    cfg = getattr(policy, "config", None)
    config: Any = None
    if dataclasses.is_dataclass(cfg) and not isinstance(cfg, type):
        try:
            config = json.loads(json.dumps(dataclasses.asdict(cfg), sort_keys=True, allow_nan=False))
        except (TypeError, ValueError):
            config = state_digest(cfg, "policy.config")
    weights = getattr(policy, "weights_hash", None)
    weights = weights if isinstance(weights, str) and weights else None
    depth = 0
    try:
        state = sb3_or_normalised_digest(policy)
        if state is None:
            walker = _Walker(MAX_STATE_BYTES, [0], 0, display_attributes(policy))
            walker.walk(policy, "policy")
            state, depth = walker.hexdigest(), walker.deepest
    except IncompleteFingerprint:
        if config is None and weights is None:
            raise
        state = UNREADABLE   # a declared identity, checked by the behaviour part
    return {"class": _qualname(type(policy)), "weights_hash": weights, "config": config, "state": state}, depth


def display_attributes(policy: Any) -> tuple[str, ...]:
    """Attributes of ``policy`` that name it and never act (its class's ``display_attributes``, e.g. an agent's
    file stem): left out of its state digest, so one content under two names is one policy. What acts is
    still read, and the behaviour part would tell a gain hidden there."""
    names = getattr(type(policy), "display_attributes", ())
    if not (isinstance(names, tuple) and all(isinstance(n, str) for n in names)):
        raise ValueError(f"{type(policy).__qualname__}.display_attributes must be a tuple of attribute names "
                         f"(got {names!r})")
    return names


def _behaviour(policy: Any, env: Any, state: str | None) -> str | None:
    """The behaviour digest of a policy (None for an object without ``predict``, e.g. a tuned config); ``state``:
    the policy's state digest, which each probed copy must have too (None: not checked)."""
    if not callable(getattr(policy, "predict", None)):
        return None
    from vtrack_gym.evaluation.identity.probes import behaviour_digest

    def faithful(copied: Any) -> bool:
        try:
            return (sb3_or_normalised_digest(copied)
                    or state_digest(copied, "copy", skip=display_attributes(copied))) == state
        except IncompleteFingerprint:
            return False

    return behaviour_digest(policy, env, faithful if state is not None else None)


def _short(parts: dict[str, Any]) -> str:
    text = json.dumps(parts, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def named_policy_hash(policy: Any, policy_id: str, env: Any = None) -> str:
    """``policy_hash``, or, when it is incomplete, a digest of the class, the user's ``policy_id`` (the name then
    identifies the policy) and the behaviour on the probes where it can be probed (so two policies given one name
    that act differently are still two rows)."""
    try:
        return policy_hash(policy, env)
    except IncompleteFingerprint:
        try:
            behaviour = _behaviour(policy, env, None)
        except ProbeError:
            behaviour = "not probed"
        return _short({"named": policy_id, "class": _qualname(type(policy)), "behaviour": behaviour})


def state_digest(obj: Any, name: str = "value", budget: int = MAX_STATE_BYTES,
                 skip: tuple[str, ...] = ()) -> str:
    """Full SHA-256 hex digest of ``obj``'s state (see the module docstring); ``IncompleteFingerprint`` beyond
    ``budget`` bytes, ``MAX_DEPTH`` levels, ``MAX_OBJECTS`` objects or at an unreadable object (``name``: how the
    message calls ``obj``; ``skip``: attributes of ``obj`` itself left out). Time and memory are linear in the size
    and depth of the state."""
    walker = _Walker(budget, [0], 0, skip)
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

    def __init__(self, budget: int, objects: list[int], nesting: int, skip: tuple[str, ...] = ()) -> None:
        self.budget = budget
        self.skip = skip              # attributes of the root object left out
        self.fed = 0
        self.digest = hashlib.sha256()
        self.memo: dict[int, int] = {}
        self.alive: list[Any] = []    # keeps memoised temporaries alive, so their ids are never reused
        self.objects = objects        # objects read, shared with the sub-walkers of unordered containers
        self.nesting = nesting        # sub-walkers this one sits in
        self.deepest = 0              # the most containers open at once

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
                self.deepest = max(self.deepest, len(stack) - 1)

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
        torch_items = self._torch_children(value, loc)
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
            own = isinstance(value, random.Random) and type(value) not in (random.Random, random.SystemRandom)
            return _frame(_extra_attributes(value, loc)) if own else None   # a subclass's attributes count
        if isinstance(value, type):
            self.feed(f"class {_qualname(value)}".encode(), loc)
            return None
        if _is_compiled(value):                 # a numba dispatcher: the Python function it compiles
            self.feed(f"compiled {tag}".encode(), loc)
            return _frame([(_VALUE, value.py_func, (loc, ".py_func"))])
        if isinstance(value, (types.FunctionType, types.MethodType, types.BuiltinFunctionType,
                              types.CodeType, types.CellType)):
            return _frame(self._callable_children(value, loc))
        self.feed(f"<{tag}>".encode(), loc)
        return _frame(_object_state(value, loc, self.skip if isinstance(loc, str) else ()))

    def _torch_children(self, value: Any, loc: Any) -> list[Item] | None:
        """A torch module (architecture text, state dict as arrays, every submodule's plain attributes, each read
        on its own so that how they share objects does not count) or tensor (its array); None for other values."""
        torch = _torch()
        if torch is None:
            return None
        if isinstance(value, torch.Tensor):
            return [(_VALUE, value.detach().cpu().numpy(), loc)]
        if not isinstance(value, torch.nn.Module):
            return None
        arrays = {k: t.detach().cpu().numpy() for k, t in value.state_dict().items()}
        plain = {name: {k: self._sub_digest(v, (loc, f" attribute {name}.{k}")) for k, v in vars(module).items()
                        if not k.startswith("_") and k != "training"} for name, module in value.named_modules()}
        plain = {name: attrs for name, attrs in plain.items() if attrs}
        out = [(_VALUE, repr(value), (loc, " architecture")), (_VALUE, arrays, (loc, " weights"))]
        return out + ([(_VALUE, plain, (loc, " attributes"))] if plain else [])

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
    """The instance attributes of a container subclass (a ``dict`` subclass holding a gain) or of a
    ``random.Random`` subclass (its generator state, ``gauss_next``, left out)."""
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


def _is_compiled(value: Any) -> bool:
    """A numba dispatcher (its compiled code follows from its ``py_func`` and the types it is called with)."""
    return type(value).__module__.startswith("numba.") and isinstance(getattr(value, "py_func", None),
                                                                       types.FunctionType)


def _is_left_out(value: Any) -> bool:
    """Environments, random generators, loggers, modules and torch optimisers: not a policy's parameters (training
    or run state; what acts is read from the weights and, always, the behaviour)."""
    torch = _torch()
    return (isinstance(value, (types.ModuleType, np.random.Generator, np.random.RandomState, random.Random,
                               np.random.BitGenerator, logging.Logger))
            or (torch is not None and isinstance(value, torch.optim.Optimizer))
            or (hasattr(value, "reset") and hasattr(value, "step") and hasattr(value, "action_space")))


def _object_state(value: Any, loc: Any, skip: tuple[str, ...] = ()) -> list[Item]:
    """What an object holds: its ``__dict__`` and ``__slots__``, and, for a class with its own pickling (an
    extension type, or a class whose ``__reduce__`` leaves attributes out), the parts of ``__reduce_ex__`` too;
    ``IncompleteFingerprint`` when neither can be read."""
    cls = type(value)
    plain = cls.__reduce_ex__ is object.__reduce_ex__ and cls.__reduce__ is object.__reduce__
    state: dict[str, Any] = {}
    attrs = getattr(value, "__dict__", None)
    if isinstance(attrs, dict):
        state.update((k, v) for k, v in attrs.items() if k not in skip)
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
        return state_digest({"class": cls, "inner": _short(identity_parts(module)),
                             "stats": [stats.mean, stats.var, getattr(vn, "clip_obs", None),
                                       getattr(vn, "epsilon", None), getattr(vn, "norm_obs", None)]}, "policy")
    return None
