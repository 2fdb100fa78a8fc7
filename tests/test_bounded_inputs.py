"""Issue 20: outputs never clobber non-regular files, loaders are bounded, crafted files give the loader's
ValueError, numeric CLI options are range-checked before any work, and SB3 pickles need trust."""

from __future__ import annotations

import io
import json
import os
import stat
import subprocess
import sys
import tempfile
import textwrap
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from vtrack_gym._io import check_output_dir, check_output_file, read_regular_file, write_atomic
from vtrack_gym.baselines.numpy_policy import load_agent, save_agent
from vtrack_gym.baselines.preset_files import PresetError, load_preset
from vtrack_gym.cli import main

ROOT = Path(__file__).resolve().parents[1]
UNUSED_STORE = Path(tempfile.gettempdir()) / "vtrack-never-created" / "s.sqlite"
"""A store path the refused commands below must never create."""
SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


# ---------------------------------------------------------------- class 1: output paths

def _special(tmp: Path, kind: str) -> Path:
    """A path of the given kind: a directory, a FIFO, a device (/dev/null), a symlink to one of them, ..."""
    if kind == "dir":
        (tmp / "d").mkdir(exist_ok=True)
        return tmp / "d"
    if kind == "fifo":
        p = tmp / "fifo"
        if not p.exists():
            os.mkfifo(p)
        return p
    if kind == "device":
        return Path("/dev/null")
    if kind == "under_file":
        (tmp / "plain").write_text("x")
        return tmp / "plain" / "out.json"
    link = tmp / f"link_{kind}"
    if not link.is_symlink():
        link.symlink_to(_special(tmp, kind.removeprefix("link_")))
    return link


BAD_OUTPUTS = ["dir", "fifo", "device", "under_file", "link_fifo", "link_device", "link_dir"]


@given(kind=st.sampled_from(BAD_OUTPUTS), data=st.binary(max_size=64))
@SETTINGS
def test_write_atomic_never_replaces_a_non_regular_file(tmp_path, kind, data):
    target = _special(tmp_path, kind)
    before = os.stat("/dev/null")
    with pytest.raises(ValueError, match="--out"):
        write_atomic(target, data, "--out")
    after = os.stat("/dev/null")
    assert stat.S_ISCHR(after.st_mode) and after.st_rdev == before.st_rdev
    if kind in ("fifo", "link_fifo"):
        assert stat.S_ISFIFO(os.stat(tmp_path / "fifo").st_mode)
    assert not list(tmp_path.rglob("*.tmp"))


@given(data=st.binary(max_size=256), existing=st.booleans(), via_link=st.booleans())
@SETTINGS
def test_write_atomic_regular_targets(tmp_path, data, existing, via_link):
    tmp_path = Path(tempfile.mkdtemp(dir=tmp_path))  # a fresh folder per example: hypothesis reuses the fixture
    real = tmp_path / "sub" / "out.bin"
    if existing:
        real.parent.mkdir(exist_ok=True)
        real.write_bytes(b"old")
    target = real
    if via_link:
        real.parent.mkdir(exist_ok=True)
        target = tmp_path / "link.bin"
        if not target.is_symlink():
            target.symlink_to(real)
    write_atomic(target, data)
    assert real.read_bytes() == data and stat.S_ISREG(os.lstat(real).st_mode)
    assert not via_link or target.is_symlink()  # the link is followed, not replaced
    assert [p.name for p in real.parent.iterdir() if p.name.endswith(".tmp")] == []


def test_output_dir_checks(tmp_path):
    assert check_output_dir(tmp_path / "a" / "b") == tmp_path / "a" / "b"
    assert not (tmp_path / "a").exists() and list(tmp_path.iterdir()) == []  # checking creates nothing
    (tmp_path / "f").write_text("x")
    for bad in (tmp_path / "f", tmp_path / "f" / "sub", Path("/dev/null")):
        with pytest.raises(ValueError, match="--figures"):
            check_output_dir(bad, "--figures")


