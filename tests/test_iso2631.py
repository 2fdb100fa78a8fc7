"""ISO 2631-1 weightings vs the standard's table, time-domain filters vs the analytic gain, a_v, comfort scale."""

from __future__ import annotations

import itertools
import math
import subprocess
import sys

import numpy as np
import pytest

from vtrack_gym.evaluation.scoring.iso2631 import (
    WeightingParams,
    comfort_band,
    vibration_total,
    weighted,
    weighted_rms,
    weighting_magnitude,
)

# ISO 2631-1:1997, Table 3 "Principal frequency weightings in one-third octaves", factors x 1000 at the nominal
# one-third-octave band centre frequencies [Hz] (same numbers as the ISO 8041 weighting tables). Cross-checked
# against a public transcription of Table 3; the Annex A filter reproduces each entry to within 0.33 %.
ISO_TABLE3_WK = {
    0.1: 31.2, 0.125: 48.6, 0.16: 79.0, 0.2: 121, 0.25: 182, 0.315: 263, 0.4: 352, 0.5: 418, 0.63: 459,
    0.8: 477, 1.0: 482, 1.25: 484, 1.6: 494, 2.0: 531, 2.5: 631, 3.15: 804, 4.0: 967, 5.0: 1039, 6.3: 1054,
    8.0: 1036, 10.0: 988, 12.5: 902, 16.0: 768, 20.0: 636, 25.0: 513, 31.5: 405, 40.0: 314, 50.0: 246,
    63.0: 186, 80.0: 132,
}
ISO_TABLE3_WD = {
    0.1: 62.4, 0.125: 97.3, 0.16: 158, 0.2: 243, 0.25: 365, 0.315: 530, 0.4: 713, 0.5: 853, 0.63: 944,
    0.8: 992, 1.0: 1011, 1.25: 1008, 1.6: 968, 2.0: 890, 2.5: 776, 3.15: 642, 4.0: 512, 5.0: 409, 6.3: 323,
    8.0: 253,
    # 10 Hz is printed as 212, but the standard's own Annex A filter gives 201.7 (-4.9 %) while the neighbours
    # 8 Hz and 12.5 Hz agree to 0.06 %: we treat it as a misprint and leave it out of the 1 % check.
    12.5: 161, 16.0: 125, 20.0: 100, 25.0: 80.0, 31.5: 63.2, 40.0: 49.4, 50.0: 38.8, 63.0: 29.5, 80.0: 21.1,
}
# ISO 2631-1:1997, Table 3, Wf (motion sickness) around its pass band, factors x 1000.
ISO_TABLE3_WF = {0.1: 695, 0.125: 895, 0.16: 1006, 0.2: 992, 0.25: 854, 0.315: 619, 0.4: 384, 0.5: 224}

THIRD_OCTAVES_05_40 = (0.5, 0.63, 0.8, 1.0, 1.25, 1.6, 2.0, 2.5, 3.15, 4.0, 5.0, 6.3, 8.0, 10.0, 12.5, 16.0,
                       20.0, 25.0, 31.5, 40.0)


@pytest.mark.parametrize(("name", "table"), [("Wk", ISO_TABLE3_WK), ("Wd", ISO_TABLE3_WD), ("Wf", ISO_TABLE3_WF)])
def test_magnitude_matches_iso_table(name: str, table: dict[float, float]) -> None:
    freqs = np.array(list(table))
    expected = np.array(list(table.values())) / 1000.0
    ratio = weighting_magnitude(name, freqs) / expected
    np.testing.assert_allclose(ratio, 1.0, rtol=0.01)  # measured: max 0.28 % (Wk), 0.33 % (Wd), 0.08 % (Wf)


def test_wd_10hz_table_entry_disagrees_with_annex_a() -> None:
    assert float(weighting_magnitude("Wd", 10.0)) == pytest.approx(0.2017, abs=5e-5)


def test_paper_math_reference_values() -> None:
    assert float(weighting_magnitude("Wk", 1.0)) == pytest.approx(0.482, abs=1e-3)
    assert float(weighting_magnitude("Wk", 6.3)) == pytest.approx(1.054, abs=1e-3)
    assert float(weighting_magnitude("Wd", 1.0)) == pytest.approx(1.011, abs=1e-3)


def test_magnitude_shape_and_limits() -> None:
    f = np.array([[0.0, 1.0], [2.0, 1e4]])
    for name in ("Wk", "Wd", "Wf"):
        mag = weighting_magnitude(name, f)
        assert mag.shape == (2, 2)
        assert mag[0, 0] == 0.0  # band-limited: no DC
        assert mag[1, 1] < 1e-3
    assert weighting_magnitude("Wk", 5.0).shape == ()


