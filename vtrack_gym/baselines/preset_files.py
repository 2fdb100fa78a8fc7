"""Tuned-preset files: JSON only (never executed, never unpickled), strict schema, unknown keys refused.

Format (``format_version`` 1)::

    {"format": "vtrack-tuned-preset", "format_version": 1, "controller": "smc",
     "config": {<every SMCConfig / MPCConfig field>},
     "speed_controller": {"g1": .., "g2": .., "g3": .., "g4": ..},     # PD-FLC gains the GA tuned (optional)
     "provenance": {"command": .., "seed": .., "budget": {..}, "space": {..}, "best_fitness": ..,
                    "metrics": {..}, "package_version": .., "date_utc": .., "scenario": .., "wall_time_s": ..,
                    "backend": "local" | "ray"}}

``make_policy("smc", env, preset="tuned")`` loads ``vtrack_gym/baselines/presets/smc_tuned.json`` (shipped
with the package if a tuning run was accepted); without that file it raises ``ValueError``. The PD-FLC gains
belong to the env (``EnvConfig(speed_controller=...)``), not to the steering policy: ``load_preset`` returns
them, ``make_policy`` ignores them.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import json
import math
from pathlib import Path
from typing import Any, ClassVar

FORMAT = "vtrack-tuned-preset"
FORMAT_VERSION = 1
MAX_BYTES = 1 << 20
PACKAGED_DIR = Path(__file__).resolve().parent / "presets"
TOP_KEYS = {"format", "format_version", "controller", "config", "speed_controller", "provenance"}
PROVENANCE_KEYS = {"command", "seed", "budget", "space", "best_fitness", "metrics", "package_version", "date_utc",
                   "scenario", "wall_time_s", "episodes", "note", "backend"}
SPEED_KEYS = ("g1", "g2", "g3", "g4")


class PresetError(ValueError):
    """A preset file that is not a valid tuned preset (it is never executed)."""


def _reject_constant(name: str) -> Any:
    raise PresetError(f"non-finite number {name} in preset")


def _check_json_value(value: Any, where: str, depth: int = 0) -> None:
    if depth > 8:
        raise PresetError(f"{where}: nested too deeply")
    if isinstance(value, float) and not math.isfinite(value):
        raise PresetError(f"{where}: non-finite number")
    if isinstance(value, dict):
        for k, v in value.items():
            _check_json_value(v, f"{where}.{k}", depth + 1)
    elif isinstance(value, list):
        for j, v in enumerate(value):
            _check_json_value(v, f"{where}[{j}]", depth + 1)


SAVABLE_TYPES = (bool, int, float, str, tuple)
"""Types of the config fields a preset file holds (tuples of numbers)."""


def preset_config_type(controller: Any) -> type:
    """The config class a preset of ``controller`` holds: the ``config_type`` of a GA-tunable registered policy
    (``registry.tunable_policies()``), a frozen dataclass whose fields all have defaults of ``SAVABLE_TYPES``.
    ``PresetError`` otherwise, naming the tunable controllers or the field that cannot be saved."""
    from vtrack_gym.baselines.registry import policy_class, tunable_policies

    tunable = tunable_policies()
    if not isinstance(controller, str) or controller not in tunable:
        raise PresetError(f"controller must be a GA-tunable registered policy: {', '.join(tunable)} "
                          f"(got {controller!r})")
    cfg_type = policy_class(controller).config_type
    if not dataclasses.is_dataclass(cfg_type):
        raise PresetError(f"{controller}: config_type {cfg_type.__name__} is not a dataclass; a preset holds "
                          "dataclass fields")
    try:
        defaults = cfg_type()
    except TypeError as exc:
        raise PresetError(f"{controller}: {cfg_type.__name__}() needs a default for every field ({exc})") from None
    for f in dataclasses.fields(cfg_type):
        if not isinstance(getattr(defaults, f.name), SAVABLE_TYPES):
            raise PresetError(f"{controller}: {cfg_type.__name__}.{f.name} is a "
                              f"{type(getattr(defaults, f.name)).__name__}; a preset holds bool, int, float, str "
                              "and tuples of numbers")
    return cfg_type


def _number(value: Any, where: str) -> float:
    try:  # float() of an int beyond 1.8e308 raises OverflowError
        number = float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else math.nan
    except OverflowError:
        number = math.nan
    if not math.isfinite(number):
        raise PresetError(f"{where} must be a finite number (got {str(value)[:40]!r})")
    return number


def parse_preset(text: str | bytes) -> dict[str, Any]:
    """Validate preset text; returns ``{"controller", "config", "speed_controller", "provenance"}`` with
    ``config`` a ``SMCConfig``/``MPCConfig`` and ``speed_controller`` a dict of g1..g4 (or None)."""
    if isinstance(text, bytes):
        if len(text) > MAX_BYTES:
            raise PresetError(f"preset larger than {MAX_BYTES} bytes")
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise PresetError("preset is not UTF-8 JSON text") from exc
    if len(text) > MAX_BYTES:
        raise PresetError(f"preset larger than {MAX_BYTES} bytes")
    try:
        data = json.loads(text, parse_constant=_reject_constant)
    except PresetError:
        raise
    except (ValueError, RecursionError) as exc:  # JSONDecodeError, integers over 4300 digits, deep nesting
        raise PresetError(f"preset is not valid JSON ({exc})") from None
    if not isinstance(data, dict):
        raise PresetError("preset must be a JSON object")
    unknown = sorted(set(data) - TOP_KEYS)
    if unknown:
        raise PresetError(f"unknown preset key(s) {', '.join(unknown)}; valid: {', '.join(sorted(TOP_KEYS))}")
    if data.get("format") != FORMAT or data.get("format_version") != FORMAT_VERSION:
        raise PresetError(f"preset must have format {FORMAT!r} and format_version {FORMAT_VERSION}")
    controller = data.get("controller")
    cfg_type = preset_config_type(controller)
    raw = data.get("config")
    if not isinstance(raw, dict):
        raise PresetError("preset 'config' must be an object")
    fields = {f.name: f for f in dataclasses.fields(cfg_type)}
    unknown = sorted(set(raw) - set(fields))
    if unknown:
        raise PresetError(f"unknown {cfg_type.__name__} field(s) {', '.join(unknown)}")
    kwargs: dict[str, Any] = {}
    defaults = cfg_type()
    for name, value in raw.items():
        ref = getattr(defaults, name)
        if isinstance(ref, bool):
            if not isinstance(value, bool):
                raise PresetError(f"config.{name} must be true/false")
            kwargs[name] = value
        elif isinstance(ref, tuple):
            if not isinstance(value, list) or len(value) > 64:
                raise PresetError(f"config.{name} must be a list of numbers")
            kwargs[name] = tuple(_number(v, f"config.{name}") for v in value)
        elif isinstance(ref, int):
            if isinstance(value, bool) or not isinstance(value, int):
                raise PresetError(f"config.{name} must be an integer")
            kwargs[name] = value
        elif isinstance(ref, float):
            kwargs[name] = _number(value, f"config.{name}")
        elif isinstance(ref, str):
            if not isinstance(value, str):
                raise PresetError(f"config.{name} must be a string")
            kwargs[name] = value
        else:  # pragma: no cover - all config fields are covered above
            raise PresetError(f"config.{name}: unsupported field type")
    try:
        config = cfg_type(**kwargs)
    except (ValueError, TypeError) as exc:
        raise PresetError(f"invalid {cfg_type.__name__}: {exc}") from None
    speed = data.get("speed_controller")
    if speed is not None:
        if not isinstance(speed, dict):
            raise PresetError("preset 'speed_controller' must be an object")
        unknown = sorted(set(speed) - set(SPEED_KEYS))
        if unknown:
            raise PresetError(f"unknown speed_controller key(s) {', '.join(unknown)}; valid: {', '.join(SPEED_KEYS)}")
        speed = {k: _number(v, f"speed_controller.{k}") for k, v in speed.items()}
        if any(v <= 0 for v in speed.values()):
            raise PresetError("speed_controller gains must be > 0")
    prov = data.get("provenance", {})
    if not isinstance(prov, dict):
        raise PresetError("preset 'provenance' must be an object")
    unknown = sorted(set(prov) - PROVENANCE_KEYS)
    if unknown:
        raise PresetError(f"unknown provenance key(s) {', '.join(unknown)}")
    _check_json_value(prov, "provenance")
    return {"controller": controller, "config": config, "speed_controller": speed, "provenance": prov}


def load_preset(path: str | Path) -> dict[str, Any]:
    """Read and validate a preset file (see ``parse_preset``): a regular file of at most ``MAX_BYTES`` bytes
    (a FIFO or device is refused without blocking)."""
    from vtrack_gym._io import read_regular_file

    p = Path(path)
    try:
        data = read_regular_file(p, MAX_BYTES, "preset file")
    except ValueError as exc:
        raise PresetError(str(exc)) from None
    try:
        return parse_preset(data)
    except PresetError as exc:
        raise PresetError(f"{p}: {exc}") from None


def preset_dict(controller: str, config: Any, speed_config: Any = None,
                provenance: dict[str, Any] | None = None) -> dict[str, Any]:
    """The JSON object of a preset (validated by a round trip through ``parse_preset`` on save)."""
    cfg = {k: (list(v) if isinstance(v, tuple) else v) for k, v in dataclasses.asdict(config).items()}
    out: dict[str, Any] = {"format": FORMAT, "format_version": FORMAT_VERSION, "controller": controller,
                           "config": cfg}
    if speed_config is not None:
        out["speed_controller"] = {k: float(getattr(speed_config, k)) for k in SPEED_KEYS}
    prov = dict(provenance or {})
    prov.setdefault("date_utc", dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"))
    if "package_version" not in prov:
        from vtrack_gym._version import __version__

        prov["package_version"] = __version__
    out["provenance"] = prov
    return out


def save_preset(path: str | Path, controller: str, config: Any, speed_config: Any = None,
                provenance: dict[str, Any] | None = None) -> Path:
    """Write a preset file (JSON, sorted keys) atomically; refuses anything ``parse_preset`` would refuse and an
    output path that is not (or cannot become) a regular file (``vtrack_gym._io.write_atomic``)."""
    from vtrack_gym._io import write_atomic

    data = preset_dict(controller, config, speed_config, provenance)
    text = json.dumps(data, indent=2, sort_keys=True, allow_nan=False)
    parse_preset(text)
    write_atomic(path, text + "\n")
    return Path(path)


def packaged_preset_path(controller: str) -> Path:
    return PACKAGED_DIR / f"{controller}_tuned.json"


def tuned_config(controller: str) -> Any:
    """The config of the packaged tuned preset of ``controller`` (``ValueError`` if there is none)."""
    from vtrack_gym.baselines.registry import tunable_policies

    path = packaged_preset_path(controller)
    if controller not in tunable_policies():
        raise ValueError(f"no 'tuned' preset for {controller!r}: GA-tunable: {', '.join(tunable_policies())}")
    if not path.is_file():
        raise ValueError(f"no tuned {controller} preset is packaged ({path} missing); run `vtrack tune "
                         f"--controller {controller} --out FILE` and install FILE there to use preset='tuned'")
    loaded = load_preset(path)
    if loaded["controller"] != controller:
        raise ValueError(f"{path} holds a {loaded['controller']} preset, not {controller}")
    return loaded["config"]


def observer_preset(controller: str, preset: str) -> Any:
    """A file preset of ``controller``: ``default``/``tuned`` the packaged tuned config, ``observer`` the same
    config with its Kalman-filter option on."""
    config = tuned_config(controller)
    return dataclasses.replace(config, observer=True) if preset == "observer" else config


class TunedPresets:
    """Mixin of the GA-tunable policies (SMC, MPC): presets ``default`` and ``tuned`` are the packaged file."""

    name: ClassVar[str]
    FILE_PRESETS: ClassVar[tuple[str, ...]] = ("default", "tuned")

    @classmethod
    def _file_preset(cls, preset: str) -> Any:
        return tuned_config(cls.name)