def test_read_only_folder_is_refused(tmp_path):
    """Permission bits for a normal user; as root (they do not stop root) the immutable attribute (chattr +i)."""
    import shutil

    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    immutable = False
    if os.geteuid() == 0:
        chattr = shutil.which("chattr")
        immutable = chattr is not None and subprocess.run([chattr, "+i", str(ro)], capture_output=True).returncode == 0
        if not immutable:
            pytest.skip("running as root without chattr +i (CAP_LINUX_IMMUTABLE): nothing makes a folder read-only")
    try:
        for call in (lambda: check_output_file(ro / "x.json", "--out"), lambda: check_output_dir(ro / "sub", "--out"),
                     lambda: write_atomic(ro / "x.json", b"{}", "--out")):
            with pytest.raises(ValueError, match="cannot create files"):
                call()
        assert list(ro.iterdir()) == []
    finally:
        if immutable:
            subprocess.run(["chattr", "-i", str(ro)], check=True)
        ro.chmod(0o755)


@pytest.mark.parametrize("kind", ["dir", "fifo", "device", "under_file"])
def test_cli_outputs_are_checked_before_any_work(tmp_path, capsys, kind):
    bad = str(_special(tmp_path, kind))
    store = str(tmp_path / "s.sqlite")
    cases = [
        ["tune", "--controller", "smc", "--budget", "quick", "--out", bad],
        ["tune", "--controller", "smc", "--budget", "quick", "--out", str(tmp_path / "ok.json"), "--store", bad],
        ["eval", "--policy", "lqr", "--env", "DLC120-v0", "--store", bad],
        ["benchmark", "--store", bad, "--no-figures"],
        ["export", "--trust-code", "--model", str(tmp_path / "m.zip"), "--algo", "ppo", "--out",
         bad.removesuffix(".json") if kind == "under_file" else str(_special(tmp_path, "dir") / "x")],
    ]
    if kind != "dir":  # folder outputs: a FIFO, a device or a path under a file
        cases += [["plot", "--out", bad], ["reproduce", "--out", bad],
                  ["benchmark", "--store", store, "--figures", bad]]
    for argv in cases:
        if argv[0] == "export" and kind != "dir":
            continue
        if argv[0] == "export":  # a directory where <out>.json goes
            (Path(argv[-1] + ".json")).mkdir(exist_ok=True)
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert "error:" in err and "Traceback" not in err, (argv, err)
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)
    assert not (tmp_path / "ok.json").exists() and not (tmp_path / "s.sqlite").exists()


def test_leaderboard_out_refuses_non_regular_before_reading(tmp_path, capsys):
    os.mkfifo(tmp_path / "fifo")
    for bad in (tmp_path, tmp_path / "fifo", Path("/dev/null")):
        assert main(["leaderboard", "--store", str(tmp_path / "none.sqlite"), "--out", str(bad)]) == 2
        assert "--out" in capsys.readouterr().err
    assert stat.S_ISFIFO(os.stat(tmp_path / "fifo").st_mode)


# ---------------------------------------------------------------- class 4: CLI numeric options

