"""Vehicles as data: small JSON files, strictly parsed into :class:`VehicleParams`, selected by name or path.

A vehicle file (``vtrack_gym/vehicle/data/<name>.json`` for the shipped cars) is one JSON object::

    {
      "format": "vtrack-vehicle/1",
      "name": "C-Class Hatchback (paper)",
      "description": "one paragraph: what car this is and where its numbers come from",
      "chassis": {
        "mass_kg": {"value": 1413.0, "source": "paper, Nomenclature m"},
        ...
      },
      "tyres": {...}, "roll": {...}, "steering": {...}, "powertrain": {...}, "brakes": {...}, "low_speed": {...}
    }

Every group of :class:`VehicleParams` and every field of every group must be present, each as
``{"value": <finite number>, "source": "<non-empty text>"}``. The shipped files start every source with its kind
(``SOURCE_TAGS``): ``paper`` (the paper's Nomenclature), ``IDSC`` (the public reproduction of the paper's CarSim
car), ``ISA`` (standard atmosphere), ``SPEC (from memory, unverified)`` (a manufacturer's published figure as
recalled, not checked against a document), ``ESTIMATE`` (inferred from typical values) or ``CHOICE`` (our own
modelling choice). Unknown keys, missing keys, duplicate keys, non-finite numbers (``NaN``/``Infinity``), booleans
or strings where a number belongs are errors naming the key (``VehicleFileError``, a ``ValueError``), and so is
any value outside the field's declared range. Files are read only if they are regular files of at most
``MAX_VEHICLE_FILE_BYTES``.
"""

from __future__ import annotations

import json
import math
import numbers
import os
import stat
from dataclasses import dataclass, fields
from importlib import resources
from pathlib import Path
from typing import Any

from vtrack_gym.vehicle.params import VehicleParams

FORMAT = "vtrack-vehicle/1"
"""The ``format`` tag every vehicle file carries."""

MAX_VEHICLE_FILE_BYTES = 64 * 1024
"""Largest vehicle file read [bytes] (the shipped ones are ~10 kB)."""

DEFAULT_VEHICLE = "hatchback"
"""Name of the shipped file holding the paper's car (equal to ``VehicleParams()``)."""

SOURCE_TAGS: tuple[str, ...] = ("paper", "IDSC", "ISA", "SPEC (from memory, unverified)", "ESTIMATE", "CHOICE")
"""How every source text of a shipped vehicle file begins (its kind of provenance, see the module docstring)."""

_TOP_KEYS = ("format", "name", "description")
_ENTRY_KEYS = ("value", "source")


class VehicleFileError(ValueError):
    """A vehicle file that cannot be read or does not follow the format; the message names the key."""


@dataclass(frozen=True)
class VehicleRecord:
    """A parsed vehicle file: the parameters plus the provenance text of every value."""

    params: VehicleParams
    description: str
    sources: dict[str, dict[str, str]]
    """Group -> field -> source text (``CHOICE...`` for modelling choices)."""

    def to_json(self) -> str:
        """The file text (``parse_vehicle(record.to_json()) == record``)."""
        doc: dict[str, Any] = {"format": FORMAT, "name": self.params.name, "description": self.description}
        for group_name, group_fields in _groups():
            group = getattr(self.params, group_name)
            doc[group_name] = {name: {"value": getattr(group, name), "source": self.sources[group_name][name]}
                               for name in group_fields}
        return json.dumps(doc, indent=2, allow_nan=False) + "\n"


def _groups() -> list[tuple[str, tuple[str, ...]]]:
    """(group name, field names) of every parameter group of ``VehicleParams``, in declaration order."""
    default = VehicleParams()
    return [(f.name, tuple(g.name for g in fields(getattr(default, f.name))))
            for f in fields(VehicleParams) if f.name != "name"]


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise VehicleFileError(f"duplicate key {key!r}")
        out[key] = value
    return out


def _reject_constant(token: str) -> float:
    raise VehicleFileError(f"non-finite number {token} (only finite numbers are allowed)")


def _exact_keys(obj: Any, expected: tuple[str, ...], where: str) -> dict[str, Any]:
    if not isinstance(obj, dict):
        raise VehicleFileError(f"{where} must be a JSON object (got {type(obj).__name__})")
    unknown = [k for k in obj if k not in expected]
    if unknown:
        raise VehicleFileError(f"unknown key {where + '.' if where != '<file>' else ''}{unknown[0]} "
                               f"(allowed: {', '.join(expected)})")
    missing = [k for k in expected if k not in obj]
    if missing:
        raise VehicleFileError(f"missing key {where + '.' if where != '<file>' else ''}{missing[0]}")
    return obj


