"""The slow tier's registry (``tests/conftest.py``) names real tests, and its gate marks them."""

from __future__ import annotations

import ast
from pathlib import Path

from conftest import KEEP_FAST, SLOW, slow_reason

TESTS = Path(__file__).resolve().parent


def test_every_slow_entry_names_a_test_function() -> None:
    for entry in SLOW:
        path, _, test = entry.partition("::")
        assert (TESTS / path).is_file(), f"SLOW lists {entry}: no file {path}"
        if test:
            function = test.split("[", 1)[0]
            tree = ast.parse((TESTS / path).read_text(encoding="utf-8"))
            names = {n.name for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)}
            assert function in names, f"SLOW lists {entry}: {path} has no {function}"


def test_every_case_kept_fast_is_a_case_of_a_grid_listed_slow() -> None:
    for entry in KEEP_FAST:
        path, _, test = entry.partition("::")
        function, bracket, _ = test.partition("[")
        assert bracket and f"{path}::{function}" in SLOW, f"KEEP_FAST lists {entry}: not a case of a slow grid"
        assert slow_reason(f"tests/{entry}") is None
        assert slow_reason(f"tests/{path}::{function}[a-case-not-kept]") is not None


def test_the_gate_matches_a_file_a_function_or_one_case(monkeypatch) -> None:
    monkeypatch.setitem(SLOW, "test_made_up.py", "a whole file")
    assert slow_reason("tests/test_made_up.py::test_any[case]") == "a whole file"
    assert slow_reason("tests/test_reproduce.py::test_report_is_deterministic_apart_from_timestamp") is not None
    assert slow_reason("tests/test_reproduce.py::test_figures_written") is None
    assert slow_reason("tests/test_agents.py::test_offpolicy_train_export_agreement[td3]") is not None
    assert slow_reason("tests/test_plain_loop.py::test_plain_loop_equals_sb3_loop[nmpc-LateralTracking-v0]")
    assert slow_reason("tests/test_plain_loop.py::test_plain_loop_equals_sb3_loop[smc-DLC120-v0]") is None
    assert slow_reason("tests/test_envs.py::test_make_without_prior_import") is None


def test_the_readme_names_both_tiers_and_the_fast_one_leaves_the_slow_tests_out() -> None:
    import subprocess
    import sys

    readme = (TESTS.parent / "README.md").read_text(encoding="utf-8")
    assert "python -m pytest -q -n 2" in readme and 'python -m pytest -q -m "not slow" -n 2' in readme
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-m", "not slow", "--collect-only", "-p", "no:xdist",
                           "tests/test_reproduce.py", "tests/test_plain_loop.py"], capture_output=True, text=True,
                          cwd=TESTS.parent, timeout=300)
    assert "test_report_is_deterministic_apart_from_timestamp" not in done.stdout, done.stdout
    assert "nmpc-LateralTracking-v0" not in done.stdout and "test_figures_written" in done.stdout, done.stdout
    assert "test_plain_loop.py::test_plain_loop_equals_sb3_loop[smc-DLC120-v0]" in done.stdout, done.stdout
