"""One range check for every frozen parameter dataclass; the ranges are declared next to the fields.

A field declares its allowed range with :func:`ranged`, and ``__post_init__`` calls :func:`validate` once::

    @documented
    @dataclass(frozen=True)
    class Tyre:
        friction_mu: float = ranged(0.9, gt=0.0, le=2.0)
        width_m: float = ranged(0.2, gt=0.0, unit="m")

        def __post_init__(self) -> None:
            validate(self)

Convention: every bound is named by its comparison, as in ``value > gt``, ``value >= ge``, ``value < lt``,
``value <= le``; a side without a bound is unbounded. A bound may be the name of another (earlier) field of the same
object, e.g. ``ge="min_hold_m"``. Values must be finite numbers (``bool`` is not a number); ``integer=True`` also
requires an ``int``. Errors name ``Type.field``, the allowed range with its unit and the value, e.g.
``ValueError: ChassisParams.mass_kg must be > 0.0 kg (got -1.0)`` or
``ValueError: TyreParams.friction_mu must be in (0.0, 2.0] (got 3.0)``. :func:`describe` renders the same text
for documentation, and the :func:`documented` class decorator (put above ``@dataclass``) appends that table to
the class docstring.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import operator
from typing import Any, TypeVar

RANGE_KEY = "range"
"""Key of the :class:`Range` in a dataclass field's ``metadata``."""

OPTIONAL = "optional"
"""Key of a field's ``metadata``: ``True`` lets a field with a numeric default be ``None`` too."""

_T = TypeVar("_T")

Bound = float | str | None
"""A number, the name of another field of the same object, or ``None`` (unbounded)."""


@dataclasses.dataclass(frozen=True)
class Range:
    """Allowed values of one field: at most one lower bound (``gt`` or ``ge``) and one upper (``lt`` or ``le``)."""

    gt: Bound = None
    ge: Bound = None
    lt: Bound = None
    le: Bound = None
    unit: str = ""
    integer: bool = False

    def __post_init__(self) -> None:
        if self.gt is not None and self.ge is not None:
            raise ValueError("Range: give gt or ge, not both")
        if self.lt is not None and self.le is not None:
            raise ValueError("Range: give lt or le, not both")

    def text(self, owner: object | None = None) -> str:
        """The allowed range as text, e.g. ``"in (0.0, 2.0] m"`` or ``"> 0.0 kg"`` (bounds naming fields resolved
        against ``owner`` when given)."""
        lo = self.gt if self.gt is not None else self.ge
        hi = self.lt if self.lt is not None else self.le
        unit = f" {self.unit}" if self.unit else ""
        lo_txt, hi_txt = _bound_text(lo, owner), _bound_text(hi, owner)
        if lo is not None and hi is not None:
            body = f"in {'(' if self.gt is not None else '['}{lo_txt}, {hi_txt}{')' if self.lt is not None else ']'}"
        elif lo is not None:
            body = f"{'>' if self.gt is not None else '>='} {lo_txt}"
        elif hi is not None:
            body = f"{'<' if self.lt is not None else '<='} {hi_txt}"
        else:
            body = ""
        return f"{body}{unit}".strip()

    def contains(self, value: Any, owner: object | None = None) -> bool:
        """Whether ``value`` is a finite number (an ``int`` if ``integer``) within the bounds."""
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            return False
        if self.integer and not isinstance(value, numbers.Integral):
            return False
        v = float(value)
        if not math.isfinite(v):
            return False
        checks = ((self.gt, operator.gt), (self.ge, operator.ge), (self.lt, operator.lt), (self.le, operator.le))
        return all(bound is None or ok(v, _resolve(bound, owner)) for bound, ok in checks)

    def check(self, owner: object, name: str, value: Any = dataclasses.MISSING) -> None:
        """Raise ``ValueError`` naming ``Type.name``, the range and the value unless ``value`` (default: the
        field's value on ``owner``) is in range."""
        if value is dataclasses.MISSING:
            value = getattr(owner, name)
        if not self.contains(value, owner):
            kind = "an int" if self.integer else "a finite number"
            number = isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)
            text = f"{kind} {self.text(owner)}".rstrip() if self.integer or not number else self.text(owner)
            raise ValueError(f"{type(owner).__name__}.{name} must be {text} (got {value!r})")


