"""Weights-only RL agents: ``<name>.json`` (architecture + provenance) and ``<name>.npz`` (float32 arrays).

Loading uses only ``json`` and ``np.load(allow_pickle=False)``: no pickle, no torch, no code execution. Every
field is checked strictly; anything else (a pickle, an SB3 ``.zip``, unknown keys, wrong shapes or dtypes,
non-finite values, oversized files) raises ``ValueError``.

Format version 1
----------------
``<name>.json`` (UTF-8 JSON object, at most 64 KiB), exactly these keys:

* ``format``: ``"vtrack_gym.agent"``; ``format_version``: ``1``
* ``algo``: ``"ppo"`` | ``"sac"`` | ``"td3"``
* ``obs_dim``, ``action_dim``: ints; ``hidden_sizes``: list of ints (0-8 layers, each 1-4096)
* ``activation``: ``"tanh"`` | ``"relu"`` (after every hidden layer)
* ``output``: ``"clip"`` (PPO: Gaussian mean clipped to [low, high]) or ``"tanh"`` (SAC/TD3: squashed, then
  scaled ``low + (tanh(x) + 1) / 2 (high - low)``)
* ``obs_norm``: ``{"enabled": bool, "eps": float}``; normalised obs ``clip((obs - mean) / sqrt(var + eps),
  -clip_obs, clip_obs)`` (SB3 ``VecNormalize``)
* ``provenance``: ``{"env_id", "command", "timesteps", "seed", "package_version", "sb3_version"}`` and
  optionally ``"warm_start"`` (how the actor was initialised before RL, e.g. behaviour cloning; ``timesteps``
  counts RL steps only)
  (strings/ints, informational only)
* ``env`` (optional; every file written by ``export`` has it): the env contract the agent was trained on,
  ``{"observation_names": [...], "control_period_s": float, "max_road_wheel_angle_rad": float}`` (the
  observation layout's names in order, the control period [s] and the road-wheel angle [rad] that action 1
  commands). ``check_env`` refuses an env whose layout differs and warns when the period or the scaling do.

``<name>.npz`` (at most 64 MiB, stored or deflated members, each ``.npy`` header checked before its data is read),
exactly these float32 arrays (finite values; weights, biases and ``clip_obs`` within +-1e4, action bounds within
+-1e6, so ``predict`` on finite observations up to 1e6 never overflows):

* ``w0 .. w{L}`` of shape ``(in, out)`` and ``b0 .. b{L}`` of shape ``(out,)`` for the L hidden layers plus the
  output layer (``y = x @ w + b``)
* ``action_low``, ``action_high``: ``(action_dim,)`` with ``low < high``
* if ``obs_norm.enabled``: ``obs_mean`` ``(obs_dim,)``, ``obs_var`` ``(obs_dim,)`` (>= 0) and ``clip_obs``
  ``(1,)`` (> 0)
"""

from __future__ import annotations

import hashlib
import io
import json
import logging
import math
import struct
import zipfile
import zlib
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

_CLIP = np.clip if not hasattr(np, "_core") else np._core.umath.clip
"""The clip ufunc ``np.clip`` calls for float arrays with both bounds (the same values, without the wrapper)."""
_SUM = np.add.reduce

FORMAT = "vtrack_gym.agent"
FORMAT_VERSION = 1
ALGOS = ("ppo", "sac", "td3")
ACTIVATIONS = ("tanh", "relu")
OUTPUTS = ("clip", "tanh")
MAX_JSON_BYTES = 64 * 1024
MAX_NPZ_BYTES = 64 * 1024 * 1024
MAX_LAYERS = 8
MAX_WIDTH = 4096
MAX_DIM = 4096
MAX_TIMESTEPS = 10**15
MAX_WEIGHT = 1e4
"""Largest |weight|, |bias| and ``clip_obs`` of an agent (trained SB3 actors stay below 10)."""
MAX_ACTION_BOUND = 1e6
"""Largest |action_low|, |action_high| of an agent."""
MAX_SEED = 2**64 - 1
JSON_KEYS = {"format", "format_version", "algo", "obs_dim", "action_dim", "hidden_sizes", "activation",
             "output", "obs_norm", "provenance"}
