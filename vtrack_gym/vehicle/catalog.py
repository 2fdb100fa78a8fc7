"""Vehicles as data: small JSON files, strictly parsed into :class:`VehicleParams`, selected by name or path.

A vehicle file (``vtrack_gym/vehicle/data/<name>.json`` for the shipped cars) is one JSON object::

    {
      "format": "vtrack-vehicle/2",
      "name": "C-Class Hatchback (paper)",
      "description": "one paragraph: what car this is and where its numbers come from",
      "chassis": {
        "mass_kg": {"value": 1413.0, "source": "paper, Nomenclature m"},
        ...
      },
      "tyres": {...}, "roll": {...}, "steering": {...}, "powertrain": {...}, "brakes": {...}, "low_speed": {...}
    }

Every group of :class:`VehicleParams` and every field of every group must be present, each as
``{"value": <finite number>, "source": "<non-empty text>"}``, except that the roll group gives the sprung mass's
roll inertia about its own CG, ``roll_inertia_cg_kgm2`` (the convention of published data and of CommonRoad's
vehicle models), and the roll-axis value the plant's roll equation uses is derived from it:
``RollParams.roll_inertia_kgm2`` = I_x,cg + m_s h_s^2 (:func:`roll_axis_inertia_kgm2`; m_s the sprung mass, h_s
its CG's height above the roll axis). Files of the earlier format ``vtrack-vehicle/1`` give
``roll_inertia_kgm2`` (about the roll axis) instead and are still read; they may leave out
``tyres.relaxation_length_m`` (then 0, off).

The shipped files start every source with its kind (``SOURCE_TAGS``): ``paper`` (the paper's Nomenclature), ``IDSC``
(the public reproduction of the paper's CarSim car), ``ADTM`` (the Formula Student template of TUM's public
Advanced Dual Track Model), ``AMZ`` (AMZ Racing's public fssim car, the car of the AMZ Driverless paper),
``ISA`` (standard atmosphere), ``SPEC (from memory,
unverified)`` (a manufacturer's published figure as recalled, not checked against a document), ``ESTIMATE``
(inferred from typical values) or ``CHOICE`` (our own modelling choice). Unknown keys, missing keys, duplicate keys,
non-finite numbers (``NaN``/``Infinity``), booleans or strings where a number belongs are errors naming the key
(``VehicleFileError``, a ``ValueError``), and so is any value outside the field's declared range. Files are read
only if they are regular files of at most ``MAX_VEHICLE_FILE_BYTES``.
"""

from __future__ import annotations

import hashlib
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

FORMAT = "vtrack-vehicle/2"
"""The ``format`` tag of the current vehicle files: the roll group holds ``roll_inertia_cg_kgm2``."""

FORMAT_V1 = "vtrack-vehicle/1"
"""The earlier format, still read: the roll group holds ``roll_inertia_kgm2`` (about the roll axis) instead."""

ROLL_CG_FIELD = "roll_inertia_cg_kgm2"
"""Key of the sprung mass's roll inertia about its own CG [kg m^2] in the roll group of a ``FORMAT`` file."""

RELAXATION_FIELD = "relaxation_length_m"
RELAXATION_OFF_SOURCE = "CHOICE: off (0 m; the earlier file format has no tyre relaxation length)"
"""A ``FORMAT_V1`` file may leave out ``tyres.relaxation_length_m``: it is then 0 (off), with this source."""

MAX_VEHICLE_FILE_BYTES = 64 * 1024
"""Largest vehicle file read [bytes] (the shipped ones are ~10 kB)."""

DEFAULT_VEHICLE = "hatchback"
"""Name of the shipped file holding the paper's car (equal to ``VehicleParams()``)."""

SOURCE_TAGS: tuple[str, ...] = ("paper", "IDSC", "ADTM", "AMZ", "ISA", "SPEC (from memory, unverified)", "ESTIMATE",
                                 "CHOICE")
"""How every source text of a shipped vehicle file begins (its kind of provenance, see the module docstring)."""

_TOP_KEYS = ("format", "name", "description")
_ENTRY_KEYS = ("value", "source")


class VehicleFileError(ValueError):
    """A vehicle file that cannot be read or does not follow the format; the message names the key."""


def roll_axis_inertia_kgm2(roll_inertia_cg_kgm2: float, sprung_mass_kg: float, sprung_cg_above_roll_axis_m: float
                           ) -> float:
    """The sprung mass's roll inertia about the roll axis [kg m^2] (what the plant's roll equation uses):
    I_x,cg + m_s h_s^2 (parallel axes), from its inertia about its own CG [kg m^2], its mass [kg] and its CG's
    height above the roll axis h_s [m]."""
    return roll_inertia_cg_kgm2 + sprung_mass_kg * sprung_cg_above_roll_axis_m * sprung_cg_above_roll_axis_m


