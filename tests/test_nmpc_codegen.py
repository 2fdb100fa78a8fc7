"""The CasADi method's compiled model: generated C compiled once into the user's cache, keyed by its content, and
CasADi's virtual machine where no compiler is found (logged once)."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("casadi")

from vtrack_gym.baselines import nmpc_codegen, nmpc_model
from vtrack_gym.vehicle.params import DesignModel, VehicleParams

DESIGN = DesignModel.from_vehicle(VehicleParams())
SHAPE = nmpc_model.TyreShape(1.367, 0.962, 1.365, 0.974)


def _functions(lag_s: float, compiled: bool) -> nmpc_model.HorizonFunctions:
    nmpc_model.horizon_functions.cache_clear()
    return nmpc_model.horizon_functions(DESIGN, SHAPE, lag_s, 0.05, 2, 10, compiled)


def _states(fns: nmpc_model.HorizonFunctions) -> np.ndarray:
    u = 0.05 * np.sin(np.arange(10) / 3.0).reshape(1, -1)
    return np.asarray(fns.simulate(np.array([0.1, 0.02, 0.3, 0.05, 0.01]), u, np.full((1, 10), 25.0),
                                   np.full((1, 10), 0.01)))


def test_the_library_key_follows_the_source_the_compiler_and_casadi() -> None:
    key = nmpc_codegen.library_key("int f;", "/usr/bin/cc", "3.8.2")
    assert key == nmpc_codegen.library_key("int f;", "/usr/bin/cc", "3.8.2")
    assert len(key) == nmpc_codegen.KEY_CHARS and int(key, 16) >= 0
    others = {nmpc_codegen.library_key("int g;", "/usr/bin/cc", "3.8.2"),
              nmpc_codegen.library_key("int f;", "/usr/bin/gcc", "3.8.2"),
              nmpc_codegen.library_key("int f;", "/usr/bin/cc", "3.7.0")}
    assert key not in others and len(others) == 3


def test_the_model_is_compiled_once_into_the_cache_and_reused(monkeypatch: pytest.MonkeyPatch,
                                                               tmp_path: Path) -> None:
    if nmpc_codegen.c_compiler() is None:
        pytest.skip("no C compiler here (the fallback is tested below)")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    compiled = _functions(0.031, True)
    libraries = list((tmp_path / "vtrack_gym" / "nmpc").glob("vtrack_nmpc_*.so"))
    assert compiled.compiled and len(libraries) == 1
    np.testing.assert_allclose(_states(compiled), _states(_functions(0.031, False)), rtol=1e-12, atol=1e-14)

    def no_compile(*args: object) -> None:
        raise AssertionError("the cached library should have been loaded")

    monkeypatch.setattr(nmpc_codegen, "_compile", no_compile)
    assert _functions(0.031, True).compiled                                  # same model: loaded, not compiled
    monkeypatch.undo()
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    _functions(0.032, True)                                                  # another model: another library
    assert len(list((tmp_path / "vtrack_gym" / "nmpc").glob("vtrack_nmpc_*.so"))) == 2


def test_without_a_compiler_the_virtual_machine_is_used_and_said_once(monkeypatch: pytest.MonkeyPatch,
                                                                      caplog: pytest.LogCaptureFixture,
                                                                      tmp_path: Path) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setattr(nmpc_codegen, "c_compiler", lambda: None)
    nmpc_codegen._log_fallback.cache_clear()
    with caplog.at_level(logging.WARNING, logger="vtrack_gym.baselines.nmpc_codegen"):
        first = _functions(0.033, True)
        second = _functions(0.034, True)
    assert not first.compiled and not second.compiled
    assert not nmpc_model.c_compiler_available()
    said = [r for r in caplog.records if "no C compiler" in r.getMessage()]
    assert len(said) == 1 and "virtual machine" in said[0].getMessage()
    assert not (tmp_path / "vtrack_gym").exists()
    np.testing.assert_allclose(_states(first), _states(_functions(0.033, False)), rtol=0, atol=0)