@pytest.mark.parametrize("argv, option", [
    (["tune", "--controller", "smc", "--generations", "0"], "--generations"),
    (["tune", "--controller", "smc", "--pop-size", "1"], "--pop-size"),
    (["tune", "--controller", "smc", "--max-steps", "-5"], "--max-steps"),
    (["tune", "--controller", "smc", "--seed", str(2**63)], "--seed"),
    (["tune", "--controller", "smc", "--seed", "9" * 5000], "--seed"),
    (["tune", "--controller", "smc", "--comfort-weight", "nan"], "--comfort-weight"),
    (["tune", "--controller", "smc", "--comfort-weight", "1e309"], "--comfort-weight"),
    (["tune", "--controller", "smc", "--backend", "ray", "--workers", "0"], "--workers"),
    (["train", "--algo", "ppo", "--run-dir", "x", "--timesteps", "-1"], "--timesteps"),
    (["train", "--algo", "ppo", "--run-dir", "x", "--num-envs", "10" * 40], "--num-envs"),
    (["train", "--algo", "ppo", "--run-dir", "x", "--seed", "-1"], "--seed"),
])
def test_numeric_options_name_the_option_and_range(argv, option, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert option in err and "must be" in err and "Traceback" not in err


@given(seed=st.one_of(st.integers(min_value=2**63, max_value=2**400), st.integers(max_value=-1)))
@settings(max_examples=30, deadline=None)
def test_huge_or_negative_seeds_refused_before_any_work(seed):
    import contextlib

    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        code = main(["eval", "--policy", "lqr", "--env", "DLC120-v0", "--seeds", str(seed), "--store",
                     str(UNUSED_STORE)])
    assert code == 2 and "--seeds" in err.getvalue() and not UNUSED_STORE.parent.exists()


def test_generations_zero_is_not_the_default():
    from vtrack_gym.tuning.job import tune_to_preset

    for kwargs in ({"generations": 0}, {"pop_size": 0}, {"max_steps": -5}, {"seed": 2**63}):
        with pytest.raises(ValueError):
            tune_to_preset("smc", "paper", "quick", out=UNUSED_STORE.parent / "x.json", progress=False,
                           **kwargs)


def test_mpc_config_range_bounds_build_in_seconds():
    from vtrack_gym.baselines.mpc import MPCConfig

    for field, value in (("prediction_horizon", 400), ("n_speeds", 400)):
        with pytest.raises(ValueError, match=field):
            MPCConfig(**{field: value})


# ---------------------------------------------------------------- class 2 and 3: loaders

def _tiny_agent(tmp_path: Path) -> Path:
    spec = {"format": "vtrack_gym.agent", "format_version": 1, "algo": "ppo", "obs_dim": 3, "action_dim": 1,
            "hidden_sizes": [4], "activation": "tanh", "output": "clip", "obs_norm": {"enabled": False, "eps": 1e-8},
            "provenance": {"env_id": "", "command": "", "timesteps": 0, "seed": 0, "package_version": "0",
                           "sb3_version": "0"}}
    rng = np.random.default_rng(0)
    arrays = {"w0": rng.normal(size=(3, 4)).astype(np.float32), "b0": np.zeros(4, np.float32),
              "w1": rng.normal(size=(4, 1)).astype(np.float32), "b1": np.zeros(1, np.float32),
              "action_low": -np.ones(1, np.float32), "action_high": np.ones(1, np.float32)}
    save_agent(tmp_path / "agent", spec, arrays)
    return tmp_path / "agent"


def _npy_header(shape: tuple[int, ...], dtype: str = "<f4") -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": dtype, "fortran_order": False, "shape": shape})
    return buf.getvalue()


def _crafted_npz(path: Path, member: str, payload: bytes, compress: int = zipfile.ZIP_STORED) -> None:
    with zipfile.ZipFile(io.BytesIO(path.read_bytes())) as src:
        members = {i.filename: src.read(i) for i in src.infolist()}
    members[member] = payload
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for name, data in members.items():
            zf.writestr(name, data, compress_type=compress if name == member else zipfile.ZIP_STORED)
    path.write_bytes(buf.getvalue())


CRAFTED_NPZ = {
    "not_npy": b"hello, not an npy file at all",
    "huge_header": _npy_header((1 << 40, 1 << 2)),
    "wrong_dtype_object": _npy_header((3, 4), "|O"),
    "truncated": _npy_header((3, 4)) + b"\x00" * 7,
    "big_endian": _npy_header((3, 4), ">f4") + b"\x00" * 48,
}


@pytest.mark.parametrize("case", sorted(CRAFTED_NPZ))
def test_crafted_npz_members_are_valueerror(tmp_path, case):
    agent = _tiny_agent(tmp_path)
    _crafted_npz(agent.with_suffix(".npz"), "w0.npy", CRAFTED_NPZ[case])
    with pytest.raises(ValueError, match="w0"):
        load_agent(agent)


@pytest.mark.parametrize("flag, compress", [(0x1, zipfile.ZIP_STORED), (0, zipfile.ZIP_LZMA),
                                            (0, zipfile.ZIP_BZIP2)])
def test_encrypted_or_unsupported_zip_members_are_valueerror(tmp_path, flag, compress):
    agent = _tiny_agent(tmp_path)
    npz = agent.with_suffix(".npz")
    _crafted_npz(npz, "w0.npy", zipfile.ZipFile(npz).read("w0.npy"), compress)
    if flag:  # set the "encrypted" bit of w0.npy in its local header and central directory entry
        raw = bytearray(npz.read_bytes())
        for sig, off in ((b"PK\x03\x04", 6), (b"PK\x01\x02", 8)):
            start = 0
            while (i := raw.find(sig, start)) >= 0:
                name_at = i + (30 if sig == b"PK\x03\x04" else 46)
                if raw[name_at:name_at + 6] == b"w0.npy":
                    raw[i + off] |= flag
                start = i + 4
        npz.write_bytes(bytes(raw))
    with pytest.raises(ValueError):
        load_agent(agent)


@given(depth=st.integers(min_value=50, max_value=200_000), digits=st.integers(min_value=4000, max_value=20_000),
       which=st.sampled_from(["nest", "bigint", "bigint_field"]))
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_crafted_agent_json_is_valueerror(tmp_path, depth, digits, which):
    agent = _tiny_agent(tmp_path)
    spec = json.loads(agent.with_suffix(".json").read_text())
    text = json.dumps(spec)
    if which == "nest":
        text = text.replace('"sb3_version": "0"', '"sb3_version": ' + "[" * min(depth, 30000) + "]" *
                            min(depth, 30000))
    elif which == "bigint":
        text = text.replace('"timesteps": 0', '"timesteps": ' + "9" * digits)
    else:
        text = text.replace('"obs_dim": 3', '"obs_dim": ' + "9" * min(digits, 4000))
    agent.with_suffix(".json").write_text(text)
    with pytest.raises(ValueError):
        load_agent(agent)


@given(depth=st.integers(min_value=10, max_value=100_000), digits=st.integers(min_value=4000, max_value=9000))
@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_crafted_presets_are_preseterror(tmp_path, depth, digits):
    base = {"format": "vtrack-tuned-preset", "format_version": 1, "controller": "smc", "config": {}}
    for text in (json.dumps(base).replace('"config": {}', '"config": {}, "provenance": {"metrics": '
                                          + "[" * depth + "]" * depth + "}"),
                 json.dumps(base).replace('"config": {}', '"config": {"pole_radps": ' + "9" * digits + "}")):
        (tmp_path / "p.json").write_text(text)
        with pytest.raises(PresetError):
            load_preset(tmp_path / "p.json")


def test_mpc_preset_beyond_the_bounded_ranges_is_refused(tmp_path):
    preset = {"format": "vtrack-tuned-preset", "format_version": 1, "controller": "mpc",
              "config": {"prediction_horizon": 400, "control_horizon": 400, "n_speeds": 400}}
    (tmp_path / "p.json").write_text(json.dumps(preset))
    with pytest.raises(PresetError, match="prediction_horizon"):
        load_preset(tmp_path / "p.json")


@pytest.mark.parametrize("loader", ["preset", "agent", "csv"])
@pytest.mark.parametrize("kind", ["fifo", "device", "dir"])
def test_loaders_read_regular_files_only_and_never_block(tmp_path, loader, kind):
    from vtrack_gym.tracks.csv_loader import load_track_csv

    path = Path("/dev/zero") if kind == "device" else _special(tmp_path, kind)
    call = {"preset": load_preset, "agent": load_agent, "csv": load_track_csv}[loader]
    if loader == "agent" and kind != "dir":
        link = tmp_path / "a.json"
        link.symlink_to(path)
        path = link
    with pytest.raises(ValueError):
        call(path)
    with pytest.raises(ValueError):
        read_regular_file(path, 10, "file")


WORST_INPUTS = """
import os, resource, sys, json
from pathlib import Path
resource.setrlimit(resource.RLIMIT_AS, (1536 * 2**20, 1536 * 2**20))
from vtrack_gym.baselines.preset_files import load_preset
from vtrack_gym.baselines.numpy_policy import load_agent
from vtrack_gym.tracks.csv_loader import load_track_csv
tmp = Path(sys.argv[1])
os.mkfifo(tmp / "fifo.json")
big = tmp / "big.json"
with open(big, "wb") as fh:
    fh.truncate(8 * 2**30)      # sparse 8 GiB file
cases = [(load_preset, "/dev/zero"), (load_preset, tmp / "fifo.json"), (load_preset, big),
         (load_agent, tmp / "fifo.json"), (load_agent, big), (load_track_csv, "/dev/zero"),
         (load_track_csv, tmp / "fifo.json"), (load_track_csv, big), (load_preset, "/dev/urandom")]
for fn, arg in cases:
    try:
        fn(arg)
    except ValueError:
        pass
    else:
        sys.exit(f"{fn.__name__}({arg}) accepted")
print("ok")
"""


def test_worst_inputs_under_memory_and_time_limits(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", textwrap.dedent(WORST_INPUTS), str(tmp_path)], env=env,
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-2000:]


CSV_WORST = """
import resource, sys, time
from pathlib import Path
resource.setrlimit(resource.RLIMIT_AS, (3 * 2**30, 3 * 2**30))
from vtrack_gym.tracks.csv_loader import load_track_csv
path = Path(sys.argv[1])
start = time.perf_counter()
try:
    load_track_csv(path)
except ValueError as exc:
    print("ValueError", str(exc)[:200])
print(f"{time.perf_counter() - start:.1f}")
"""


@pytest.mark.parametrize("case", ["long_segment", "too_many_points"])
def test_csv_worst_cases_bounded(tmp_path, case):
    path = tmp_path / "t.csv"
    if case == "long_segment":  # 40k points bunched at one end of a 5 km segment
        xs = np.concatenate([np.linspace(0.0, 200.0, 40_000), [5000.0, 5000.0]])
        ys = np.concatenate([np.zeros(40_000), [0.0, 50.0]])
    else:  # one more point than MAX_POINTS
        from vtrack_gym.tracks.csv_loader import MAX_POINTS

        xs = np.arange(MAX_POINTS + 1, dtype=float) * 0.4
        ys = np.zeros_like(xs)
    path.write_text("x,y\n" + "\n".join(f"{x:.3f},{y:.3f}" for x, y in zip(xs, ys, strict=True)) + "\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", textwrap.dedent(CSV_WORST), str(path)], env=env,
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    assert float(out.stdout.strip().splitlines()[-1]) < 60.0


# ---------------------------------------------------------------- class 6: SB3 pickles need trust

def test_export_model_needs_trust(tmp_path, capsys):
    payload = tmp_path / "model.zip"
    payload.write_bytes(b"not even a zip")
    assert main(["export", "--model", str(payload), "--algo", "ppo", "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert "--trust" in err and "pickle" in err


def test_export_run_dir_not_signed_is_refused(tmp_path, capsys, monkeypatch):
    from vtrack_gym.agents.export import run_is_trusted, sign_run

    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))
    run = tmp_path / "run"
    run.mkdir()
    (run / "config.json").write_text(json.dumps({"algo": "ppo", "env_id": "DLC120-v0"}))
    (run / "model.zip").write_bytes(b"pretend pickle")
    assert not run_is_trusted(run)
    assert main(["export", "--run-dir", str(run), "--out", str(tmp_path / "x")]) == 2
    assert "--trust" in capsys.readouterr().err
    sign_run(run)
    assert run_is_trusted(run)
    (run / "model.zip").write_bytes(b"changed after training")
    assert not run_is_trusted(run)
    sign_run(run)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "other_user"))
    assert not run_is_trusted(run)  # another key (user / machine)
    assert "pickles" in _export_help()


