"""The compiled-kernel cache cannot go stale: an edit to any kernel source recompiles on the next run, by itself.

Each test copies the package to a temporary folder and runs small kernels in fresh interpreters, as a contributor
editing a checkout (or a user of a read-only install) would.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from vtrack_gym._jit import KEEP_DIRS

PACKAGE = Path(__file__).resolve().parents[1] / "vtrack_gym"

CALLEE = '''from vtrack_gym._jit import kernel


@kernel
def offset(x: float) -> float:
    return x + 1.0
'''
CALLER = '''from vtrack_gym._jit import kernel
from vtrack_gym._probe_callee import offset


@kernel
def twice_offset(x: float) -> float:
    return 2.0 * offset(x)
'''
PROBE = '''import json, sys
from vtrack_gym import _jit
from vtrack_gym._probe_caller import twice_offset
value = twice_offset(1.0)
stats = twice_offset.stats
print(json.dumps({"value": value, "hits": sum(stats.cache_hits.values()), "misses": sum(stats.cache_misses.values()),
                  "dir": str(_jit.kernel_cache_dir())}))
'''


def _copy_package(root: Path, probes: bool = True) -> Path:
    """A copy of the package (no compiled files) under ``root`` with the two probe kernel modules."""
    target = root / "vtrack_gym"
    shutil.copytree(PACKAGE, target, ignore=shutil.ignore_patterns("__pycache__"))
    if probes:
        (target / "_probe_callee.py").write_text(CALLEE)
        (target / "_probe_caller.py").write_text(CALLER)
    return target


def _run(root: Path, code: str, prefix: tuple[str, ...] = ()) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env.update(PYTHONPATH=str(root), XDG_CACHE_HOME=str(root / "xdg"), PYTHONDONTWRITEBYTECODE="1")
    done = subprocess.run([*prefix, sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=root,
                          timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_editing_a_called_function_in_another_module_recompiles_the_caller(tmp_path: Path) -> None:
    package = _copy_package(tmp_path)
    first = _run(tmp_path, PROBE)
    assert first["value"] == 4.0 and first["misses"] == 1 and first["hits"] == 0
    assert Path(first["dir"]).is_relative_to(package / "__pycache__" / "kernels")
    again = _run(tmp_path, PROBE)
    assert again == {**first, "hits": 1, "misses": 0}  # unchanged sources: loaded from the cache
    (package / "_probe_callee.py").write_text(CALLEE.replace("x + 1.0", "x + 2.0"))
    edited = _run(tmp_path, PROBE)
    assert edited["value"] == 6.0 and edited["misses"] == 1 and edited["dir"] != first["dir"]
    assert _run(tmp_path, PROBE)["hits"] == 1


def test_plain_numba_cache_would_have_run_the_stale_callee(tmp_path: Path) -> None:
    """Why the package does not use numba's ``cache=True``: the same edit keeps the caller's old machine code."""
    package = _copy_package(tmp_path)
    for name, text in (("_probe_callee.py", CALLEE), ("_probe_caller.py", CALLER)):
        plain = text.replace("from vtrack_gym._jit import kernel", "from numba import njit")
        (package / name).write_text(plain.replace("@kernel", "@njit(cache=True)"))
    assert _run(tmp_path, PROBE)["value"] == 4.0
    (package / "_probe_callee.py").write_text((package / "_probe_callee.py").read_text().replace("+ 1.0", "+ 2.0"))
    assert _run(tmp_path, PROBE)["value"] == 4.0  # stale: numba checks only the caller's own file


def test_editing_a_package_kernel_module_reaches_its_callers(tmp_path: Path) -> None:
    """A real kernel: the env step's linear track column (``envs.kernels``) through ``tracks.kernels``'s ``wrap_s``,
    with ``wrap_s`` edited (clamping open paths at 1 m instead of 0)."""
    package = _copy_package(tmp_path, probes=False)
    code = '''import json, numpy as np
from vtrack_gym import _jit
from vtrack_gym.envs.kernels import _linear
table = np.arange(20.0).reshape(10, 2)
print(json.dumps({"value": _linear(table, 1.0, 9.0, False, -5.0, 0), "dir": str(_jit.kernel_cache_dir())}))
'''
    first = _run(tmp_path, code)
    assert first["value"] == 0.0
    kernels = package / "tracks" / "kernels.py"
    source = kernels.read_text()
    edited = source.replace("    if s < 0.0:\n        return 0.0\n", "    if s < 0.0:\n        return 1.0\n", 1)
    assert edited != source
    kernels.write_text(edited)
    assert _run(tmp_path, code)["value"] == 2.0  # row 1, column 0


def test_old_cache_directories_are_pruned(tmp_path: Path) -> None:
    package = _copy_package(tmp_path)
    dirs = []
    for k in range(KEEP_DIRS + 2):
        (package / "_probe_callee.py").write_text(CALLEE.replace("x + 1.0", f"x + {k}.0"))
        result = _run(tmp_path, PROBE)
        assert result["value"] == 2.0 * (1.0 + k)
        dirs.append(Path(result["dir"]))
    left = sorted(p for p in dirs[0].parent.iterdir() if p.is_dir())
    assert len(left) == KEEP_DIRS and set(dirs[-KEEP_DIRS:]) == set(left)


def test_read_only_install_caches_in_the_user_cache_dir() -> None:
    """Run as an unprivileged user (root may write a read-only folder): the package folder stays untouched and the
    second run loads the kernels from ``$XDG_CACHE_HOME/vtrack_gym/kernels``."""
    prefix: tuple[str, ...] = ()
    if os.geteuid() == 0:
        if shutil.which("setpriv") is None:
            pytest.skip("needs setpriv to drop root")
        prefix = ("setpriv", "--reuid=65534", "--regid=65534", "--clear-groups")
        probe = subprocess.run([*prefix, sys.executable, "-c", "import numba"], capture_output=True, cwd="/",
                               timeout=120)
        if probe.returncode != 0:
            pytest.skip("the unprivileged user cannot read this Python environment")
    tmp_path = Path(tempfile.mkdtemp(prefix="vtrack-kernels-"))  # pytest's own tmp_path is private to root
    os.chmod(tmp_path, 0o755)
    package = _copy_package(tmp_path)
    (tmp_path / "xdg").mkdir(mode=0o777)
    os.chmod(tmp_path / "xdg", 0o777)
    for folder in [package, *(p for p in package.rglob("*") if p.is_dir())]:
        os.chmod(folder, 0o555)
    try:
        before = sorted(p.relative_to(package) for p in package.rglob("*"))
        first = _run(tmp_path, PROBE, prefix)
        assert Path(first["dir"]).is_relative_to(tmp_path / "xdg" / "vtrack_gym" / "kernels")
        assert _run(tmp_path, PROBE, prefix)["hits"] == 1
        assert sorted(p.relative_to(package) for p in package.rglob("*")) == before
    finally:
        for folder in [package, *(p for p in package.rglob("*") if p.is_dir())]:
            os.chmod(folder, 0o755)
        shutil.rmtree(tmp_path, ignore_errors=True)
