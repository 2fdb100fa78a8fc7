"""CPU cost of the first ``gym.make`` of the exact-line env ids, and a bit-identity check of their planned lines.

Each make runs in a fresh process (the planned line is cached in memory only), timed with ``time.process_time``
(CPU) beside wall time, once with an empty kernel cache (cold: numba compiles) and once with it filled (warm).
``vtrack/DLC120-v0`` is measured in the same run as the peer. ``--record FILE`` instead writes the planned lines'
arrays (path table, spline coefficients, clearance) of every exact-line make to an ``.npz`` file; ``--compare A B``
checks two such files for bit-identity (``np.array_equal``), e.g. one recorded with another checkout first on
``PYTHONPATH``.

Run: ``python benchmarks/bench_exact_line.py`` (timings; ``--vehicle formula_student``: that car's makes),
``python benchmarks/bench_exact_line.py --record a.npz``,
``python benchmarks/bench_exact_line.py --compare a.npz b.npz``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

EXACT_IDS = ("vtrack/ISO3888-1-v2", "vtrack/ISO3888-2-v2")
PEER_ID = "vtrack/DLC120-v0"

_TIME_ONE = """
import json, sys, time
t0, w0 = time.process_time(), time.perf_counter()
import gymnasium as gym, vtrack_gym
t1, w1 = time.process_time(), time.perf_counter()
gym.make(sys.argv[1], **({"vehicle": sys.argv[2]} if len(sys.argv) > 2 else {}))
t2, w2 = time.process_time(), time.perf_counter()
print(json.dumps({"import_cpu": t1 - t0, "make_cpu": t2 - t1, "make_wall": w2 - w1}))
"""

_RECORD = """
import sys
import numpy as np
import gymnasium as gym, vtrack_gym
import vtrack_gym.tracks.exact_line as el
lines, plan = [], el.plan_exact_line
def recording(*args, **kwargs):
    line = plan(*args, **kwargs)
    lines.append(line)
    return line
el.plan_exact_line = recording
out = {}
for env_id in sys.argv[2:]:
    gym.make(env_id)
    for k, line in enumerate(lines):
        key = f"{env_id}#{k}"
        out[key + "/table"], out[key + "/coef"] = line.path.table, line._coef
        out[key + "/clearance"] = np.array([line.clearance_m])
    lines.clear()
np.savez(sys.argv[1], **out)
"""


def _run(code: str, args: list[str], cache_dir: str) -> str:
    """Stdout of ``python -c code args`` in a fresh process with ``NUMBA_CACHE_DIR=cache_dir``."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir, OMP_NUM_THREADS="1")
    return subprocess.run([sys.executable, "-c", code, *args], env=env, check=True, capture_output=True,
                          text=True).stdout


def time_makes(ids: tuple[str, ...], vehicle: str | None = None) -> None:
    """Print CPU [s] and wall [s] of the first make of each id (with ``vehicle=``, a car's name, if given), cold
    and warm kernel cache, and the load."""
    print(f"load average {os.getloadavg()}")
    for env_id in ids:
        with tempfile.TemporaryDirectory(prefix="bench_exact_line_") as cache:
            for label in ("cold", "warm"):
                r = json.loads(_run(_TIME_ONE, [env_id, *([vehicle] if vehicle else [])], cache)
                               .strip().splitlines()[-1])
                print(f"{env_id:24s} {label}: make CPU {r['make_cpu']:6.2f} s  wall {r['make_wall']:6.2f} s  "
                      f"(import CPU {r['import_cpu']:.2f} s)", flush=True)
    print(f"load average {os.getloadavg()}")


def compare(a_file: str, b_file: str) -> bool:
    """True when both recordings hold the same keys and bit-identical arrays; prints each difference."""
    a, b = np.load(a_file), np.load(b_file)
    same = sorted(a.files) == sorted(b.files)
    if not same:
        print(f"keys differ: {sorted(set(a.files) ^ set(b.files))}")
    for key in sorted(set(a.files) & set(b.files)):
        if not np.array_equal(a[key], b[key]):
            same = False
            print(f"{key}: differs, max |diff| {np.max(np.abs(a[key] - b[key])):.3g}")
    print(f"{len(a.files)} arrays: {'bit-identical' if same else 'DIFFERENT'}")
    return same


def main() -> None:
    """Command line: timings (default), ``--record FILE`` or ``--compare A B``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--record", metavar="FILE")
    parser.add_argument("--compare", nargs=2, metavar=("A", "B"))
    parser.add_argument("--vehicle", help="time the makes with this car (vehicle=; default: the env's own)")
    args = parser.parse_args()
    if args.record:
        cache = os.environ.get("NUMBA_CACHE_DIR", tempfile.gettempdir())
        _run(_RECORD, [args.record, *EXACT_IDS], cache)
    elif args.compare:
        sys.exit(0 if compare(*args.compare) else 1)
    else:
        time_makes((*EXACT_IDS, PEER_ID), args.vehicle)


if __name__ == "__main__":
    main()
