"""Learning curves of the from-scratch RL recipes: train each seed with the shipped hyperparameters (no warm start)
and tabulate the periodic paper-scenario evaluations across seeds; write the figure.

    PYTHONPATH=. python benchmarks/rl_recipes.py --algo ppo --seeds 0,1,2 --timesteps 4000000 --out runs/rl
    PYTHONPATH=. python benchmarks/rl_recipes.py --summarise runs/rl/ppo_s0 runs/rl/ppo_s1 ... --out runs/rl

Each run is ``vtrack_gym.agents.train.train(algo, DEFAULT_ENV_ID, ...)``, exactly what ``vtrack train --algo
ALGO --timesteps N --seed S`` runs. Every ``--eval-freq`` steps the deterministic policy drives ``DLC120-v0`` in
full and the first 30 s of ``LateralTracking-v0`` (the full lap at the end). Reported per evaluation step, over
seeds: the share of seeds whose DLC120-v0 run succeeded (every cone gate passed) with Case 1 not failed, and the
DLC120-v0 max |e_y| [m] (mean, min, max over the seeds that succeeded). Figure: ``<out>/learning_curves_<algo>.png``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

FAILURES = ("off_road", "spin_out", "wheel_lift", "invalid_state")


def read_curve(run_dir: Path) -> list[dict]:
    """The periodic evaluations of one run (``evaluations.jsonl``), in step order."""
    lines = (run_dir / "evaluations.jsonl").read_text(encoding="utf-8").strip().splitlines()
    return [json.loads(line) for line in lines]


def paper_success(results: dict) -> bool:
    """DLC120-v0 succeeded (gates) and LateralTracking-v0 (capped or full) did not fail."""
    dlc, lap = results["DLC120-v0"], results["LateralTracking-v0"]
    ok_dlc = bool(dlc.get("success", dlc.get("completed")))
    ok_lap = lap["termination"] not in FAILURES and (lap.get("step_cap") is not None or lap.get("completed"))
    return ok_dlc and ok_lap


def table(curves: dict[str, list[dict]]) -> list[dict]:
    """One row per evaluation step shared by every run: success share and DLC max |e_y| statistics."""
    steps = sorted(set.intersection(*[{e["timesteps"] for e in c if not e["final"]} for c in curves.values()]))
    rows = []
    for step in steps:
        ok, ey, case1, ey_all = [], [], [], []
        for curve in curves.values():
            e = next(x for x in curve if x["timesteps"] == step and not x["final"])
            ok.append(paper_success(e["results"]))
            ey_all.append(e["results"]["DLC120-v0"]["max_e_y_m"])
            if ok[-1]:
                ey.append(e["results"]["DLC120-v0"]["max_e_y_m"])
                case1.append(e["results"]["LateralTracking-v0"]["max_e_y_m"])
        rows.append({"steps": step, "success": sum(ok) / len(ok), "n": len(ok),
                     "dlc_mean": sum(ey) / len(ey) if ey else math.nan, "dlc_min": min(ey, default=math.nan),
                     "dlc_max": max(ey, default=math.nan),
                     "case1_mean": sum(case1) / len(case1) if case1 else math.nan,
                     "dlc_all_mean": sum(ey_all) / len(ey_all)})
    return rows


def finals(curves: dict[str, list[dict]]) -> list[str]:
    """One line per run: its final evaluation (full Case 1 lap) and wall time."""
    out = []
    for name, curve in curves.items():
        last = [e for e in curve if e["final"]]
        if not last:
            out.append(f"{name}: no final evaluation")
            continue
        r = last[-1]["results"]
        dlc, lap = r["DLC120-v0"], r["LateralTracking-v0"]
        out.append(f"{name}: DLC120-v0 {dlc['termination']} success={dlc.get('success')} max e_y "
                   f"{dlc['max_e_y_m']:.3f} m | LateralTracking-v0 (full lap) {lap['termination']} max e_y "
                   f"{lap['max_e_y_m']:.3f} m")
    return out


def plot(rows: list[dict], path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = [r["steps"] / 1e6 for r in rows]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 3.8))
    a1.plot(x, [r["success"] for r in rows], marker="o")
    a1.set(xlabel="environment steps [millions]", ylabel="share of seeds", ylim=(-0.05, 1.05),
           title="success on both paper scenarios")
    mean = [r["dlc_mean"] for r in rows]
    a2.plot(x, mean, marker="o", label="mean over successful seeds")
    a2.plot(x, [r["dlc_all_mean"] for r in rows], ls=":", marker=".", label="mean over all seeds")
    a2.fill_between(x, [r["dlc_min"] for r in rows], [r["dlc_max"] for r in rows], alpha=0.25, label="min-max")
    a2.axhline(0.156, color="k", ls="--", lw=1, label="tuned MPC (0.156 m)")
    a2.set(xlabel="environment steps [millions]", ylabel="DLC120-v0 max |e_y| [m]", title="lane-change precision")
    a2.legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--algo", choices=("ppo", "sac"), default="ppo")
    ap.add_argument("--seeds", default="0,1,2", help="comma-separated training seeds")
    ap.add_argument("--timesteps", type=int, default=4_000_000)
    ap.add_argument("--eval-freq", type=int, default=250_000)
    ap.add_argument("--out", type=Path, default=Path("vtrack_runs/rl_recipes"))
    ap.add_argument("--overwrite", action="store_true",
                    help="replace earlier runs in --out (default: refuse a seed folder that holds a run)")
    ap.add_argument("--summarise", type=Path, nargs="*", default=None, metavar="RUN_DIR",
                    help="only tabulate these finished run folders (no training)")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.summarise:
        runs = list(args.summarise)
    else:
        from vtrack_gym.agents.train import DEFAULT_ENV_ID, check_run_dir, train

        seeds = [int(s) for s in args.seeds.split(",")]
        for seed in seeds:  # every seed's folder checked before the first one trains (hours of work)
            try:
                check_run_dir(args.out / f"{args.algo}_s{seed}", args.overwrite)
            except ValueError as exc:
                ap.error(str(exc))
        runs = []
        for seed in seeds:
            run = args.out / f"{args.algo}_s{seed}"
            summary = train(args.algo, DEFAULT_ENV_ID, args.timesteps, seed, run, eval_freq=args.eval_freq,
                            case1_full_every=0, overwrite=args.overwrite,
                            command=f"vtrack train --algo {args.algo} --timesteps {args.timesteps} --seed {seed} "
                            f"--run-dir {run} --eval-freq {args.eval_freq} --case1-full-every 0"
                            + (" --overwrite" if args.overwrite else ""))
            print(f"{run}: {summary['timesteps']} steps in {summary['train_s']} s", flush=True)
            runs.append(run)
    curves = {str(r): read_curve(r) for r in runs}
    rows = table(curves)
    print("| steps | success (both paper scenarios) | DLC120-v0 max e_y, successful seeds: mean [min, max] | "
          "DLC120-v0 max e_y, all seeds: mean | Case 1 (30 s) max e_y, successful seeds |")
    print("|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['steps']:,} | {r['success']:.2f} of {r['n']} | {r['dlc_mean']:.3f} [{r['dlc_min']:.3f}, "
              f"{r['dlc_max']:.3f}] m | {r['dlc_all_mean']:.3f} m | {r['case1_mean']:.3f} m |")
    for line in finals(curves):
        print(line)
    fig = args.out / f"learning_curves_{args.algo}.png"
    plot(rows, fig, f"{args.algo.upper()} from scratch on vtrack/TrainingMix20Hz-v0, {len(runs)} seeds")
    print(f"figure: {fig}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
