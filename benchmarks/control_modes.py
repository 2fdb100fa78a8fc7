"""The steering baselines with the pedals: max |e_y| in ``steer`` against ``steer_accel``, and the speed error.

For each policy (default: the decoupled mpc, smc and lqr, and the coupled NMPC ``nmpc_coupled``) and each paper
scenario, one episode (seed 0) through the public entry points (``vtrack_gym.evaluate`` of a factory
``make_policy(name, env)``, the rows' metrics as the leaderboard shows them):

* ``steer``: the paper's mode, the PD-FLC on the pedals inside the env (``nmpc_coupled`` drives ``steer_accel``
  only: its ``steer`` figure is the steering NMPC's, ``nmpc``, the same model without the speed states);
* ``steer_accel``: the policy on both (a steering baseline paired with the default speed law);
* ``steer_accel`` with ``launch="powertrain"`` for ``LateralTracking-v0`` (the held 40 km/h from rest reached on
  a ramp the powertrain can follow, ``envs.launch``; ``DLC120-v0`` starts at speed and has no launch).

Columns: max |e_y| [m] in each, the ratio steer_accel / steer, RMS speed error [m/s] (``rms_e_v_mps``), success;
the targets: ratio <= 1.25 and RMS speed error < 0.5 m/s. CPU (process) and wall seconds per episode and the load
average are printed beside them.

Run: ``python benchmarks/control_modes.py [--policies mpc,smc,lqr,nmpc_coupled] [--envs DLC120-v0,...]``.
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from typing import Any

import vtrack_gym

POLICIES = ("mpc", "smc", "lqr", "nmpc_coupled")
ENVS = ("DLC120-v0", "LateralTracking-v0")
STEER_COUNTERPART = {"nmpc_coupled": "nmpc"}
"""A policy that drives ``steer_accel`` only -> the steering policy whose ``steer`` figure it is compared with."""
TARGET_RATIO, TARGET_RMS_EV_MPS = 1.25, 0.5


def episode(name: str, env_id: str, control: str, launch: str | None = None) -> dict[str, Any]:
    """One seed-0 episode's row metrics (max_e_y_m, rms_e_v_mps, success) with its CPU and wall seconds."""
    c0, w0 = time.process_time(), time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)   # the step launch's warning: its figures are in the table
        row = vtrack_gym.evaluate(lambda env: vtrack_gym.make_policy(name, env), env_id, [0], control=control,
                                  launch=launch)[0]
    metrics = row.metrics
    return {"max_ey": float(metrics["max_e_y_m"]) if row.success else float("nan"),
            "rms_ev": float(metrics.get("rms_e_v_mps", float("nan"))), "success": bool(row.success),
            "termination": row.termination, "cpu_s": time.process_time() - c0, "wall_s": time.perf_counter() - w0}


def _cell(r: dict[str, Any]) -> str:
    ok = "yes" if r["success"] else f"no ({r['termination']})"
    return f"{r['max_ey']:.4f} / {r['rms_ev']:.3f} / {ok}"


def _verdict(steer: dict[str, Any], accel: dict[str, Any]) -> tuple[str, str]:
    """(ratio text, met / not met) of one steer_accel episode against its steer figure."""
    ratio = accel["max_ey"] / steer["max_ey"] if steer["success"] and accel["success"] else float("nan")
    met = accel["success"] and ratio <= TARGET_RATIO and accel["rms_ev"] < TARGET_RMS_EV_MPS
    return f"{ratio:.2f}", "met" if met else "not met"


HEADER = ("| policy | scenario | steer | steer_accel | ratio | target | steer_accel, launch=\"powertrain\" | ratio | "
          "target |\n|---|---|---|---|---|---|---|---|---|")


def table(policies: tuple[str, ...], envs: tuple[str, ...]) -> list[str]:
    """The markdown rows of the table; each row and one timing line per episode printed as it ends."""
    lines = []
    for name in policies:
        for env_id in envs:
            steer = episode(STEER_COUNTERPART.get(name, name), env_id, "steer")
            accel = episode(name, env_id, "steer_accel")
            ramp = episode(name, env_id, "steer_accel", "powertrain") if env_id == "LateralTracking-v0" else None
            for label, r in (("steer", steer), ("steer_accel", accel), ("powertrain", ramp)):
                if r is not None:
                    print(f"# {name} {env_id} {label}: cpu {r['cpu_s']:.1f} s, wall {r['wall_s']:.1f} s", flush=True)
            cells = [f"{name}", env_id, _cell(steer), _cell(accel), *_verdict(steer, accel)]
            cells += [_cell(ramp), *_verdict(steer, ramp)] if ramp is not None else ["-", "-", "-"]
            lines.append("| " + " | ".join(cells) + " |")
            print(lines[-1], flush=True)
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--policies", default=",".join(POLICIES))
    parser.add_argument("--envs", default=",".join(ENVS))
    args = parser.parse_args()
    c0, w0 = time.process_time(), time.perf_counter()
    print(f"# load average at start: {os.getloadavg()}")
    lines = table(tuple(args.policies.split(",")), tuple(args.envs.split(",")))
    print("\nmax |e_y| [m] / RMS speed error [m/s] / success (seed 0); ratio = steer_accel / steer max |e_y|; "
          f"target: ratio <= {TARGET_RATIO}, RMS speed error < {TARGET_RMS_EV_MPS} m/s\n")
    print(HEADER)
    print("\n".join(lines))
    print(f"\n# total: cpu {time.process_time() - c0:.1f} s, wall {time.perf_counter() - w0:.1f} s, "
          f"load average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
