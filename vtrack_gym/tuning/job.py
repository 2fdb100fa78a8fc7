"""One ``vtrack tune`` job end to end: run the GA, write the tuned preset with its provenance, optionally record the
result in a leaderboard store. The CLI only parses its arguments into a call of :func:`tune_to_preset`."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from vtrack_gym.tuning.ga import TuneResult

SCENARIO = "LateralTracking-v0"
"""The GA's fitness scenario (Case 1); ``also_complete`` adds scenarios every individual must complete."""


@dataclass(frozen=True)
class TuneOutcome:
    """What a tuning job produced: the GA result, the preset file written and the provenance recorded in it."""

    result: TuneResult
    preset_file: Path
    provenance: dict[str, Any]

    @property
    def episodes_per_s(self) -> float:
        """Episodes evaluated per wall-clock second [1/s]."""
        return self.result.episodes / max(self.result.wall_s, 1e-9)


def tune_to_preset(controller: str, space: str | None = None, budget: str | None = None, *, seed: int = 0,
                   generations: int | None = None, pop_size: int | None = None, comfort_weight: float = 0.0,
                   max_steps: int | None = None, also_complete: tuple[str, ...] = (), backend: str = "local",
                   ray_address: str | None = None, num_workers: int | None = None, out: Path | None = None,
                   store: Path | None = None, command: str = "", progress: bool = True) -> TuneOutcome:
    """GA-tune ``controller`` (a GA-tunable registered policy, ``registry.tunable_policies()``) in its search space
    ``space`` with its named ``budget`` (default: the first ones it declares; ``paper`` for smc and mpc).

    ``generations`` / ``pop_size`` override the budget (then named ``custom``); ``out`` defaults to
    ``vtrack_results/<controller>_tuned.json``; ``command`` is recorded as the preset's provenance; ``store``: also
    add a row to that result store (suite ``tuning``). The other arguments are :func:`vtrack_gym.tuning.ga.tune`'s.
    """
    from vtrack_gym._io import check_output_file
    from vtrack_gym.baselines.preset_files import preset_config_type, save_preset
    from vtrack_gym.tuning.ga import check_tune_args, tune
    from vtrack_gym.tuning.population import FitnessConfig
    from vtrack_gym.tuning.spaces import budget as named_budget
    from vtrack_gym.tuning.spaces import search_space, tuning_of

    preset_config_type(controller)  # a controller whose preset cannot be saved is refused before the GA
    declared = tuning_of(controller)
    search = search_space(controller, space if space is not None else next(iter(declared.spaces)))
    b = named_budget(controller, budget if budget is not None else next(iter(declared.budgets)))
    if generations is not None or pop_size is not None:  # 0 is an error (check_tune_args), not the default
        b = dataclasses.replace(b, name="custom", generations=b.generations if generations is None else generations,
                                pop_size=b.pop_size if pop_size is None else pop_size)
    check_tune_args(b, seed, max_steps)
    preset_file = Path(out) if out is not None else Path("vtrack_results") / f"{controller}_tuned.json"
    check_output_file(preset_file, "--out")  # both outputs checked before the GA runs
    if store is not None:
        check_output_file(store, "--store", store=True)
    result = tune(search, b, seed=seed, fitness=FitnessConfig(comfort_weight=comfort_weight), progress=progress,
                  max_steps=max_steps, also_complete=also_complete, backend=backend, ray_address=ray_address,
                  num_workers=num_workers)
    budget_info = {"name": b.name, "generations": b.generations, "pop_size": b.pop_size}
    provenance: dict[str, Any] = {
        "command": command, "seed": seed, "budget": budget_info, "space": search.as_dict(),
        "best_fitness": result.best_fitness, "metrics": result.best_metrics,
        "scenario": ",".join([SCENARIO, *also_complete]), "wall_time_s": round(result.wall_s, 3),
        "episodes": result.episodes, "backend": result.backend}
    if max_steps is not None:
        provenance["note"] = f"episodes cut after {max_steps} steps (smoke test, not a tuning result)"
    save_preset(preset_file, controller, result.best_config, result.best_speed_config, provenance)
    if store is not None:
        _store_result(store, controller, search.name, seed, result, budget_info, preset_file)
    return TuneOutcome(result, preset_file, provenance)


def _store_result(store: Path, controller: str, space: str, seed: int, result: TuneResult,
                  budget_info: dict[str, Any], preset_file: Path) -> None:
    """Add the best individual's metrics to ``store`` as one ``tuning`` row."""
    from vtrack_gym.evaluation.identity.fingerprint import policy_hash
    from vtrack_gym.evaluation.scoring.rows import ResultRow
    from vtrack_gym.evaluation.storage.store import ResultStore

    class _Cfg:  # policy_hash reads .config
        config = result.best_config

    row = ResultRow(suite="tuning", env_id=SCENARIO, policy_id=f"{controller}_tuned",
                    policy_hash=policy_hash(_Cfg()), seed=seed,
                    metrics={**result.best_metrics, "wall_time_s": result.wall_s, "episodes": float(result.episodes)},
                    termination="completed" if result.best_metrics.get("completed") else "not_completed",
                    wall_time_per_step_s=result.wall_s / max(result.car_steps, 1),
                    options={"space": f"{controller}/{space}", "budget": budget_info, "preset_file": str(preset_file)})
    ResultStore(store).add([row])