def _export_help() -> str:
    from vtrack_gym.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    return sub.choices["export"].format_help()


def test_leaderboard_store_fifo_or_device_is_refused_without_blocking(tmp_path, capsys):
    os.mkfifo(tmp_path / "store.sqlite")
    for store in (tmp_path / "store.sqlite", Path("/dev/zero")):
        assert main(["leaderboard", "--store", str(store)]) == 2
        err = capsys.readouterr().err
        assert "not a regular file" in err and "Traceback" not in err


@given(scale=st.floats(min_value=1.0, max_value=1e4), obs_scale=st.floats(min_value=0.0, max_value=1e6),
       relu=st.booleans(), depth=st.integers(min_value=0, max_value=8), seed=st.integers(0, 2**32 - 1))
@settings(max_examples=60, deadline=None)
def test_agents_within_the_limits_always_predict_finite_actions(scale, obs_scale, relu, depth, seed):
    from vtrack_gym.baselines.numpy_policy import NumpyPolicy

    rng = np.random.default_rng(seed)
    sizes = [3, *([16] * depth), 1]
    arrays = {}
    for i in range(len(sizes) - 1):
        arrays[f"w{i}"] = (scale * rng.choice([-1.0, 1.0], size=(sizes[i], sizes[i + 1]))).astype(np.float32)
        arrays[f"b{i}"] = (scale * rng.choice([-1.0, 1.0], size=sizes[i + 1])).astype(np.float32)
    arrays["action_low"], arrays["action_high"] = -np.ones(1, np.float32), np.ones(1, np.float32)
    spec = {"format": "vtrack_gym.agent", "format_version": 1, "algo": "ppo", "obs_dim": 3, "action_dim": 1,
            "hidden_sizes": sizes[1:-1], "activation": "relu" if relu else "tanh", "output": "clip",
            "obs_norm": {"enabled": False, "eps": 1e-8},
            "provenance": {"env_id": "", "command": "", "timesteps": 0, "seed": 0, "package_version": "0",
                           "sb3_version": "0"}}
    action, _ = NumpyPolicy(spec, arrays).predict(obs_scale * rng.choice([-1.0, 1.0], size=(4, 3)))
    assert np.isfinite(action).all()
    arrays["w0"] = np.full((3, sizes[1]), 3e38, np.float32)  # float32 weights that overflow are refused
    with pytest.raises(ValueError, match="w0"):
        NumpyPolicy(spec, arrays)


