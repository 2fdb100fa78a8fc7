"""The observation field table is the one source: space, layout, noise, agents' scaling and docs derive from it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vtrack_gym.envs import observation as O
from vtrack_gym.envs.config import EnvConfig
from vtrack_gym.envs.observation import OBS, SCALARS, ObservationField, ObservationLayout


def _expected_scalars(e_y: float, e_phi: float, v_x: float, v_y: float, r: float, delta: float, v_ref: float,
                      kappa: float, dkappa: float, s_dot: float, a_x: float) -> dict[str, float]:
    """Each scalar field by its documented formula (module docstring of ``envs.observation``)."""
    return {"e_y": e_y, "e_phi": e_phi, "e_y_dot": v_x * math.sin(e_phi) + v_y * math.cos(e_phi),
            "e_phi_dot": r - kappa * s_dot, "v_x": v_x, "v_y": v_y, "yaw_rate": r, "road_wheel_angle": delta,
            "target_speed": v_ref, "yaw_rate_ref": kappa * s_dot, "yaw_acc_ref": dkappa * s_dot ** 2 + kappa * a_x,
            "curvature": kappa, "curvature_rate": dkappa}


def test_the_writer_computes_every_row_of_the_table_at_its_index() -> None:
    from vtrack_gym.envs.kernels import write_scalar_fields

    args = (0.31, -0.07, 17.3, 0.42, 0.19, 0.033, 18.0, 0.011, -0.0023, 16.9, 0.7)
    expected = _expected_scalars(*args)
    assert tuple(expected) == O.SCALAR_FIELDS  # the formulas above cover exactly the table's rows
    row = np.full(OBS.size, np.nan, dtype=np.float32)
    write_scalar_fields(row, *args)
    for name, value in expected.items():
        assert row[OBS.index(name)] == pytest.approx(np.float32(value), rel=1e-6, abs=1e-9), name
    assert np.isnan(row[OBS.preview]).all() and np.isnan(row[OBS.speed_preview]).all()


def test_layout_and_space_derive_from_the_table() -> None:
    assert OBS.names[:O.N_SCALARS] == tuple(f.name for f in SCALARS)
    for j, f in enumerate(SCALARS):
        assert getattr(OBS, f.name.upper()) == j == OBS.index(f.name)
    low, high = OBS.bounds()
    table_high = [f.bound for f in SCALARS] + [O.CURVATURE_PREVIEW.bound] * OBS.n_preview \
        + [O.SPEED_PREVIEW.bound] * OBS.n_speed_preview
    np.testing.assert_array_equal(high, np.array(table_high, dtype=np.float32))
    np.testing.assert_array_equal(low, -high)
    assert all(name.startswith(O.CURVATURE_PREVIEW.name) for name in OBS.names[OBS.preview])
    assert all(name.startswith(O.SPEED_PREVIEW.name) for name in OBS.names[OBS.speed_preview])


def test_env_space_equals_the_table_bounds() -> None:
    from vtrack_gym.envs.tracking_env import observation_space

    space = observation_space(EnvConfig())
    np.testing.assert_array_equal(space.high, OBS.bounds()[1])
    np.testing.assert_array_equal(space.low, OBS.bounds()[0])


def test_noise_config_derives_from_the_table() -> None:
    measured = [f for f in SCALARS if f.noise_std is not None]
    assert O.NOISY_FIELDS == tuple(f.name for f in measured)
    assert EnvConfig().noise_std == tuple(f.noise_std for f in measured)
    assert O.NOISY_INDICES == tuple(OBS.index(f.name) for f in measured)


def test_agents_scaling_derives_from_the_table() -> None:
    pytest.importorskip("stable_baselines3")
    from vtrack_gym.agents.obs_scaling import fixed_statistics

    mean, var = fixed_statistics(OBS.names)
    rows = OBS.fields()
    np.testing.assert_array_equal(mean, [f.centre for f in rows])
    np.testing.assert_array_equal(var, [f.scale ** 2 for f in rows])


def test_docs_table_is_generated_from_the_table() -> None:
    doc = O.__doc__ or ""
    assert O.field_table() in doc
    for f in SCALARS:
        line = next(x for x in doc.splitlines() if x.startswith(f.name + " "))
        assert f.unit in line.split() and f"{f.bound:g}" in line.split() and line.endswith(f.doc)


def test_adding_a_field_is_one_row() -> None:
    """Every artefact derived from an extended table gains the new row (the kernel adds the line computing it)."""
    new = ObservationField("lateral_accel", "m/s^2", 100.0, 0.05, 0.0, 2.0, "body lateral acceleration")
    rows = (*SCALARS, new)
    names, stds = O.noise_columns(rows)
    assert names == (*O.NOISY_FIELDS, "lateral_accel") and stds == (*O.DEFAULT_NOISE_STD, 0.05)
    assert O.scale_columns(rows)["lateral_accel"] == (0.0, 2.0)
    assert O.field_table(rows).splitlines()[-2].startswith("lateral_accel")
    assert O.noise_columns(SCALARS) == (O.NOISY_FIELDS, O.DEFAULT_NOISE_STD)


@pytest.mark.parametrize("kwargs", [
    {"name": "bad name"}, {"bound": math.inf}, {"bound": 0.0}, {"noise_std": -1.0}, {"scale": 0.0},
    {"centre": 1e9}, {"name": "kappa", "series": True}])
def test_bad_rows_are_refused(kwargs: dict) -> None:
    base = {"name": "x", "unit": "m", "bound": 10.0, "noise_std": None, "centre": 0.0, "scale": 1.0, "doc": "x"}
    with pytest.raises(ValueError, match="ObservationField"):
        ObservationField(**{**base, **kwargs})


def test_shipped_layout_without_speed_preview() -> None:
    layout = ObservationLayout()
    assert layout.size == O.N_SCALARS + layout.n_preview
    assert len(layout.fields()) == layout.size
