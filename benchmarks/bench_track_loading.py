"""Track loading time and the self-crossing check's work for large CSV files.

Writes closed loops of 10k and 100k points at 0.1 m spacing (coordinates rounded to mm, like a survey export) to a
temporary folder and times ``load_track_csv`` on each (best of 3 after one warm-up that also imports scipy), the
self-crossing check alone (with its exact segment-pair tests per segment: flat in n means linear work), and the
curvature-limited speed profile on the loaded path. Run: ``python benchmarks/bench_track_loading.py``.
"""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path as FsPath

import numpy as np

from vtrack_gym.tracks import CurvatureLimited, load_track_csv, speed_table
from vtrack_gym.tracks.geometry import segment_intersections

SPACING_M = 0.1


def loop_points(n: int) -> np.ndarray:
    """n points ~0.1 m apart on a closed, wavy oval (radii of curvature down to ~12 m), rounded to mm."""
    length = n * SPACING_M
    t = np.linspace(0.0, 2.0 * math.pi, 20 * n, endpoint=False)
    a = length / 7.0
    xy = np.column_stack((a * np.cos(t), 0.6 * a * np.sin(t) + 0.02 * a * np.sin(9.0 * t)))
    seg = np.hypot(*np.diff(np.vstack((xy, xy[:1])), axis=0).T)
    s = np.concatenate(([0.0], np.cumsum(seg)))
    tt = np.interp(np.arange(n) * s[-1] / n, s, np.append(t, 2.0 * math.pi))
    out = np.column_stack((a * np.cos(tt), 0.6 * a * np.sin(tt) + 0.02 * a * np.sin(9.0 * tt)))
    return np.round(out, 3)


def best_of(fn, repeats: int = 3) -> float:
    fn()
    best = math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        print(f"{'points':>8} {'load [s]':>9} {'check [s]':>10} {'tests/seg':>10} {'profile [s]':>12} {'rows':>7}")
        for n in (10_000, 100_000):
            xy = loop_points(n)
            f = FsPath(tmp) / f"loop_{n}.csv"
            f.write_text("# x_m, y_m\n" + "\n".join(f"{x:.3f},{y:.3f}" for x, y in xy) + "\n")
            t_load = best_of(lambda f=f: load_track_csv(f))
            ring = np.vstack((xy, xy[:1]))
            t_check = best_of(lambda ring=ring: segment_intersections(ring, closed=True))
            work = segment_intersections(ring, closed=True).candidates / n
            path = load_track_csv(f)
            profile = CurvatureLimited(max_speed_mps=40.0 / 3.6, max_lateral_accel_mps2=0.7 * 9.80665)
            t_prof = best_of(lambda path=path, profile=profile: speed_table(path, profile))
            print(f"{n:>8} {t_load:>9.2f} {t_check:>10.3f} {work:>10.2f} {t_prof:>12.3f} {path.n_samples:>7}")


if __name__ == "__main__":
    main()