STORE_SPECIALS = """
import os, sys
from pathlib import Path
from vtrack_gym.evaluation.storage.store import ResultStore, StoreError
tmp = Path(sys.argv[1])
os.mkfifo(tmp / "fifo.sqlite")
for path in (tmp / "fifo.sqlite", Path("/dev/null"), Path("/dev/zero")):
    for read_only in (False, True):
        try:
            ResultStore(path, read_only=read_only)
        except StoreError as exc:
            assert "not a regular file" in str(exc), exc
        else:
            sys.exit(f"ResultStore({path}) accepted")
print("ok")
"""


def test_store_refuses_fifos_and_devices_without_blocking(tmp_path):
    before = os.stat("/dev/null")
    out = subprocess.run([sys.executable, "-c", STORE_SPECIALS, str(tmp_path)], capture_output=True, text=True,
                         timeout=60, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-2000:]
    after = os.stat("/dev/null")
    assert stat.S_ISCHR(after.st_mode) and after.st_rdev == before.st_rdev


@pytest.mark.parametrize("item", ["n_steps=" + "9" * 5000, "n_steps=" + "9" * 30, "x=" + "[" * 5000 + "]" * 5000,
                                  "gamma=.inf", "net=" + "[" * 12 + "1" + "]" * 12, "x=" + "a" * 5000])