OBS_NORM_KEYS = {"enabled", "eps"}
PROVENANCE_KEYS = {"env_id", "command", "timesteps", "seed", "package_version", "sb3_version"}
OPTIONAL_PROVENANCE_KEYS = {"warm_start"}
OPTIONAL_JSON_KEYS = {"env"}
ENV_KEYS = {"observation_names", "control_period_s", "max_road_wheel_angle_rad"}


def agent_paths(path: str | Path) -> tuple[Path, Path]:
    """``(<name>.json, <name>.npz)`` for ``<name>``, ``<name>.json`` or ``<name>.npz``; other suffixes refused."""
    p = Path(path)
    if p.suffix in (".json", ".npz"):
        p = p.with_suffix("")
    elif p.suffix and p.with_suffix(p.suffix + ".json").exists():
        pass  # a dotted name such as "ppo_v1.2"
    elif p.suffix:
        raise ValueError(f"{path}: not a vtrack agent (expected <name>.json + <name>.npz; got suffix {p.suffix!r}; "
                         "SB3 .zip and pickle files are refused, export them with vtrack_gym.agents.export)")
    return p.parent / (p.name + ".json"), p.parent / (p.name + ".npz")


def _is_int(x: Any) -> bool:
    return isinstance(x, int) and not isinstance(x, bool)


def _check_int(value: Any, name: str, low: int, high: int) -> int:
    if not _is_int(value) or not (low <= value <= high):
        raise ValueError(f"agent json: {name} must be an integer in [{low}, {high}] (got {str(value)[:40]})")
    return value


def _reject_constant(name: str) -> None:
    raise ValueError(f"agent json: non-standard number {name} is not allowed")


def _parse_json(path: Path, raw: bytes) -> dict[str, Any]:
    """The agent description in ``raw`` (the bytes read from ``path``, named in errors)."""
    try:
        spec = json.loads(raw.decode("utf-8"), parse_constant=_reject_constant)
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:  # also: deep nesting, integers > 4300 digits
        raise ValueError(f"{path}: not a UTF-8 JSON agent description ({type(exc).__name__}: {exc})"[:600]) from None
    if not isinstance(spec, dict):
        raise ValueError(f"{path}: agent json must be an object (got {type(spec).__name__})")
    return spec


