"""The compiled-kernel cache is keyed on compiled code only: an edit to a module no kernel depends on keeps every
compiled kernel; an edit to a compiled function, to what it calls or to a constant it reads recompiles.

Each case copies the package, edits one line of the copy and compares the cache key (``_jit.source_hash``) of the
copy with that of an untouched copy; one case runs a kernel in fresh interpreters, as a contributor would.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from test_kernel_cache import PROBE, _copy_package, _run

from vtrack_gym._jit import source_hash
from vtrack_gym._kernel_sources import kernel_sources

PACKAGE = Path(__file__).resolve().parents[1] / "vtrack_gym"

NOT_COMPILED = {
    "a plot": ("evaluation/figures/plots.py", "def _pyplot():", "def _pyplot():  # edited"),
    "the CLI's env helper (imports _jit lazily)": ("cli/_envs.py", "from vtrack_gym._jit import kernel_cache_dir",
                                                   "from vtrack_gym._jit import kernel_cache_dir  # edited"),
    "a registry line": ("envs/scenarios.py", "MAX_EPISODE_S = 7200.0", "MAX_EPISODE_S = 7201.0"),
    "the env's batch driver": ("envs/sim.py", "def _kernels():",
                                                            "def _kernels():  # edited"),
    "the tracks' planner": ("tracks/planned_line.py", "SLP_ITERATIONS = 4", "SLP_ITERATIONS = 5"),
}
COMPILED = {
    "a compiled function's body": ("vehicle/kernels.py", "def step_vehicle(", "def step_vehicle(  # edited\n"),
    "a compiled function it calls, in another module": ("tracks/kernels.py", "    if s < 0.0:\n        return 0.0\n",
                                                        "    if s < 0.0:\n        return 1.0\n"),
    "a constant compiled code reads": ("vehicle/layout.py", "O_AX, O_AY, O_AZ", "O_AX, O_AY, O_AZ  "),
    "the PD-FLC kernel": ("envs/pdflc_kernel.py", "@kernel(inline=True)\n", "@kernel(inline=True)  # edited\n"),
}


def _edited_copy(root: Path, relative: str, old: str, new: str) -> Path:
    """A copy of the package under ``root`` with the first ``old`` of ``relative`` replaced by ``new``."""
    package = root / "vtrack_gym"
    shutil.copytree(PACKAGE, package, ignore=shutil.ignore_patterns("__pycache__"))
    path = package / relative
    text = path.read_text()
    assert old in text, f"{relative} no longer contains {old!r}: update this test"
    path.write_text(text.replace(old, new, 1))
    return package


@pytest.fixture(scope="module")
def untouched(tmp_path_factory: pytest.TempPathFactory) -> str:
    root = tmp_path_factory.mktemp("untouched")
    shutil.copytree(PACKAGE, root / "vtrack_gym", ignore=shutil.ignore_patterns("__pycache__"))
    return source_hash(root / "vtrack_gym")


@pytest.mark.parametrize("what", sorted(NOT_COMPILED))
def test_editing_code_no_kernel_depends_on_keeps_the_cache(what: str, untouched: str, tmp_path: Path) -> None:
    package = _edited_copy(tmp_path, *NOT_COMPILED[what])
    assert source_hash(package) == untouched


@pytest.mark.parametrize("what", sorted(COMPILED))
def test_editing_compiled_code_invalidates_the_cache(what: str, untouched: str, tmp_path: Path) -> None:
    package = _edited_copy(tmp_path, *COMPILED[what])
    assert source_hash(package) != untouched


def test_the_key_covers_the_kernel_modules_not_the_import_graph() -> None:
    files = {p.relative_to(PACKAGE).as_posix() for p in kernel_sources(PACKAGE)}
    assert {"envs/kernels.py", "vehicle/kernels.py", "tracks/kernels.py", "envs/pdflc_kernel.py",
            "baselines/laws.py", "tuning/_kernels.py", "vehicle/layout.py", "_jit.py"} <= files
    assert not files & {"cli/_envs.py", "evaluation/figures/plots.py", "envs/scenarios.py", "envs/sim.py",
                        "envs/tracking_env.py", "tracks/planned_line.py"}
    assert len(files) < 40, sorted(files)


def test_a_kernel_stays_cached_after_an_edit_elsewhere(tmp_path: Path) -> None:
    """End to end: the probe kernel compiles once; an edit to a plot module loads it from the same cache."""
    package = _copy_package(tmp_path)
    first = _run(tmp_path, PROBE)
    assert first["misses"] == 1
    plots = package / "evaluation" / "figures" / "plots.py"
    plots.write_text(plots.read_text() + "\n# edited\n")
    again = _run(tmp_path, PROBE)
    assert again == {**first, "hits": 1, "misses": 0}
