"""The race baselines' driven laps against the car's lap-time bound: a table and the driven-lap figure of the Race
page (docs/figures/race_<circuit>.png).

    python benchmarks/race_laps.py [--figures docs/figures] [--split ids|validation|held_out|train]

For each circuit of ``--split`` (default ``ids``: the shipped circuits, ``vtrack/Race-v0``: the handling course,
``vtrack/RaceRing-v0``: the example ring; ``validation``, ``held_out``, ``train``: that group of the race split,
``tracks.race_circuits.RACE_SPLIT``, each driven as ``vtrack/Race-v0`` with ``track=`` the circuit), seed 0, two
laps from a standing start: each policy's verdict (``--policies``, default the two race baselines; e.g.
``--policies raceline,centreline,dagger_race``), laps completed, lap times, best lap / bound, track-limit
excursions (each run of steps beyond the rule counted once) and least edge margin, and the CPU and wall time of the
whole table with the load average; the figure shows the best lap of ``raceline``: its speed along the lap against the bound's profile,
and its longitudinal against lateral acceleration against the bound's.
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import numpy as np

import vtrack_gym

CIRCUITS = {"handling_course": "vtrack/Race-v0", "ring": "vtrack/RaceRing-v0"}
SPLITS = ("ids", "validation", "held_out", "train")


def circuits(split: str) -> dict[str, Callable[[], gym.Env]]:
    """``{label: make the race}`` for the circuits of ``split`` (``SPLITS``)."""
    if split == "ids":
        return {name: (lambda _id=env_id: gym.make(_id)) for name, env_id in CIRCUITS.items()}
    from vtrack_gym.tracks.race_circuits import RACE_SPLIT, race_circuit

    return {name: (lambda _n=name: gym.make("vtrack/Race-v0", track=race_circuit(_n))) for name in RACE_SPLIT[split]}


def run(env: gym.Env, name: str) -> tuple[dict, list[dict]]:
    """One episode of baseline ``name``: its last info and every step's info."""
    policy = vtrack_gym.make_policy(name, env)
    obs, info = env.reset(seed=0)
    infos = []
    while True:
        obs, _, terminated, truncated, info = env.step(policy.predict(obs)[0])
        infos.append(info)
        if terminated or truncated:
            return info, infos


def figure(env: gym.Env, infos: list[dict], title: str, file: Path) -> None:
    """Speed along the best lap against the bound's profile; the lap's a_x against a_y against the bound's."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from vtrack_gym.evaluation.figures.lap_figure import accelerations

    base = env.unwrapped
    length = base.lap_length_m
    p = np.array([i["progress_m"] for i in infos])
    last = p >= length                                   # the second (flying) lap
    bound = base.lap_bound
    rows = bound.path.table
    s_centre = base.paths[0].project(rows[:, 0], rows[:, 1]).s    # the bound's rows at their centre-line station
    order = np.argsort(s_centre)
    fig, (ax_v, ax_g) = plt.subplots(1, 2, figsize=(12, 4.2))
    ax_v.plot(s_centre[order], bound.speed_table.v_mps[order] * 3.6, color="0.5",
              label=f"bound ({bound.lap_time_s:.2f} s)")
    ax_v.plot(p[last] - length, np.array([i["v_mps"] for i in infos])[last] * 3.6, color="C0", lw=1.0,
              label="raceline, lap 2")
    ax_v.set_xlabel("centre-line station [m]")
    ax_v.set_ylabel("speed [km/h]")
    ax_v.legend(loc="lower right")
    _, a_x, a_y = accelerations(bound)
    ax_g.plot(a_y, a_x, ".", color="0.6", ms=2, label="bound")
    ax_g.plot([i["a_y_mps2"] for i, k in zip(infos, last, strict=True) if k],
              [i["a_x_mps2"] for i, k in zip(infos, last, strict=True) if k], ".", color="C0", ms=1.5,
              label="raceline, lap 2")
    ax_g.set_xlabel("lateral acceleration [m/s$^2$]")
    ax_g.set_ylabel("longitudinal acceleration [m/s$^2$]")
    ax_g.set_aspect("equal")
    ax_g.legend(loc="lower right")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(file, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--figures", type=Path, default=None)
    parser.add_argument("--policies", default="raceline,centreline",
                        help="comma-separated policies (race baselines, shipped agents, agent files)")
    parser.add_argument("--split", choices=SPLITS, default="ids")
    args = parser.parse_args()
    cpu0, wall0 = time.process_time(), time.perf_counter()
    print("| circuit | policy | success | laps_completed | lap_times_s | best_lap_s | lap_time_bound_s | "
          "lap_time_fraction | track_limit_violations | min_edge_margin_m |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for circuit, make in circuits(args.split).items():
        env = make()
        env_id = env.spec.id if args.split == "ids" else f"vtrack/Race-v0 on {circuit}"
        for name in args.policies.split(","):
            info, infos = run(env, name)
            m = env.unwrapped.success_metrics()
            laps = ", ".join(f"{t:.2f}" for t in info["lap_times_s"])
            verdict = "yes" if info["success"] else f"no ({info['termination'] or 'time limit'})"
            print(f"| {circuit} | {name} | {verdict} | {info['laps_completed']} | {laps} | {info['best_lap_s']:.2f} | "
                  f"{info['lap_time_bound_s']:.2f} | "
                  f"{info['lap_time_fraction']:.4f} | {m['track_limit_violations']:.0f} | "
                  f"{m['min_edge_margin_m']:.3f} |", flush=True)
            if args.figures is not None and name == "raceline":
                figure(env, infos, f"{env_id}: raceline's second lap against the bound",
                       args.figures / f"race_{circuit}.png")
    print(f"\n{len(circuits(args.split))} circuits: CPU {time.process_time() - cpu0:.1f} s, wall "
          f"{time.perf_counter() - wall0:.1f} s, load average {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