def test_wf_sanity() -> None:
    f = np.geomspace(0.01, 10.0, 4001)
    mag = weighting_magnitude("Wf", f)
    assert 0.15 < f[mag.argmax()] < 0.19 and mag.max() == pytest.approx(1.01, abs=0.01)
    assert float(weighting_magnitude("Wf", 4.0)) < 1e-3 and float(weighting_magnitude("Wf", 0.02)) < 0.03
    fs, f0 = 250.0, 0.16  # time domain: 60 s settle (slowest pole 0.08 Hz), then 25 whole periods
    t = np.arange(round(220.0 * fs)) / fs
    y = weighted(np.sin(2 * np.pi * f0 * t), fs, "Wf")
    tail = y[-round(25 / f0 * fs):]
    assert math.sqrt(2.0) * float(np.sqrt(np.mean(tail**2))) == pytest.approx(
        float(weighting_magnitude("Wf", f0)), rel=2e-3)


def steady_sine_gain(name: str, fs: float, f: float, seconds: float = 30.0) -> float:
    """Steady-state RMS gain of ``weighted`` for a unit sine, over the whole periods of the last 20 s."""
    t = np.arange(round(seconds * fs)) / fs
    y = weighted(np.sin(2 * np.pi * f * t), fs, name)
    m = round(math.floor(20.0 * f) * fs / f)
    return math.sqrt(2.0) * float(np.sqrt(np.mean(y[-m:] ** 2)))


@pytest.mark.parametrize("fs", [250.0, 500.0, 1000.0])
@pytest.mark.parametrize("name", ["Wk", "Wd"])
def test_time_domain_matches_analytic_gain(name: str, fs: float) -> None:
    gains = np.array([steady_sine_gain(name, fs, f) for f in THIRD_OCTAVES_05_40])
    ratio = gains / weighting_magnitude(name, np.array(THIRD_OCTAVES_05_40))
    # required: 2 % at 500 Hz; measured max |ratio - 1| over 0.5..40 Hz: 0.13 % (250 Hz), 0.11 % (500 Hz),
    # 0.05 % (1000 Hz), because the bilinear filters run at >= 2000 Hz internally.
    np.testing.assert_allclose(ratio, 1.0, atol=2e-3)
    high = [steady_sine_gain(name, fs, f) / float(weighting_magnitude(name, f)) for f in (50.0, 63.0, 80.0)]
    np.testing.assert_allclose(high, 1.0, atol=1e-2)  # measured <= 0.85 %


def test_plain_bilinear_at_native_rate_is_worse() -> None:
    """Why ``weighted`` oversamples: the native-rate bilinear transform warps 40 Hz by -2.3 % at 500 Hz."""
    from scipy.signal import sosfreqz

    from vtrack_gym.evaluation.scoring.iso2631 import _digital_sos

    for fs, expected in ((500.0, -0.0228), (250.0, -0.0926)):
        _, h = sosfreqz(_digital_sos("Wk", fs), worN=[40.0], fs=fs)
        assert abs(h[0]) / float(weighting_magnitude("Wk", 40.0)) - 1.0 == pytest.approx(expected, abs=1e-3)


def step_energy(name: str) -> float:
    """Energy [(m/s^2)^2 s] of the response to a unit acceleration step, by Parseval on |W|."""
    from scipy.integrate import quad

    def integrand(f: float) -> float:
        return float(weighting_magnitude(name, f) / f) ** 2 if f > 0.0 else 0.0

    edges = [0.0, 0.05, 0.1, 0.4, 1.0, 2.0, 5.0, 12.5, 100.0, math.inf]
    total = sum(quad(integrand, a, b, limit=200)[0] for a, b in itertools.pairwise(edges))
    return total / (2.0 * math.pi**2)


def test_vibration_total_constant_inputs() -> None:
    fs, seconds = 500.0, 100.0
    n = round(fs * seconds)
    c = (0.3, -0.2, 1.5)  # constant accelerations: only the start-up transient survives the weighting
    a_v = vibration_total(np.full(n, c[0]), np.full(n, c[1]), np.full(n, c[2]), fs)
    e_d, e_k = step_energy("Wd"), step_energy("Wk")
    expected = math.sqrt(((c[0] ** 2 + c[1] ** 2) * e_d + c[2] ** 2 * e_k) / seconds)
    assert a_v == pytest.approx(expected, rel=1e-4)  # measured 1e-6
    assert vibration_total(np.zeros(n), np.zeros(n), np.zeros(n), fs) == 0.0