def test_train_set_values_are_bounded_before_any_work(tmp_path, capsys, item):
    run = tmp_path / "run"
    assert main(["train", "--algo", "ppo", "--timesteps", "64", "--run-dir", str(run), "--no-progress",
                 "--set", item]) == 2
    err = capsys.readouterr().err
    assert "--set" in err and "Traceback" not in err
    assert not (run / "model.zip").exists()


def test_too_many_seeds_refused(capsys):
    assert main(["eval", "--policy", "lqr", "--env", "DLC120-v0", "--seeds", ",".join(map(str, range(10_001))),
                 "--store", str(UNUSED_STORE)]) == 2
    assert not UNUSED_STORE.parent.exists()
    assert "at most 10000 seeds" in capsys.readouterr().err


@given(member=st.sampled_from(["w0.npy", "b0.npy", "action_low.npy"]),
       payload=st.one_of(st.binary(max_size=300),
                         st.builds(lambda shape, tail: _npy_header(shape) + tail,
                                   st.tuples(st.integers(0, 2**40), st.integers(0, 2**20)), st.binary(max_size=64))))
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
def test_random_npz_members_are_valueerror(tmp_path, member, payload):
    agent = _tiny_agent(tmp_path)
    _crafted_npz(agent.with_suffix(".npz"), member, payload, zipfile.ZIP_DEFLATED)
    with pytest.raises(ValueError, match=member.removesuffix(".npy")):
        load_agent(agent)


