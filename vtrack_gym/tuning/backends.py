"""Where a GA generation is evaluated: ``local`` (one batched rollout in this process) or ``ray``.

The ``ray`` backend splits the population row-wise into contiguous chunks (``np.array_split``), rolls each chunk
out on a Ray actor that holds its own ``PopulationEvaluator`` (built with the same arguments) and concatenates
the chunks' results in order (``merge_results``). Every car of a batched rollout is simulated independently
(same nominal scenario, same seed, its own accumulators), so the per-individual results, and therefore the GA
run, are bit-identical to the local backend's as long as ``PopulationEvaluator`` gives a row the same result
whatever the number of rows it is evaluated with, which holds for the SMC and the MPC spaces (the MPC's
``population_gain_tables`` contracts with ``einsum``, not BLAS matmul, whose round-off depends on the row count;
``tests/test_tuning_ray.py`` compares both controllers bit for bit).

Ray is an optional dependency (``pip install "vtrack_gym[ray]"``), imported only when the ``ray`` backend is
used.
"""

from __future__ import annotations

import dataclasses
import os
from types import ModuleType, TracebackType
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # imported at run time only where needed: importing this module stays cheap (the CLI does)
    from vtrack_gym.tuning.population import FitnessConfig, PopulationEvaluator, PopulationResult
    from vtrack_gym.tuning.spaces import SearchSpace

BACKENDS = ("local", "ray")
RAY_INSTALL_HINT = 'pip install "vtrack_gym[ray]"'
_SCALAR_MAX_FIELDS = ("steps", "wall_s")


class BackendError(RuntimeError):
    """The evaluation backend could not be set up (e.g. the Ray cluster is unreachable)."""


def merge_results(parts: list[PopulationResult]) -> PopulationResult:
    """One ``PopulationResult`` of the chunks ``parts`` (in population order).

    Per-individual arrays (and each ``also_completed`` entry) are concatenated in order. ``steps`` [control
    steps] is the longest chunk's, ``wall_s`` [s] the slowest chunk's: the chunks run in parallel, so this is
    the parallel wall time of the rollouts (not their sum; transfer and scheduling overhead not included).
    """
    from vtrack_gym.tuning.population import PopulationResult

    if not parts:
        raise ValueError("merge_results: parts must hold at least one PopulationResult")
    scenarios = list(parts[0].also_completed)
    for p in parts[1:]:
        if list(p.also_completed) != scenarios:
            raise ValueError(f"merge_results: also_completed scenarios differ between parts "
                             f"({scenarios} vs {list(p.also_completed)})")
    merged: dict[str, Any] = {}
    for f in dataclasses.fields(PopulationResult):
        values = [getattr(p, f.name) for p in parts]
        if f.name in _SCALAR_MAX_FIELDS:
            merged[f.name] = max(values)
        elif isinstance(values[0], dict):  # per constraint scenario (also_completed, also_max_abs_e_y_m)
            merged[f.name] = {s: np.concatenate([v[s] for v in values]) for s in scenarios}
        else:
            merged[f.name] = np.concatenate(values)
    return PopulationResult(**merged)


def _import_ray() -> ModuleType:
    try:
        import ray
    except ImportError as exc:
        raise ImportError(f"the ray backend needs Ray, which is not installed: {RAY_INSTALL_HINT}") from exc
    return ray


class _EvaluatorWorker:
    """Body of one Ray actor: a ``PopulationEvaluator`` of its own, numba on one thread (an actor has <= 1 CPU)."""

    def __init__(self, space: SearchSpace, evaluator_kwargs: dict[str, Any]) -> None:
        import numba

        from vtrack_gym.tuning.population import PopulationEvaluator

        numba.set_num_threads(1)
        self.evaluator = PopulationEvaluator(space, **evaluator_kwargs)

    def ready(self) -> int:
        """Number of numba threads of this actor (a start-up ping)."""
        import numba

        return int(numba.get_num_threads())

    def evaluate(self, X: np.ndarray) -> tuple[PopulationResult, int, int]:
        """(result of the rows ``X``, episodes so far, car steps so far) of this actor's evaluator."""
        res = self.evaluator(X)
        return res, self.evaluator.episodes, self.evaluator.car_steps