def validate_spec(spec: dict[str, Any]) -> dict[str, Any]:
    """Check an agent description (the parsed json) field by field; return it unchanged."""
    keys = set(spec)
    if not JSON_KEYS <= keys <= JSON_KEYS | OPTIONAL_JSON_KEYS:
        extra, missing = sorted(keys - JSON_KEYS - OPTIONAL_JSON_KEYS), sorted(JSON_KEYS - keys)
        raise ValueError(f"agent json: unexpected keys {extra} / missing keys {missing}")
    if spec["format"] != FORMAT:
        raise ValueError(f"agent json: format must be {FORMAT!r} (got {spec['format']!r})")
    if spec["format_version"] != FORMAT_VERSION or not _is_int(spec["format_version"]):
        raise ValueError(f"agent json: format_version must be {FORMAT_VERSION} (got {spec['format_version']!r})")
    if spec["algo"] not in ALGOS:
        raise ValueError(f"agent json: algo must be one of {ALGOS} (got {spec['algo']!r})")
    _check_int(spec["obs_dim"], "obs_dim", 1, MAX_DIM)
    _check_int(spec["action_dim"], "action_dim", 1, MAX_DIM)
    hidden = spec["hidden_sizes"]
    if not isinstance(hidden, list) or len(hidden) > MAX_LAYERS:
        raise ValueError(f"agent json: hidden_sizes must be a list of at most {MAX_LAYERS} ints (got {hidden!r})")
    for i, h in enumerate(hidden):
        _check_int(h, f"hidden_sizes[{i}]", 1, MAX_WIDTH)
    if spec["activation"] not in ACTIVATIONS:
        raise ValueError(f"agent json: activation must be one of {ACTIVATIONS} (got {spec['activation']!r})")
    if spec["output"] not in OUTPUTS:
        raise ValueError(f"agent json: output must be one of {OUTPUTS} (got {spec['output']!r})")
    expected_output = "clip" if spec["algo"] == "ppo" else "tanh"
    if spec["output"] != expected_output:
        raise ValueError(f"agent json: output of a {spec['algo']} agent must be {expected_output!r}")
    norm = spec["obs_norm"]
    if not isinstance(norm, dict) or set(norm) != OBS_NORM_KEYS:
        raise ValueError(f"agent json: obs_norm must be an object with keys {sorted(OBS_NORM_KEYS)} (got {norm!r})")
    if not isinstance(norm["enabled"], bool):
        raise ValueError(f"agent json: obs_norm.enabled must be a bool (got {norm['enabled']!r})")
    eps = norm["eps"]
    if isinstance(eps, bool) or not isinstance(eps, (int, float)) or not (0.0 < eps <= 1.0) or not math.isfinite(eps):
        raise ValueError(f"agent json: obs_norm.eps must be a number in (0, 1] (got {eps!r})")
    prov = spec["provenance"]
    if not isinstance(prov, dict) or not PROVENANCE_KEYS <= set(prov) <= PROVENANCE_KEYS | OPTIONAL_PROVENANCE_KEYS:
        raise ValueError(f"agent json: provenance must be an object with keys {sorted(PROVENANCE_KEYS)} "
                         f"(optionally {sorted(OPTIONAL_PROVENANCE_KEYS)})")
    for name in ("env_id", "command", "package_version", "sb3_version", *(OPTIONAL_PROVENANCE_KEYS & set(prov))):
        if not isinstance(prov[name], str) or len(prov[name]) > 4096:
            raise ValueError(f"agent json: provenance.{name} must be a string (<= 4096 chars)")
    if not _is_int(prov["timesteps"]) or not 0 <= prov["timesteps"] <= MAX_TIMESTEPS:
        raise ValueError(f"agent json: provenance.timesteps must be an int in [0, {MAX_TIMESTEPS}] "
                         f"(got {str(prov['timesteps'])[:40]})")
    if prov["seed"] is not None and not (_is_int(prov["seed"]) and 0 <= prov["seed"] <= MAX_SEED):
        raise ValueError(f"agent json: provenance.seed must be an int in [0, 2^64 - 1] or null "
                         f"(got {str(prov['seed'])[:40]})")
    if "env" in spec:
        _validate_env(spec["env"])
    return spec