@pytest.mark.parametrize("k", [(1.0, 1.0, 1.0), (1.4, 1.4, 1.0)])
def test_vibration_total_sine_inputs(k: tuple[float, float, float]) -> None:
    fs, seconds = 250.0, 200.0
    t = np.arange(round(fs * seconds)) / fs
    amp, freq = (0.5, 0.8, 1.2), (1.0, 2.0, 6.3)
    a = [ai * np.sin(2 * np.pi * fi * t) for ai, fi in zip(amp, freq, strict=True)]
    a_v = vibration_total(a[0], a[1], a[2], fs, k=k)
    gains = [weighting_magnitude(w, fi) for w, fi in zip(("Wd", "Wd", "Wk"), freq, strict=True)]
    expected = math.sqrt(sum((ki * ai * float(g)) ** 2 / 2.0 for ki, ai, g in zip(k, amp, gains, strict=True)))
    assert a_v == pytest.approx(expected, rel=5e-3)  # whole record, start-up transient included
    assert weighted_rms(a[2], fs, "Wk") == pytest.approx(1.2 * 1.054 / math.sqrt(2.0), rel=5e-3)


@pytest.mark.parametrize(("a_v", "label"), [
    (0.0, "not uncomfortable"), (0.3, "not uncomfortable"), (0.315, "a little uncomfortable"),
    (0.45, "a little uncomfortable"), (0.5, "fairly uncomfortable"), (0.63, "fairly uncomfortable"),
    (0.8, "uncomfortable"), (1.2, "uncomfortable"), (1.25, "very uncomfortable"), (1.99, "very uncomfortable"),
    (2.0, "extremely uncomfortable"), (9.0, "extremely uncomfortable"),
])
def test_comfort_band(a_v: float, label: str) -> None:
    assert comfort_band(a_v) == label


@pytest.mark.parametrize("bad", [-0.1, float("nan"), float("inf")])
def test_comfort_band_rejects_bad_values(bad: float) -> None:
    with pytest.raises(ValueError, match="a_v"):
        comfort_band(bad)


def test_bad_inputs() -> None:
    x = np.zeros(1000)
    with pytest.raises(ValueError, match="finite"):
        weighted(np.array([0.0, np.nan, 1.0]), 500.0, "Wk")
    with pytest.raises(ValueError, match="fs_hz"):
        weighted(x, 199.0, "Wk")
    with pytest.raises(ValueError, match="fs_hz"):
        weighted_rms(x, float("nan"), "Wd")
    with pytest.raises(ValueError, match=r"valid names: \['Wd', 'Wf', 'Wk'\]"):
        weighted(x, 500.0, "Wb")
    with pytest.raises(ValueError, match="valid names"):
        weighting_magnitude("wk", 1.0)
    with pytest.raises(ValueError, match="1-D"):
        weighted(np.zeros((10, 3)), 500.0, "Wd")
    with pytest.raises(ValueError, match="1-D"):
        weighted([], 500.0, "Wd")
    with pytest.raises(ValueError, match="same length"):
        vibration_total(x, x, x[:-1], 500.0)
    with pytest.raises(ValueError, match="k must"):
        vibration_total(x, x, x, 500.0, k=(1.0, 1.0))
    with pytest.raises(ValueError, match="a_z"):
        vibration_total(x, x, np.full(1000, np.inf), 500.0)


def test_weighting_params_validation() -> None:
    with pytest.raises(ValueError, match="f1_hz"):
        WeightingParams(f1_hz=100.0, f2_hz=0.4, f3_hz=2.0, f4_hz=2.0, q4=0.63)
    with pytest.raises(ValueError, match="q4"):
        WeightingParams(f1_hz=0.4, f2_hz=100.0, f3_hz=2.0, f4_hz=2.0, q4=0.0)
    with pytest.raises(ValueError, match="f5_hz and f6_hz"):
        WeightingParams(f1_hz=0.4, f2_hz=100.0, f3_hz=2.0, f4_hz=2.0, q4=0.63, f5_hz=2.0)
    with pytest.raises(ValueError, match="q5"):
        WeightingParams(f1_hz=0.4, f2_hz=100.0, f3_hz=2.0, f4_hz=2.0, q4=0.63, f5_hz=2.0, f6_hz=3.0)


def test_imports_are_cheap() -> None:
    code = ("import sys, vtrack_gym.evaluation.scoring.iso2631, vtrack_gym.envs.pdflc; "
            "print(sorted(m for m in ('scipy', 'numba') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
