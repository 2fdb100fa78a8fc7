"""CPU time of the automatic smoothing fit of GPS-like CSV tracks, against the number of points.

Writes open, gently winding roads sampled every 0.5 m with 3 cm of Gaussian noise on x and y (coordinates rounded to
mm, like a GPS log export) of 5k, 20k and 200k points, and measures the CPU time of ``load_track_csv`` on each in a
fresh process (imports excluded): once with the automatic smoothing (the default) and once with
``smoothing_m=0.05``. The load may end in a ``ValueError`` (noise this large makes kinks an observation cannot hold
unless smoothing_m is given); its time is what is bounded. ``docs/GUARANTEES.md`` promises under 60 s of CPU at
200k points. Run: ``python benchmarks/bench_csv_fit.py [N ...]``.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import numpy as np

SPACING_M = 0.5
NOISE_M = 0.03
SIZES = (5_000, 20_000, 200_000)

MEASURE = textwrap.dedent("""
    import sys, time, warnings
    warnings.simplefilter("ignore")
    from vtrack_gym.tracks.csv_loader import load_track_csv
    smoothing = None if sys.argv[2] == "auto" else float(sys.argv[2])
    start = time.process_time()
    try:
        path = load_track_csv(sys.argv[1], smoothing_m=smoothing)
        outcome = f"{path.length_m / 1000:.1f} km"
    except ValueError as exc:
        outcome = "ValueError: " + str(exc).split(": ", 1)[-1][:60]
    print(f"{time.process_time() - start:.2f}|{outcome}")
""")


def write_gps_road(file: Path, n: int, seed: int = 0) -> Path:
    """``n`` points every ``SPACING_M`` along a road winding with a 940 m period (radii >= 100 m), with
    ``NOISE_M`` of noise on x and y, rounded to mm."""
    rng = np.random.default_rng(seed)
    s = np.arange(n) * SPACING_M
    kappa = 0.01 * np.sin(s / 150.0)
    psi = np.concatenate(([0.0], np.cumsum(kappa[1:] * SPACING_M)))
    x = np.concatenate(([0.0], np.cumsum(np.cos(psi[:-1]) * SPACING_M))) + rng.normal(0.0, NOISE_M, n)
    y = np.concatenate(([0.0], np.cumsum(np.sin(psi[:-1]) * SPACING_M))) + rng.normal(0.0, NOISE_M, n)
    file.write_text("x_m,y_m\n" + "\n".join(f"{a:.3f},{b:.3f}" for a, b in zip(x, y, strict=True)) + "\n")
    return file


def cpu_seconds(file: Path, smoothing: str) -> tuple[float, str]:
    """CPU time [s] of ``load_track_csv(file)`` in a fresh process, and what it returned."""
    done = subprocess.run([sys.executable, "-c", MEASURE, str(file), smoothing], capture_output=True, text=True,
                          check=True)
    seconds, outcome = done.stdout.strip().splitlines()[-1].split("|", 1)
    return float(seconds), outcome


def main(sizes: tuple[int, ...] = SIZES) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        print(f"{'points':>8} {'smoothing':>10} {'CPU [s]':>8}  outcome")
        for n in sizes:
            file = write_gps_road(Path(tmp) / f"gps_{n}.csv", n)
            for smoothing in ("auto", "0.05"):
                seconds, outcome = cpu_seconds(file, smoothing)
                print(f"{n:>8} {smoothing:>10} {seconds:>8.2f}  {outcome}")


if __name__ == "__main__":
    main(tuple(int(a) for a in sys.argv[1:]) or SIZES)