@dataclass(frozen=True)
class VehicleRecord:
    """A parsed vehicle file: the parameters plus the provenance text of every value.

    ``roll_inertia_cg_kgm2`` [kg m^2]: the sprung mass's roll inertia about its CG as the file gives it (format
    ``FORMAT``); ``params.roll.roll_inertia_kgm2`` is then the roll-axis value derived from it
    (:func:`roll_axis_inertia_kgm2`). None for a ``FORMAT_V1`` file, which gives the roll-axis value itself."""

    params: VehicleParams
    description: str
    sources: dict[str, dict[str, str]]
    """Group -> field -> source text, with the file's keys (``CHOICE...`` for modelling choices)."""
    roll_inertia_cg_kgm2: float | None = None

    def to_json(self) -> str:
        """The file text (``parse_vehicle(record.to_json()) == record``), in the format the record was read from."""
        v2 = self.roll_inertia_cg_kgm2 is not None
        doc: dict[str, Any] = {"format": FORMAT if v2 else FORMAT_V1, "name": self.params.name,
                               "description": self.description}
        for group_name, group_fields in _groups(v2):
            group = getattr(self.params, group_name)
            doc[group_name] = {name: {"value": self.roll_inertia_cg_kgm2 if name == ROLL_CG_FIELD
                                      else getattr(group, name), "source": self.sources[group_name][name]}
                               for name in group_fields}
        return json.dumps(doc, indent=2, allow_nan=False) + "\n"


def _groups(v2: bool = True) -> list[tuple[str, tuple[str, ...]]]:
    """(group name, field names) of every parameter group of a vehicle file, in declaration order: the fields of
    ``VehicleParams``, with ``roll_inertia_kgm2`` replaced by ``ROLL_CG_FIELD`` in a ``FORMAT`` (``v2``) file."""
    default = VehicleParams()
    out = []
    for f in fields(VehicleParams):
        if f.name == "name":
            continue
        names = tuple(g.name for g in fields(getattr(default, f.name)))
        if v2 and f.name == "roll":
            names = tuple(ROLL_CG_FIELD if n == "roll_inertia_kgm2" else n for n in names)
        out.append((f.name, names))
    return out


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


def _read_group(entries: dict[str, Any], group_name: str) -> tuple[dict[str, float], dict[str, str]]:
    """Values and source texts of one group's (already key-checked) entries."""
    values: dict[str, float] = {}
    sources: dict[str, str] = {}
    for field_name, raw in entries.items():
        key = f"{group_name}.{field_name}"
        entry = _exact_keys(raw, _ENTRY_KEYS, key)
        value = entry["value"]
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise VehicleFileError(f"{key}.value must be a number (got {value!r})")
        if not math.isfinite(value):
            raise VehicleFileError(f"{key}.value must be finite (got {value!r})")
        values[field_name] = float(value)
        sources[field_name] = _text(entry["source"], f"{key}.source")
    return values, sources


def _roll_axis_from_cg(values: dict[str, float], chassis: Any) -> float:
    """Pop ``ROLL_CG_FIELD`` from a roll group's values and put the derived roll-axis inertia in its place."""
    cg_value = values.pop(ROLL_CG_FIELD)
    if not cg_value > 0.0:
        raise VehicleFileError(f"roll.{ROLL_CG_FIELD} must be > 0 kg m^2 (got {cg_value})")
    m_s = chassis.mass_kg - values["unsprung_mass_kg"]
    h_s = chassis.cg_height_m - values["roll_centre_height_m"]
    values["roll_inertia_kgm2"] = roll_axis_inertia_kgm2(cg_value, m_s, h_s)
    return cg_value


def parse_vehicle(text: str) -> VehicleRecord:
    """Parse and validate the text of a vehicle file (see the module docstring)."""
    try:
        doc = json.loads(text, object_pairs_hook=_no_duplicates, parse_constant=_reject_constant)
    except json.JSONDecodeError as exc:
        raise VehicleFileError(f"not valid JSON: {exc}") from None
    if not isinstance(doc, dict) or doc.get("format") not in (FORMAT, FORMAT_V1):
        found = doc.get("format") if isinstance(doc, dict) else None
        raise VehicleFileError(f"format must be {FORMAT!r} (or the earlier {FORMAT_V1!r}; got {found!r})")
    v2 = doc["format"] == FORMAT
    groups = _groups(v2)
    doc = _exact_keys(doc, _TOP_KEYS + tuple(g for g, _ in groups), "<file>")
    name = _text(doc["name"], "name")
    description = _text(doc["description"], "description")
    default = VehicleParams()
    built: dict[str, Any] = {}
    sources: dict[str, dict[str, str]] = {}
    roll_cg = None
    for group_name, group_fields in groups:
        entries = doc[group_name]
        if not v2 and group_name == "tyres" and isinstance(entries, dict) and RELAXATION_FIELD not in entries:
            entries = {**entries, RELAXATION_FIELD: {"value": 0.0, "source": RELAXATION_OFF_SOURCE}}
        values, sources[group_name] = _read_group(_exact_keys(entries, group_fields, group_name), group_name)
        if v2 and group_name == "roll":
            roll_cg = _roll_axis_from_cg(values, built["chassis"])
        try:
            built[group_name] = type(getattr(default, group_name))(**values)
        except ValueError as exc:
            raise VehicleFileError(f"{group_name}: {exc}") from None
    try:
        params = VehicleParams(name=name, **built)
    except ValueError as exc:
        raise VehicleFileError(str(exc)) from None
    return VehicleRecord(params, description, sources, roll_cg)