def _text(value: Any, key: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise VehicleFileError(f"{key} must be a non-empty string (got {value!r})")
    return value


def parse_vehicle(text: str) -> VehicleRecord:
    """Parse and validate the text of a vehicle file (see the module docstring)."""
    try:
        doc = json.loads(text, object_pairs_hook=_no_duplicates, parse_constant=_reject_constant)
    except json.JSONDecodeError as exc:
        raise VehicleFileError(f"not valid JSON: {exc}") from None
    groups = _groups()
    doc = _exact_keys(doc, _TOP_KEYS + tuple(g for g, _ in groups), "<file>")
    if doc["format"] != FORMAT:
        raise VehicleFileError(f"format must be {FORMAT!r} (got {doc['format']!r})")
    name = _text(doc["name"], "name")
    description = _text(doc["description"], "description")
    default = VehicleParams()
    built: dict[str, Any] = {}
    sources: dict[str, dict[str, str]] = {}
    for group_name, group_fields in groups:
        entries = _exact_keys(doc[group_name], group_fields, group_name)
        values: dict[str, float] = {}
        sources[group_name] = {}
        for field_name in group_fields:
            key = f"{group_name}.{field_name}"
            entry = _exact_keys(entries[field_name], _ENTRY_KEYS, key)
            value = entry["value"]
            if isinstance(value, bool) or not isinstance(value, numbers.Real):
                raise VehicleFileError(f"{key}.value must be a number (got {value!r})")
            if not math.isfinite(value):
                raise VehicleFileError(f"{key}.value must be finite (got {value!r})")
            values[field_name] = float(value)
            sources[group_name][field_name] = _text(entry["source"], f"{key}.source")
        try:
            built[group_name] = type(getattr(default, group_name))(**values)
        except ValueError as exc:
            raise VehicleFileError(f"{group_name}: {exc}") from None
    try:
        params = VehicleParams(name=name, **built)
    except ValueError as exc:
        raise VehicleFileError(str(exc)) from None
    return VehicleRecord(params, description, sources)


def _data_dir() -> Path:
    return Path(str(resources.files("vtrack_gym.vehicle") / "data"))


def list_vehicles() -> tuple[str, ...]:
    """Names of the shipped vehicles (``load_vehicle`` accepts each), sorted."""
    return tuple(sorted(p.stem for p in _data_dir().glob("*.json")))


def _read_capped(path: Path) -> str:
    """Text of ``path`` if it is a regular file of at most ``MAX_VEHICLE_FILE_BYTES``."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as exc:
        raise VehicleFileError(f"{path}: cannot open ({exc.strerror})") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise VehicleFileError(f"{path}: not a regular file")
        if info.st_size > MAX_VEHICLE_FILE_BYTES:
            raise VehicleFileError(f"{path}: {info.st_size} bytes exceeds the limit of {MAX_VEHICLE_FILE_BYTES}")
        data = os.read(fd, MAX_VEHICLE_FILE_BYTES + 1)
    finally:
        os.close(fd)
    if len(data) > MAX_VEHICLE_FILE_BYTES:
        raise VehicleFileError(f"{path}: exceeds the limit of {MAX_VEHICLE_FILE_BYTES} bytes")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise VehicleFileError(f"{path}: not UTF-8 text") from None


def _resolve(name_or_path: str | os.PathLike[str]) -> Path:
    if isinstance(name_or_path, str) and name_or_path in list_vehicles():
        return _data_dir() / f"{name_or_path}.json"
    path = Path(name_or_path)
    if isinstance(name_or_path, str) and path.suffix != ".json" and os.sep not in name_or_path:
        raise VehicleFileError(f"unknown vehicle {name_or_path!r}; shipped: {', '.join(list_vehicles())} "
                               "(or give the path of a .json vehicle file)")
    return path


def load_vehicle_record(name_or_path: str | os.PathLike[str]) -> VehicleRecord:
    """The parsed file of a shipped vehicle name (see :func:`list_vehicles`) or of a vehicle file path."""
    path = _resolve(name_or_path)
    try:
        return parse_vehicle(_read_capped(path))
    except VehicleFileError as exc:
        msg = str(exc)
        raise VehicleFileError(msg if msg.startswith(str(path)) else f"{path}: {msg}") from None


def load_vehicle(name_or_path: str | os.PathLike[str]) -> VehicleParams:
    """``VehicleParams`` of a shipped vehicle name (``"hatchback"``, ``"suv"``, ...) or of a vehicle file path."""
    return load_vehicle_record(name_or_path).params


def resolve_vehicle(vehicle: VehicleParams | str | os.PathLike[str] | None) -> VehicleParams:
    """``VehicleParams`` as given, loaded by name/path, or the default car for ``None``."""
    if vehicle is None:
        return VehicleParams()
    if isinstance(vehicle, VehicleParams):
        return vehicle
    if isinstance(vehicle, (str, os.PathLike)):
        return load_vehicle(vehicle)
    raise TypeError(f"vehicle must be VehicleParams, a vehicle name or a file path (got {type(vehicle).__name__})")


def record_from_params(params: VehicleParams, description: str, source: str) -> VehicleRecord:
    """A record for ``params`` with the same ``source`` text on every value (e.g. for a derived car)."""
    return VehicleRecord(params, description,
                         {g: dict.fromkeys(names, source) for g, names in _groups()})


__all__ = [
    "DEFAULT_VEHICLE",
    "FORMAT",
    "MAX_VEHICLE_FILE_BYTES",
    "SOURCE_TAGS",
    "VehicleFileError",
    "VehicleRecord",
    "list_vehicles",
    "load_vehicle",
    "load_vehicle_record",
    "parse_vehicle",
    "record_from_params",
    "resolve_vehicle",
]