NUMERIC_OPTIONS = [("tune", "--generations", 1, 10_000), ("tune", "--pop-size", 2, 10_000),
                   ("tune", "--seed", 0, 2**32 - 1), ("tune", "--max-steps", 1, 10**7), ("tune", "--workers", 1, 4096),
                   ("train", "--timesteps", 1, 10**10), ("train", "--num-envs", 1, 4096),
                   ("train", "--eval-freq", 0, 10**10), ("train", "--bc-dagger-rounds", 0, 100)]


@given(option=st.sampled_from(NUMERIC_OPTIONS),
       value=st.one_of(st.integers(min_value=-2**80, max_value=2**80).map(str), st.text(max_size=12)))
@settings(max_examples=200, deadline=None)
@example(option=("tune", "--generations", 1, 10_000), value="--")  # argparse turned "--" into [] (found by this test)
def test_numeric_options_parse_in_range_or_exit_2(option, value):
    import contextlib

    from vtrack_gym.cli import build_parser

    command, flag, low, high = option
    base = ["tune", "--controller", "smc"] if command == "tune" else ["train", "--algo", "ppo", "--run-dir", "r"]
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err):
            args = build_parser().parse_args([*base, f"{flag}={value}"])
    except SystemExit as exc:
        assert exc.code == 2 and flag in err.getvalue()
        return
    parsed = getattr(args, flag.lstrip("-").replace("-", "_"))
    assert isinstance(parsed, int) and low <= parsed <= high


@pytest.mark.parametrize("name", ["config.json", "model.zip", "evaluations.jsonl"])
def test_train_refuses_a_run_dir_with_non_regular_outputs(tmp_path, capsys, name):
    run = tmp_path / "run"
    run.mkdir()
    os.mkfifo(run / name)
    assert main(["train", "--algo", "ppo", "--timesteps", "64", "--run-dir", str(run), "--no-progress"]) == 2
    assert "is a FIFO" in capsys.readouterr().err
    assert [p.name for p in run.iterdir()] == [name]


def test_folder_outputs_that_are_regular_files_are_refused_before_any_work(tmp_path, capsys):
    plain = tmp_path / "plain"
    plain.write_text("keep me")
    for argv in (["reproduce", "--quick", "--out", str(plain)], ["plot", "--out", str(plain)],
                 ["benchmark", "--store", str(tmp_path / "s.sqlite"), "--figures", str(plain)],
                 ["train", "--algo", "ppo", "--timesteps", "64", "--run-dir", str(plain)]):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert "is a regular file where a folder is needed" in err, err
    assert plain.read_text() == "keep me" and sorted(p.name for p in tmp_path.iterdir()) == ["plain"]