def _data_dir() -> Path:
    return Path(str(resources.files("vtrack_gym.vehicle") / "data"))


def list_vehicles() -> tuple[str, ...]:
    """Names of the shipped vehicles (``load_vehicle`` accepts each), sorted."""
    return tuple(sorted(p.stem for p in _data_dir().glob("*.json")))


def _read_capped(path: Path) -> str:
    """Text of ``path`` if it is a regular file of at most ``MAX_VEHICLE_FILE_BYTES``."""
    try:
        return _read_capped_bytes(path).decode("utf-8")
    except UnicodeDecodeError:
        raise VehicleFileError(f"{path}: not UTF-8 text") from None


def _read_capped_bytes(path: Path) -> bytes:
    """Bytes of ``path`` if it is a regular file of at most ``MAX_VEHICLE_FILE_BYTES`` (read once)."""
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
    return data


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


@dataclass(frozen=True)
class VehicleFile:
    """A vehicle file read once: its ``path`` (as given), the SHA-256 of the bytes read and the parameters parsed
    from those same bytes. A run reads a ``--vehicle FILE`` once into this and hands it to every env it makes and
    to every row it records, so a file saved during the run changes neither (``str()`` is the path)."""

    path: str
    sha256: str
    params: VehicleParams

    def __post_init__(self) -> None:
        if not isinstance(self.params, VehicleParams):
            raise TypeError(f"params must be VehicleParams (got {type(self.params).__name__})")
        if len(self.sha256) != 64:
            raise ValueError(f"sha256 must be 64 hex digits (got {self.sha256!r:.80})")

    def __str__(self) -> str:
        return self.path

    @property
    def label(self) -> str:
        """``<file stem>-<sha256[:10]>``: what a row records of this car (two contents never mix)."""
        return f"{Path(self.path).stem}-{self.sha256[:10]}"


def read_vehicle_once(vehicle: str | os.PathLike[str] | VehicleFile | None) -> str | VehicleFile | None:
    """``vehicle`` as a run uses it: ``None`` and shipped names as given, a vehicle file read once into a
    ``VehicleFile`` (``VehicleFileError`` for a bad file)."""
    if vehicle is None or isinstance(vehicle, VehicleFile) or (isinstance(vehicle, str) and vehicle in list_vehicles()):
        return vehicle
    path = _resolve(vehicle)
    data = _read_capped_bytes(path)
    try:
        record = parse_vehicle(data.decode("utf-8"))
    except UnicodeDecodeError:
        raise VehicleFileError(f"{path}: not UTF-8 text") from None
    except VehicleFileError as exc:
        msg = str(exc)
        raise VehicleFileError(msg if msg.startswith(str(path)) else f"{path}: {msg}") from None
    return VehicleFile(os.fspath(vehicle), hashlib.sha256(data).hexdigest(), record.params)


def resolve_vehicle(vehicle: VehicleParams | VehicleFile | str | os.PathLike[str] | None) -> VehicleParams:
    """``VehicleParams`` as given (or of a ``VehicleFile``), loaded by name/path, or the default car for
    ``None``."""
    if vehicle is None:
        return VehicleParams()
    if isinstance(vehicle, VehicleParams):
        return vehicle
    if isinstance(vehicle, VehicleFile):
        return vehicle.params
    if isinstance(vehicle, (str, os.PathLike)):
        return load_vehicle(vehicle)
    raise TypeError(f"vehicle must be VehicleParams, a vehicle name or a file path (got {type(vehicle).__name__})")


def record_from_params(params: VehicleParams, description: str, source: str) -> VehicleRecord:
    """A record for ``params`` with the same ``source`` text on every value (e.g. for a derived car); it is written
    in the ``FORMAT_V1`` form (roll inertia about the roll axis, as ``params`` holds it)."""
    return VehicleRecord(params, description,
                         {g: dict.fromkeys(names, source) for g, names in _groups(v2=False)})


__all__ = [
    "DEFAULT_VEHICLE",
    "FORMAT",
    "FORMAT_V1",
    "MAX_VEHICLE_FILE_BYTES",
    "ROLL_CG_FIELD",
    "SOURCE_TAGS",
    "VehicleFile",
    "VehicleFileError",
    "VehicleRecord",
    "list_vehicles",
    "load_vehicle",
    "load_vehicle_record",
    "parse_vehicle",
    "read_vehicle_once",
    "record_from_params",
    "resolve_vehicle",
    "roll_axis_inertia_kgm2",
]
