"""The runs behind ``vtrack reproduce``: which episodes (cases x preset pairs), running them, and their figures.

Case 1 (``LateralTracking-v0``: 0 -> 40 km/h on the handling course) and Case 2 (``DLC120-v0``: double lane
change at 120 km/h), each with PD-FLC + SMC and PD-FLC + MPC, for the preset pairs in ``PAIRS``. The figures are
the paper-figure analogues (Figs. 8-13 for Case 1, 15-19 for Case 2) as PNG files. The prose report that checks
the paper's claims on these runs is ``vtrack_gym.evaluation.reproduction.reproduce_report``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym

from vtrack_gym.evaluation.rollouts.rollout import rollout
from vtrack_gym.evaluation.scoring.metrics import evaluate_trace
from vtrack_gym.evaluation.scoring.trace import Trace

QUICK_MAX_STEPS = {"LateralTracking-v0": 1500, "DLC120-v0": 500}
"""Control steps per episode with ``--quick`` (15 s and 5 s of driving: a smoke test, not a reproduction)."""

CASES: tuple[tuple[str, str, str], ...] = (
    ("case1", "LateralTracking-v0", "Case 1: handling course, 0 -> 40 km/h"),
    ("case2", "DLC120-v0", "Case 2: double lane change, 120 km/h"),
)


@dataclass(frozen=True)
class PresetPair:
    """One SMC preset compared with one MPC preset."""

    key: str
    smc_preset: str
    mpc_preset: str

    @property
    def label(self) -> str:
        return f"SMC `{self.smc_preset}` vs MPC `{self.mpc_preset}`"


PAIRS: tuple[PresetPair, ...] = (PresetPair("paper", "paper", "paper"), PresetPair("tuned", "tuned", "tuned"),
                                  PresetPair("hand", "hand", "hand"))
"""The preset pairs compared in the claim table (``paper`` first)."""

EXTRA_RUNS: tuple[tuple[str, str], ...] = ()
"""Runs reported in the all-runs table only (not part of a pair)."""

FAILURES = ("off_road", "spin_out", "wheel_lift")

METRIC_KEYS = ("hand_wheel_deg", "e_y_m", "e_phi_deg", "a_y_mps2", "roll_deg")


@dataclass
class Run:
    """One episode: policy, preset, env, its trace and metrics."""

    policy: str
    preset: str
    env_id: str
    trace: Trace
    metrics: dict[str, Any]

    @property
    def name(self) -> str:
        return f"{self.policy}[{self.preset}]"

    @property
    def failed(self) -> bool:
        return self.trace.termination in FAILURES


def run_episode(policy: str, preset: str, env_id: str, max_steps: int | None) -> Run:
    """Roll out ``policy`` with ``preset`` on ``env_id`` (seed 0, nominal conditions) and score it."""
    from vtrack_gym.baselines.registry import make_policy
    from vtrack_gym.evaluation.benchmarking.benchmark import success_metrics

    env = gym.make(env_id)
    pol = make_policy(policy, env, preset=preset)
    trace = rollout(pol, env, seed=0, max_steps=max_steps)
    trace.policy_id = f"{policy}[{preset}]"
    metrics = evaluate_trace(trace)
    metrics.update(success_metrics(env))
    env.close()
    return Run(policy, preset, env_id, trace, metrics)


def run_all(quick: bool = False, progress: Callable[[str], None] | None = None) -> dict[tuple[str, str, str], Run]:
    """Every episode the report needs: ``{(policy, preset, env_id): Run}`` (cut short with ``quick``)."""
    wanted: list[tuple[str, str]] = []
    for pair in PAIRS:
        for item in (("smc", pair.smc_preset), ("mpc", pair.mpc_preset)):
            if item not in wanted:
                wanted.append(item)
    wanted += [e for e in EXTRA_RUNS if e not in wanted]
    runs: dict[tuple[str, str, str], Run] = {}
    for _, env_id, _ in CASES:
        for policy, preset in wanted:
            if progress is not None:
                progress(f"{env_id} {policy}[{preset}]")
            runs[(policy, preset, env_id)] = run_episode(policy, preset, env_id,
                                                         QUICK_MAX_STEPS[env_id] if quick else None)
    return runs


FIGURES = {
    "case1": ("fig08", "fig09-12", "fig13"),
    "case2": ("fig15", "fig16-18", "fig19"),
}


def write_figures(runs: dict[tuple[str, str, str], Run], out_dir: Path, dpi: int = 60) -> list[Path]:
    """Trajectories, signals and deviation-rate bars per case and preset pair (modest dpi)."""
    import matplotlib

    matplotlib.use("Agg")
    from vtrack_gym.evaluation.figures import plots

    files: list[Path] = []
    with matplotlib.rc_context({"savefig.dpi": dpi, "svg.hashsalt": "vtrack", "path.simplify": True}):
        for case, env_id, title in CASES:
            env = gym.make(env_id)
            env.reset(seed=0)
            path = env.unwrapped.current_path
            f_traj, f_sig, f_dev = FIGURES[case]
            prefix = "max_" if case == "case2" else "rms_"
            keys = [f"{prefix}{k}" for k in METRIC_KEYS]
            for pair in PAIRS:
                smc = runs[("smc", pair.smc_preset, env_id)]
                mpc = runs[("mpc", pair.mpc_preset, env_id)]
                stem = f"{case}_{pair.key}"
                files.append(plots.plot_trajectories([smc.trace, mpc.trace], path,
                                                     out_dir / f"{f_traj}_{stem}_trajectories.png",
                                                     title=f"{title}: {smc.name} vs {mpc.name}", preset=pair.key))
                files.append(plots.plot_signals([smc.trace, mpc.trace], out_dir / f"{f_sig}_{stem}_signals.png",
                                                title=f"{title}: {smc.name} vs {mpc.name}", preset=pair.key))
                files.append(plots.plot_deviation_rates(smc.name, smc.metrics, mpc.name, mpc.metrics, keys,
                                                        out_dir / f"{f_dev}_{stem}_deviation_rates.png",
                                                        env_id=env_id, seed=0, preset=pair.key))
            env.close()
    return files