def _validate_env(env: Any) -> None:
    if not isinstance(env, dict) or set(env) != ENV_KEYS:
        raise ValueError(f"agent json: env must be an object with keys {sorted(ENV_KEYS)}")
    names = env["observation_names"]
    if (not isinstance(names, list) or not 1 <= len(names) <= MAX_DIM
            or not all(isinstance(n, str) and 0 < len(n) <= 64 for n in names)):
        raise ValueError(f"agent json: env.observation_names must be a list of 1-{MAX_DIM} names (<= 64 chars)")
    for key, high in (("control_period_s", 1.0), ("max_road_wheel_angle_rad", 3.2)):
        v = env[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not (0.0 < v <= high):
            raise ValueError(f"agent json: env.{key} must be a number in (0, {high}] (got {v!r})")


def env_record(env: Any) -> dict[str, Any]:
    """The ``env`` field of an agent file for ``env`` (a Gymnasium env, vector env or SB3 VecEnv)."""
    from vtrack_gym.baselines.base import env_contract

    design, layout, period = env_contract(env)
    return {"observation_names": list(layout.names), "control_period_s": float(period),
            "max_road_wheel_angle_rad": float(design.max_road_wheel_angle_rad)}


def expected_arrays(spec: dict[str, Any]) -> dict[str, tuple[int, ...]]:
    """Name -> shape of every array the npz of ``spec`` must hold (exactly these)."""
    sizes = [spec["obs_dim"], *spec["hidden_sizes"], spec["action_dim"]]
    shapes: dict[str, tuple[int, ...]] = {}
    for i in range(len(sizes) - 1):
        shapes[f"w{i}"] = (sizes[i], sizes[i + 1])
        shapes[f"b{i}"] = (sizes[i + 1],)
    shapes["action_low"] = (spec["action_dim"],)
    shapes["action_high"] = (spec["action_dim"],)
    if spec["obs_norm"]["enabled"]:
        shapes["obs_mean"] = (spec["obs_dim"],)
        shapes["obs_var"] = (spec["obs_dim"],)
        shapes["clip_obs"] = (1,)
    return shapes


_NPZ_ERRORS = (ValueError, OSError, EOFError, zipfile.BadZipFile, RuntimeError, NotImplementedError, zlib.error,
               struct.error, SyntaxError, TypeError, KeyError, RecursionError, MemoryError, AttributeError)
"""What a crafted zip member can make ``zipfile`` / ``numpy.lib.format`` raise; all become the loader's ValueError."""


def _read_member(zf: zipfile.ZipFile, info: zipfile.ZipInfo, shape: tuple[int, ...]) -> np.ndarray:
    """One ``.npy`` member: its header must declare little-endian float32 of ``shape`` before any data is read."""
    if info.flag_bits & 0x1:
        raise ValueError("encrypted member")
    if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
        raise ValueError(f"unsupported compression method {info.compress_type}")
    with zf.open(info) as fh:
        version = np.lib.format.read_magic(fh)
        if version == (1, 0):
            header = np.lib.format.read_array_header_1_0(fh)
        elif version == (2, 0):
            header = np.lib.format.read_array_header_2_0(fh)
        else:
            raise ValueError(f"unsupported .npy version {version}")
        declared, fortran, dtype = header
        if dtype != np.dtype("<f4"):
            raise ValueError(f"must be float32 (got {dtype})")
        if tuple(declared) != shape:
            raise ValueError(f"must have shape {shape} (got {tuple(declared)})")
        count = math.prod(shape)
        data = fh.read(4 * count)
        if len(data) != 4 * count:
            raise ValueError("truncated array data")
    arr = np.frombuffer(data, dtype="<f4", count=count).reshape(shape, order="F" if fortran else "C")
    return np.ascontiguousarray(arr, dtype=np.float32)


def _parse_npz(path: Path, raw: bytes, shapes: dict[str, tuple[int, ...]]) -> dict[str, np.ndarray]:
    """The arrays of the agent npz in ``raw`` (the bytes read from ``path``), member by member with their headers
    checked first (bounded memory)."""
    if not zipfile.is_zipfile(io.BytesIO(raw)):
        raise ValueError(f"{path}: not an npz archive (pickles and other files are refused)")
    expected_members = {f"{name}.npy": name for name in shapes}
    arrays: dict[str, np.ndarray] = {}
    try:
        with zipfile.ZipFile(io.BytesIO(raw)) as zf:
            infos = zf.infolist()
            members = [info.filename for info in infos]
            if len(members) != len(set(members)) or set(members) != set(expected_members):
                raise ValueError(f"{path}: npz members {sorted(members)[:20]} do not match the expected "
                                 f"{sorted(expected_members)} (an SB3 .zip or a tampered file?)")
            declared = sum(info.file_size for info in infos)
            if declared > MAX_NPZ_BYTES:
                raise ValueError(f"{path}: npz uncompressed size {declared} bytes exceeds {MAX_NPZ_BYTES}")
            for info in infos:
                name = expected_members[info.filename]
                try:
                    arr = _read_member(zf, info, shapes[name])
                except _NPZ_ERRORS as exc:
                    raise ValueError(f"{path}: array {name!r}: {type(exc).__name__}: {exc}"[:600]) from None
                if not np.isfinite(arr).all():
                    raise ValueError(f"{path}: array {name!r} contains NaN/inf")
                arrays[name] = arr
    except ValueError as exc:
        if str(exc).startswith(str(path)):
            raise
        raise ValueError(f"{path}: unreadable npz ({exc})"[:600]) from None
    except _NPZ_ERRORS as exc:
        raise ValueError(f"{path}: unreadable npz ({type(exc).__name__}: {exc})"[:600]) from None
    if not np.all(arrays["action_low"] < arrays["action_high"]):
        raise ValueError(f"{path}: action_low must be < action_high")
    if "obs_var" in arrays:
        if np.any(arrays["obs_var"] < 0):
            raise ValueError(f"{path}: obs_var must be >= 0")
        if not arrays["clip_obs"][0] > 0:
            raise ValueError(f"{path}: clip_obs must be > 0")
    return arrays


def _magnitude_limits(shapes: dict[str, tuple[int, ...]]) -> dict[str, float]:
    """Largest |entry| of each array: with these, 9 layers of width 4096 fed observations up to 1e6 (or clipped
    normalised ones) stay below 1e200, so ``predict`` never overflows to inf or NaN."""
    limits = {name: MAX_WEIGHT for name in shapes if name[0] in "wb" and name[1:].isdigit()}
    limits.update({name: MAX_ACTION_BOUND for name in ("action_low", "action_high")})
    if "clip_obs" in shapes:
        limits["clip_obs"] = MAX_WEIGHT
    return limits


def weights_sha256(spec: dict[str, Any], arrays: dict[str, np.ndarray]) -> str:
    """Content hash of an agent: what determines its actions (spec minus provenance, arrays as float32 bytes)."""
    h = hashlib.sha256()
    h.update(json.dumps({k: v for k, v in spec.items() if k != "provenance"}, sort_keys=True).encode())
    for key in sorted(arrays):
        arr = np.ascontiguousarray(arrays[key], dtype=np.float32)
        h.update(f"{key}:{arr.shape}:".encode())
        h.update(arr.tobytes())
    return h.hexdigest()


class NumpyPolicy:
    """A trained MLP agent evaluated in pure numpy with SB3's ``predict`` signature (stateless).

    ``predict(obs)`` takes raw env observations (the stored ``VecNormalize`` statistics are applied here) of
    shape ``(obs_dim,)`` -> action ``(action_dim,)`` or ``(N, obs_dim)`` -> ``(N, action_dim)``, float32.
    Always deterministic (the Gaussian mean / the deterministic actor); ``state`` is returned as ``None``.
    """

    solver_failures: int = 0
    """A closed-form network: no solver, never a failed solve (the leaderboard's ``solver_failures``)."""
    display_attributes: ClassVar[tuple[str, ...]] = ("name",)
    """The file stem an agent is shown by: not part of its identity (``evaluation.identity.fingerprint``), its content
    is."""

    def __init__(self, spec: dict[str, Any], arrays: dict[str, np.ndarray], name: str = "agent") -> None:
        self.spec = validate_spec(spec)
        shapes = expected_arrays(spec)
        if set(arrays) != set(shapes):
            raise ValueError(f"arrays {sorted(arrays)} do not match the expected {sorted(shapes)}")
        for key, shape in shapes.items():
            if arrays[key].shape != shape or arrays[key].dtype != np.float32 or not np.isfinite(arrays[key]).all():
                raise ValueError(f"array {key!r} must be finite float32 of shape {shape}")
        for key, limit in _magnitude_limits(shapes).items():
            if np.abs(arrays[key]).max(initial=0.0) > limit:
                raise ValueError(f"array {key!r} has an entry beyond +-{limit:g} (the limit that keeps every action "
                                 "finite in float64)")
        if "env" in spec and len(spec["env"]["observation_names"]) != spec["obs_dim"]:
            raise ValueError(f"agent json: env.observation_names has {len(spec['env']['observation_names'])} names, "
                             f"obs_dim is {spec['obs_dim']}")
        self.name = name
        self._weights_hash = weights_sha256(spec, arrays)
        self.algo = spec["algo"]
        self.obs_dim = spec["obs_dim"]
        self.action_dim = spec["action_dim"]
        n_layers = len(spec["hidden_sizes"]) + 1
        self._weights = [(arrays[f"w{i}"].astype(np.float64), arrays[f"b{i}"].astype(np.float64))
                         for i in range(n_layers)]
        self._relu = spec["activation"] == "relu"
        self._tanh_out = spec["output"] == "tanh"
        self.action_low = arrays["action_low"].astype(np.float64)
        self.action_high = arrays["action_high"].astype(np.float64)
        self._norm = spec["obs_norm"]["enabled"]
        if self._norm:
            self.obs_mean = arrays["obs_mean"].astype(np.float64)
            self._obs_scale = 1.0 / np.sqrt(arrays["obs_var"].astype(np.float64) + float(spec["obs_norm"]["eps"]))
            self.clip_obs = float(arrays["clip_obs"][0])
        self._inputs: np.ndarray | None = None  # env observation -> agent inputs, by name (set by check_env)
        self._env_obs_dim = self.obs_dim

    @property
    def policy_id(self) -> str:
        return self.name

    def check_env(self, env: Any) -> None:
        """Refuse ``env`` if its observation layout lacks a field the agent was trained on (``ValueError``), and
        select the agent's inputs from the env's observation BY NAME (layouts grow by appending named fields, e.g.
        the speed preview: the agent keeps reading the fields it knows).

        Files with the ``env`` record need every recorded name in the env's layout, in the recorded order, and log
        a warning when the road-wheel angle of action 1 differs or the env's control period is longer than the
        trained one (the agent still runs, on a different plant timing or scale, e.g. highway-env; a shorter period
        is only logged at DEBUG, ``vtrack -v``: the state-feedback law is sampled faster, as for every shipped agent
        on the 100 Hz envs); files without it are taken to have the
        layout without the speed preview and compare the observation size only.
        """
        from vtrack_gym.baselines.base import env_contract

        design, layout, period = env_contract(env)
        self._check_layout(layout)
        record = self.spec.get("env")
        if record is None:
            return
        for key, value in (("control_period_s", period), ("max_road_wheel_angle_rad",
                                                           design.max_road_wheel_angle_rad)):
            if math.isclose(record[key], float(value), rel_tol=1e-9):
                continue
            if key == "control_period_s" and float(value) < record[key]:
                # an agent that decided every 50 ms in training, asked every 10 ms: a state-feedback law sampled
                # faster (the from-scratch recipes train at 20 Hz and are scored at the envs' 100 Hz)
                logging.getLogger(__name__).debug("agent %r was trained deciding every %g s; this env asks every %g s",
                                                  self.name, record[key], float(value))
                continue
            logging.getLogger(__name__).warning("agent %r was trained with %s = %g, this env has %g",
                                                self.name, key, record[key], float(value))

    def _check_layout(self, layout: Any) -> None:
        """``ValueError`` unless ``layout`` has the agent's fields (see ``check_env``); selects them by name."""
        from dataclasses import replace

        record = self.spec.get("env")
        names = list(layout.names)
        if record is None:
            base = replace(layout, n_speed_preview=0)
            if base.size != self.obs_dim:
                raise ValueError(f"agent {self.name!r} takes {self.obs_dim} observations; this env's layout has "
                                 f"{base.size}")
            self._select(names, list(base.names))
            return
        wanted = list(record["observation_names"])
        known = set(wanted)
        ours_in_order = [n for n in names if n in known]  # the agent's fields as this env orders them
        if ours_in_order != wanted:  # a field missing, or in another order
            diff = next((i for i, (a, b) in enumerate(zip(wanted, ours_in_order, strict=False)) if a != b),
                        min(len(ours_in_order), self.obs_dim))
            theirs = wanted[diff] if diff < self.obs_dim else "(end)"
            ours = ours_in_order[diff] if diff < len(ours_in_order) else "(end)"
            raise ValueError(f"agent {self.name!r} was trained on another observation layout: entry {diff} is "
                             f"{theirs!r} for the agent and {ours!r} in this env ({self.obs_dim} vs {len(names)} "
                             "entries); retrain or export it for this env's layout")
        self._select(names, wanted)

    def _select(self, env_names: list[str], agent_names: list[str]) -> None:
        """Feed the agent the entries ``agent_names`` of observations laid out as ``env_names``."""
        index = np.array([env_names.index(n) for n in agent_names], dtype=np.intp)
        identity = len(env_names) == len(agent_names) and bool((index == np.arange(index.size)).all())
        self._inputs = None if identity else index
        self._env_obs_dim = len(env_names)

    @property
    def weights_hash(self) -> str:
        """SHA-256 (hex) of the agent's content: the spec's network fields and every array (name, shape, bytes)."""
        return self._weights_hash

    @property
    def provenance(self) -> dict[str, Any]:
        return dict(self.spec["provenance"])

    def normalize(self, obs: np.ndarray) -> np.ndarray:
        """The observation the network sees (SB3 ``VecNormalize.normalize_obs``)."""
        if not self._norm:
            return obs
        x = (obs - self.obs_mean) * self._obs_scale   # the clip ufunc itself: np.clip's result, without its wrapper
        return _CLIP(x, -self.clip_obs, self.clip_obs, out=x)

    def predict(self, observation: Any, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> tuple[np.ndarray, None]:
        """SB3-compatible deterministic action for one observation or a batch (see the class docstring)."""
        obs = np.asarray(observation, dtype=np.float64)
        single = obs.ndim == 1
        if single:
            obs = obs.reshape(1, -1)
        if obs.ndim == 2 and obs.shape[1] != self.obs_dim and obs.shape[1] != self._env_obs_dim:
            from vtrack_gym.envs.observation import OBS

            if obs.shape[1] == OBS.size:  # not checked against an env: assume the package's default layout
                self._check_layout(OBS)
        if self._inputs is not None and obs.ndim == 2 and obs.shape[1] == self._env_obs_dim:
            obs = obs[:, self._inputs]  # the env's layout has more fields: the agent's, by name
        if obs.ndim != 2 or obs.shape[1] != self.obs_dim:
            raise ValueError(f"observation must have shape ({self.obs_dim},) or (N, {self.obs_dim}) (got {obs.shape})")
        if not math.isfinite(_SUM(obs, axis=None)) and not np.isfinite(obs).all():   # a finite sum: all finite
            raise ValueError("observation contains NaN/inf")
        x = self.normalize(obs)
        last = len(self._weights) - 1
        for i, (w, b) in enumerate(self._weights):   # in place on the fresh products: the same values, fewer arrays
            x = x @ w
            x += b
            if i < last:
                x = np.maximum(x, 0.0, out=x) if self._relu else np.tanh(x, out=x)
        if self._tanh_out:
            x = np.tanh(x, out=x)   # low + 0.5 * (tanh(x) + 1) * (high - low), in place, operation by operation
            x += 1.0
            x *= 0.5
            x *= self.action_high - self.action_low
            x = np.add(self.action_low, x, out=x)
        else:
            x = _CLIP(x, self.action_low, self.action_high)
        action = x.astype(np.float32)
        return (action[0] if single else action), None

    def __repr__(self) -> str:
        return (f"NumpyPolicy({self.name!r}, algo={self.algo}, hidden={self.spec['hidden_sizes']}, "
                f"timesteps={self.spec['provenance']['timesteps']})")


def load_agent(path: str | Path) -> NumpyPolicy:
    """Load ``<name>.json`` + ``<name>.npz`` (``path`` may name either or the common stem) as a ``NumpyPolicy``.

    Each file is read once; the policy, and its ``weights_hash``, are built from those bytes and nothing reads
    the files again. The two files are one agent: when either is no longer the version that was read once both
    are read (an agent written again meanwhile, e.g. by ``vtrack export``), the pair may be half old, half new,
    and the load is refused with a ``ValueError`` saying so (load it again once it is written).
    """
    from vtrack_gym._io import read_regular_file_stamped, unchanged_since

    json_path, npz_path = agent_paths(path)
    json_raw, json_stamp = read_regular_file_stamped(json_path, MAX_JSON_BYTES, "agent json")
    spec = validate_spec(_parse_json(json_path, json_raw))
    npz_raw, npz_stamp = read_regular_file_stamped(npz_path, MAX_NPZ_BYTES, "agent npz")
    for file, stamp in ((json_path, json_stamp), (npz_path, npz_stamp)):
        if not unchanged_since(file, stamp):
            raise ValueError(f"{file}: the agent changed while it was being read (its .json and .npz may be of two "
                             "versions); load it again once it is written")
    arrays = _parse_npz(npz_path, npz_raw, expected_arrays(spec))
    return NumpyPolicy(spec, arrays, name=json_path.stem)


def save_agent(path: str | Path, spec: dict[str, Any], arrays: dict[str, np.ndarray]) -> tuple[Path, Path]:
    """Validate and write an agent (used by ``export``); returns the json and npz paths."""
    validate_spec(spec)
    NumpyPolicy(spec, arrays)  # full check before anything is written
    from vtrack_gym._io import check_output_file, write_atomic

    json_path, npz_path = agent_paths(path)
    check_output_file(json_path)
    check_output_file(npz_path)
    buffer = io.BytesIO()
    np.savez(buffer, **{k: np.ascontiguousarray(v, dtype=np.float32) for k, v in arrays.items()})
    write_atomic(npz_path, buffer.getvalue())
    write_atomic(json_path, json.dumps(spec, indent=2, sort_keys=True) + "\n")
    return json_path, npz_path