def _resolve(bound: float | str, owner: object | None) -> float:
    if isinstance(bound, str):
        if owner is None:
            raise ValueError(f"bound {bound!r} names a field: pass the owner")
        return float(getattr(owner, bound))
    return bound


def _bound_text(bound: Bound, owner: object | None) -> str:
    if isinstance(bound, str) and owner is not None:
        return f"{bound} = {getattr(owner, bound)}"
    return str(bound)


def ranged(default: Any = dataclasses.MISSING, *, gt: Bound = None, ge: Bound = None, lt: Bound = None,
           le: Bound = None, unit: str = "", integer: bool = False, **field_kwargs: Any) -> Any:
    """A ``dataclasses.field`` with a default (optional) and a :class:`Range` in its metadata."""
    metadata = {**field_kwargs.pop("metadata", {}),
                RANGE_KEY: Range(gt=gt, ge=ge, lt=lt, le=le, unit=unit, integer=integer)}
    return dataclasses.field(default=default, metadata=metadata, **field_kwargs)


def range_of(cls_or_obj: Any, name: str) -> Range:
    """The :class:`Range` declared for field ``name`` of a dataclass (``KeyError`` if it has none)."""
    for f in dataclasses.fields(cls_or_obj):
        if f.name == name and RANGE_KEY in f.metadata:
            return f.metadata[RANGE_KEY]
    raise KeyError(f"{name!r} has no declared range")


def validate(obj: Any) -> None:
    """Check every field of dataclass ``obj`` that declares a :class:`Range`, in field order (and that every field
    annotated ``bool`` holds a ``bool``).

    A field whose default is ``None`` may be ``None`` (optional: "use the scenario's value"), as may a field
    declared ``ranged(..., metadata={OPTIONAL: True})`` (a number by default, ``None`` allowed).
    """
    for f in dataclasses.fields(obj):
        if f.type in ("bool", bool) and not isinstance(getattr(obj, f.name), bool):
            raise ValueError(f"{type(obj).__name__}.{f.name} must be a bool (got {getattr(obj, f.name)!r})")
        rng = f.metadata.get(RANGE_KEY)
        if rng is not None:
            value = getattr(obj, f.name)
            if value is not None or (f.default is not None and not f.metadata.get(OPTIONAL)):
                rng.check(obj, f.name, value)


def closed_ranges(cls: Any) -> dict[str, tuple[float, float]]:
    """Field name -> ``(lo, hi)`` for every field of dataclass ``cls`` declaring numeric ``ge`` and ``le`` bounds."""
    out: dict[str, tuple[float, float]] = {}
    for f in dataclasses.fields(cls):
        rng = f.metadata.get(RANGE_KEY)
        if rng is not None and not isinstance(rng.ge, (str, type(None))) and not isinstance(rng.le, (str, type(None))):
            out[f.name] = (rng.ge, rng.le)
    return out


def documented(cls: _T) -> _T:
    """Class decorator (outside ``@dataclass``): append the fields' allowed ranges to the class docstring, so that
    ``help()`` and the API docs show the same table the errors quote."""
    table = describe(cls)
    if table:
        width = max(map(len, table))
        doc = (cls.__doc__ or "").rstrip()
        body = [ln for ln in doc.splitlines()[1:] if ln.strip()]
        indent = min((len(ln) - len(ln.lstrip()) for ln in body), default=4) if body else 4
        pad = " " * indent
        rows = "\n".join(f"{pad}    {name.ljust(width)}  {text}" for name, text in table.items())
        cls.__doc__ = f"{doc}\n\n{pad}Allowed values (checked on construction):\n\n{rows}\n{pad}"
    return cls


def describe(cls: Any) -> dict[str, str]:
    """Field name -> allowed range as text, for every field of dataclass ``cls`` that declares one (for docs)."""
    out = {}
    for f in dataclasses.fields(cls):
        rng = f.metadata.get(RANGE_KEY)
        if rng is not None:
            out[f.name] = f"{'int ' if rng.integer else ''}{rng.text() or 'finite'}"
    return out