class RayPopulationEvaluator:
    """``PopulationEvaluator`` whose rollouts run on ``num_workers`` Ray actors (same call, same result).

    ``address``: the Ray cluster to connect to; ``None`` connects to ``$RAY_ADDRESS`` if it is set, else starts a
    local Ray instance (no dashboard) that ``close()`` shuts down again. If Ray is already initialised in this
    process, that connection is used (``address`` ignored) and left alone. ``num_workers`` (default: the
    cluster's CPU count, at most ``pop_size`` if given) actors are created, each asking for
    min(1, CPUs / num_workers) CPUs (so more workers than CPUs still start) and running numba on one thread.
    ``startup_timeout_s`` [s]: how long to wait for the actors to start.

    ``episodes`` and ``car_steps`` sum the actors' counters. ``env()`` and ``base_config`` come from a local
    ``PopulationEvaluator`` (used by ``ga.tune`` to build the result, not for rollouts). Use as a context
    manager or call ``close()``.
    """

    def __init__(self, space: SearchSpace, scenario: str = "LateralTracking-v0", fitness: FitnessConfig | None = None,
                 seed: int = 0, max_steps: int | None = None, compiled: bool = True,
                 also_complete: tuple[str, ...] = (), *, address: str | None = None, num_workers: int | None = None,
                 pop_size: int | None = None, startup_timeout_s: float = 300.0) -> None:
        if num_workers is not None and (isinstance(num_workers, bool) or not isinstance(num_workers, int)
                                        or num_workers < 1):
            raise ValueError(f"num_workers must be an integer >= 1 (got {num_workers!r})")
        if pop_size is not None and (isinstance(pop_size, bool) or not isinstance(pop_size, int) or pop_size < 1):
            raise ValueError(f"pop_size must be an integer >= 1 (got {pop_size!r})")
        from vtrack_gym.tuning.population import PopulationEvaluator

        ray = _import_ray()
        kwargs: dict[str, Any] = {"scenario": scenario, "fitness": fitness, "seed": seed, "max_steps": max_steps,
                                  "compiled": compiled, "also_complete": tuple(also_complete)}
        self._local = PopulationEvaluator(space, **kwargs)
        self.space = space
        self.scenario = self._local.scenario
        self.fitness = self._local.fitness
        self.seed = self._local.seed
        self.max_steps = self._local.max_steps
        self.compiled = self._local.compiled
        self.also_complete = self._local.also_complete
        self.base_config = self._local.base_config
        self._ray = ray
        self._actors: list[Any] = []
        self._counts: list[tuple[int, int]] = []
        self._initialised_ray = False
        if not ray.is_initialized():
            target = address or os.environ.get("RAY_ADDRESS") or None
            try:
                if target:
                    ray.init(address=target)
                else:
                    ray.init(include_dashboard=False)
            except (ConnectionError, RuntimeError, ValueError) as exc:
                where = f"the Ray cluster at {target}" if target else "a local Ray instance"
                raise BackendError(f"could not connect to {where}: {exc}") from exc
            self._initialised_ray = True
        try:
            self._start_actors(num_workers, pop_size, space, kwargs, startup_timeout_s)
        except BaseException:
            self.close()
            raise

    def _start_actors(self, num_workers: int | None, pop_size: int | None, space: SearchSpace,
                      kwargs: dict[str, Any], timeout_s: float) -> None:
        ray = self._ray
        cpus = float(ray.cluster_resources().get("CPU", 0.0))
        n = num_workers if num_workers is not None else max(1, int(cpus))
        if num_workers is None and pop_size is not None:
            n = min(n, pop_size)
        per_actor = min(1.0, cpus / n) if cpus > 0 else 1.0
        worker_cls = ray.remote(num_cpus=per_actor)(_EvaluatorWorker)
        self._actors = [worker_cls.remote(space, kwargs) for _ in range(n)]
        self._counts = [(0, 0)] * n
        try:
            ray.get([a.ready.remote() for a in self._actors], timeout=timeout_s)
        except ray.exceptions.GetTimeoutError as exc:
            raise BackendError(f"{n} Ray workers (each {per_actor:g} CPU) did not start within {timeout_s:g} s; "
                               f"the cluster has {cpus:g} CPUs") from exc

    @property
    def num_workers(self) -> int:
        """Number of Ray actors."""
        return len(self._actors)

    @property
    def episodes(self) -> int:
        """Episodes rolled out so far (all actors)."""
        return sum(e for e, _ in self._counts)

    @property
    def car_steps(self) -> int:
        """Control steps driven so far, summed over cars and actors [steps]."""
        return sum(s for _, s in self._counts)

    def env(self, n: int, scenario: str | None = None) -> Any:
        """A local ``TrackingVectorEnv`` of ``n`` cars (as ``PopulationEvaluator.env``; not used for rollouts)."""
        return self._local.env(n, scenario)

    def __call__(self, X: np.ndarray) -> PopulationResult:
        """Fitness of every row of ``X``: contiguous row chunks on the actors, merged in order."""
        if not self._actors:
            raise BackendError("RayPopulationEvaluator is closed")
        X = np.atleast_2d(np.asarray(X, dtype=np.float64))
        chunks = [c for c in np.array_split(X, len(self._actors)) if c.shape[0] > 0] or [X]
        refs = [actor.evaluate.remote(c) for actor, c in zip(self._actors, chunks, strict=False)]
        outs = self._ray.get(refs)
        for i, (_, episodes, car_steps) in enumerate(outs):
            self._counts[i] = (episodes, car_steps)
        return merge_results([res for res, _, _ in outs])

    def close(self) -> None:
        """Stop the actors; shut Ray down only if this object initialised it (a local instance it started, or
        the connection it opened to a running cluster, which keeps running)."""
        ray = self._ray
        for actor in self._actors:
            try:
                ray.kill(actor)
            except Exception:  # best effort: the actor or the cluster may already be gone
                pass
        self._actors = []
        if self._initialised_ray:
            self._initialised_ray = False
            ray.shutdown()

    def __enter__(self) -> RayPopulationEvaluator:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


def make_evaluator(backend: str, space: SearchSpace, *, ray_address: str | None = None,
                   num_workers: int | None = None, pop_size: int | None = None,
                   **evaluator_kwargs: Any) -> PopulationEvaluator | RayPopulationEvaluator:
    """The population evaluator of ``backend`` (``"local"`` or ``"ray"``); ``evaluator_kwargs`` go to
    ``PopulationEvaluator`` (scenario, fitness, seed, max_steps, compiled, also_complete). ``ray_address``,
    ``num_workers`` and ``pop_size`` (caps the default worker count) apply to the ``ray`` backend only."""
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {', '.join(repr(b) for b in BACKENDS)} (got {backend!r})")
    if backend == "local":
        if ray_address is not None or num_workers is not None:
            raise ValueError("ray_address and num_workers apply to backend 'ray' only (got backend 'local')")
        from vtrack_gym.tuning.population import PopulationEvaluator

        return PopulationEvaluator(space, **evaluator_kwargs)
    return RayPopulationEvaluator(space, **evaluator_kwargs, address=ray_address, num_workers=num_workers,
                                  pop_size=pop_size)
