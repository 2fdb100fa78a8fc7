"""Where benchmark episodes run: in this process, in N local processes, or on a Ray cluster.

Every episode is one ``EpisodeTask`` (a policy factory, an ``Episode`` and the suite label); ``run_tasks`` returns
the rows (and the traces asked for) in task order whatever the backend, and each task builds its own env and
policy exactly as the serial loop does, so the rows of ``workers=N`` equal those of ``workers=1`` (apart from the
metrics measured from the clock, ``metrics.CLOCK_MEASURED``, and the creation time).

``local`` with ``workers > 1`` forks worker processes (the tasks, factories included, are inherited, not pickled:
any callable works) after a warm-up here that loads what each worker would otherwise load again (the env's
compiled kernels, each policy and the scoring: ``_warm_up``); each worker runs its native libraries with one thread
(``worker_threads``), and a debug line reports the warm-up's and each worker's CPU time (``usage_line``).
Each result reaches the caller (``on_result``) as its episode ends, so finished work can be stored before anything
else can fail; a worker that dies costs only its own episode (a ``worker_pool.LostTask`` in its place).
``ray`` sends each task to a Ray worker with cloudpickle (factories must be picklable; a
track id registered in this process is registered again in the worker by the task's ``setup``); it connects to
``address`` or ``RAY_ADDRESS`` when given, else starts a local Ray instance. Ray is an optional dependency
(``pip install "vtrack_gym[ray]"``), imported only by the ``ray`` backend.
"""

from __future__ import annotations

import contextlib
import logging
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from vtrack_gym.evaluation.rollouts.episodes import Episode
from vtrack_gym.evaluation.rollouts.worker_pool import LostTask, run_pool

log = logging.getLogger(__name__)

BACKENDS = ("local", "ray")
"""Where ``run_tasks`` runs the episodes."""
RAY_INSTALL_HINT = 'pip install "vtrack_gym[ray]"'


@dataclass(frozen=True)
class EpisodeTask:
    """One episode to score: ``make(env) -> policy`` on ``episode``, stored under ``suite`` as ``policy_id``, by
    ``score(policy_id, policy, env, episode, suite) -> (row, trace)`` (``benchmark.score_episode``).

    ``keep_trace``: return the trace too (for figures). ``setup``: called with no argument in the worker before
    the env is made (e.g. registering a track id there); None for nothing.
    """

    policy_id: str
    make: Callable[[Any], Any]
    episode: Episode
    suite: str
    score: Callable[..., tuple[Any, Any]]
    keep_trace: bool = False
    setup: Callable[[], Any] | None = None

    def __post_init__(self) -> None:
        for name in ("make", "score"):
            if not callable(getattr(self, name)):
                raise ValueError(f"{name} must be callable (got {type(getattr(self, name)).__name__})")


def default_workers() -> int:
    """The cores this process may run on (at least 1)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def check_workers(workers: Any, backend: str) -> int | None:
    """``workers`` validated: an int >= 1, or None (local: the cores; ray: one task per cluster CPU)."""
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {', '.join(BACKENDS)} (got {backend!r})")
    if workers is None:
        return None
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1 (got {workers!r})")
    return workers


def run_task(task: EpisodeTask) -> tuple[Any, Any]:
    """Score one task in this process: (row, trace or None)."""
    import gymnasium as gym

    from vtrack_gym.evaluation.rollouts.episode_failure import in_episode

    ep = task.episode
    with in_episode(task.policy_id, ep.env_id, ep.seed):   # an error names its episode, also from a worker
        if task.setup is not None:
            task.setup()
        env = gym.make(ep.env_id, **ep.make_kwargs)
        try:
            row, trace = task.score(task.policy_id, task.make(env), env, ep, task.suite)
        finally:
            env.close()
    return row, (trace if task.keep_trace else None)


ResultSink = Callable[[int, tuple[Any, Any]], None]
"""Called in the calling process as each task ends: ``(task index, (row, trace or None))``."""


def run_tasks(tasks: Sequence[EpisodeTask], workers: int | None = 1, backend: str = "local",
              progress: Any = None, address: str | None = None,
              on_result: ResultSink | None = None) -> list[tuple[Any, Any] | LostTask]:
    """Every task's (row, trace or None), in task order; ``progress`` (a tqdm bar) advances once per episode and
    counts the lost and failed ones beside the bar (``_progress.EpisodeCounts``: ``12 done, 2 lost``).

    ``workers``: local processes (default: the cores; 1 runs in this process) or, with ``backend="ray"``, the most
    tasks in flight at once (default: one per cluster CPU). ``address``: the Ray cluster to join.
    ``on_result(i, result)`` is called here as each task ends, before the next result is waited for (store the
    row there: a later failure cannot lose it). A task whose worker died (``kill -9``, the OOM killer, a crashed
    Ray worker) is a ``worker_pool.LostTask`` in its place; every other task still runs. An exception raised by a
    task ends the run (after the results that arrived were delivered), marked with its episode
    (``episode_failure``).
    """
    from vtrack_gym._progress import EpisodeCounts

    workers = check_workers(workers, backend)
    tasks = list(tasks)
    results: list[Any] = [None] * len(tasks)
    counts = EpisodeCounts(progress)

    def deliver(index: int, result: tuple[Any, Any]) -> None:
        _log_result(tasks[index], result)
        counts.add("done")
        results[index] = result
        if on_result is not None:
            on_result(index, results[index])

    def lose(task: LostTask) -> None:   # the bar counts the episode, and shows it as lost
        counts.add("lost")

    n = min(workers or default_workers(), max(1, len(tasks)))   # never more processes than episodes
    try:
        if backend == "ray":
            lost = _run_ray(tasks, workers, deliver, address, lose)
        elif n > 1:
            lost = _run_forked(tasks, n, deliver, lose)
        else:   # in this process
            lost = []
            for index, task in enumerate(tasks):
                deliver(index, run_task(task))
    except Exception:
        counts.add("failed")
        raise
    for task in lost:
        log.warning("episode lost: %s", lost_line(tasks[task.index], task))
        results[task.index] = task
    return results


def lost_line(task: EpisodeTask, lost: LostTask) -> str:
    """``lqr on DLC120-v0 seed 0: worker killed by SIGKILL`` (what a lost episode's report says)."""
    ep = task.episode
    return f"{task.policy_id} on {ep.env_id} seed {ep.seed}: worker {lost.reason}"


def _log_result(task: EpisodeTask, result: tuple[Any, Any]) -> None:
    """``task``'s debug line, logged here in the process that draws the bar (a worker's own line would print
    through it)."""
    ep = task.episode
    log.debug("%s on %s seed %s: %s", task.policy_id, ep.env_id, ep.seed, result[0].termination)


class _Inherited:
    """The task list of a forked worker, handed over by the fork itself (never pickled)."""

    tasks: Sequence[EpisodeTask] = ()


def _start_worker(tasks: Sequence[EpisodeTask]) -> None:
    """A forked worker's start: keep the inherited tasks, run the native libraries single-threaded."""
    from vtrack_gym.evaluation.rollouts.worker_threads import limit_native_threads

    _Inherited.tasks = tasks
    limit_native_threads(1)


def _run_index(i: int) -> tuple[tuple[Any, Any], int, float]:
    """Task ``i`` in a worker: its result, the worker's pid and the task's CPU time [s]."""
    start = time.process_time()
    result = run_task(_Inherited.tasks[i])
    return result, os.getpid(), time.process_time() - start


WARM_UP_STEPS = 300
"""Steps of the short episodes ``_warm_up`` scores (results discarded): 3 s at the envs' 100 Hz, past the one second
the comfort metrics need before they filter (and import their filters)."""


def _warm_up(tasks: Sequence[EpisodeTask], steps: int = WARM_UP_STEPS) -> float:
    """Load here, once, before the fork, what each worker would otherwise load again: the env's compiled kernels,
    and every distinct factory's policy (its caches, lazy imports and kernels) with the scoring's, on a
    ``steps``-step episode of the first task's env (a fresh env: no task's episode is touched; results discarded).
    Best effort: a policy that fails here is left to its own tasks to report. Returns the CPU time spent [s]."""
    import gymnasium as gym

    start = time.process_time()
    first = tasks[0]
    if first.setup is not None:
        first.setup()
    env = gym.make(first.episode.env_id, **{**first.episode.make_kwargs, "max_episode_steps": steps})
    try:
        env.reset(seed=0)
        env.step(env.action_space.sample())  # the env's kernels, even when no policy can be built here
        seen: set[int] = set()
        for task in tasks:
            if id(task.make) not in seen:
                seen.add(id(task.make))
                _warm_policy(task, env, first.episode)
    finally:
        env.close()
    return time.process_time() - start


def _warm_policy(task: EpisodeTask, env: Any, episode: Episode) -> None:
    """Score ``task``'s policy on ``env`` (a short episode). A factory that returns the same object on every call
    is built but not driven: the tasks will drive that very object, which must start as it would without a
    warm-up."""
    import warnings

    try:
        built = task.make(env)
        fresh = task.make(env)
        if fresh is built:
            return
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # metrics of a short episode: not the user's concern
            task.score(task.policy_id, fresh, env, episode, task.suite)
    except Exception as exc:  # the task itself raises it where it belongs
        log.debug("warm-up of %s skipped: %s", task.policy_id, exc)


def _run_forked(tasks: list[EpisodeTask], n: int, deliver: ResultSink,
                lose: Callable[[LostTask], None]) -> list[LostTask]:
    """``tasks`` on at most ``n`` forked processes (after ``_warm_up`` here), each result delivered as it
    arrives (``worker_pool.run_pool``); returns the tasks whose worker died."""
    warm_cpu_s = _warm_up(tasks)
    cpu_by_worker: dict[int, float] = {}
    start = time.perf_counter()

    def done(index: int, payload: tuple[tuple[Any, Any], int, float]) -> None:
        result, pid, cpu_s = payload
        cpu_by_worker[pid] = cpu_by_worker.get(pid, 0.0) + cpu_s
        deliver(index, result)

    lost = run_pool(len(tasks), n, _run_index, done, init=lambda: _start_worker(tasks), on_lost=lose)
    log.debug(usage_line(len(tasks), warm_cpu_s, list(cpu_by_worker.values()), time.perf_counter() - start))
    return lost


USAGE_PREFIX = "episodes in worker processes:"
"""How the ``usage_line`` debug line starts (``vtrack -v benchmark``; ``benchmarks/bench_workers.py`` reads it)."""


def usage_line(n_tasks: int, warm_cpu_s: float, cpu_s: Sequence[float], wall_s: float) -> str:
    """One line on where a forked run's CPU time went: the parent's warm-up, each worker's episodes [s]."""
    per_worker = ", ".join(f"{c:.2f}" for c in sorted(cpu_s, reverse=True))
    return (f"{USAGE_PREFIX} {n_tasks} on {len(cpu_s)}; warm-up CPU {warm_cpu_s:.2f} s; episode CPU per worker "
            f"[{per_worker}] s (sum {sum(cpu_s):.2f} s); pool wall {wall_s:.2f} s")


def _import_ray() -> Any:
    try:
        import ray
    except ImportError as exc:
        raise ImportError(f"the ray backend needs Ray, which is not installed: {RAY_INSTALL_HINT}") from exc
    return ray


RAY_CRASHES = ("WorkerCrashedError", "NodeDiedError", "ObjectLostError", "OutOfMemoryError",
               "ActorDiedError", "LocalRayletDiedError")
"""Ray exceptions that mean the process running a task died (the task is lost, the others go on)."""


def _run_ray(tasks: list[EpisodeTask], workers: int | None, deliver: ResultSink, address: str | None,
             lose: Callable[[LostTask], None]) -> list[LostTask]:
    """``tasks`` as Ray tasks (at most ``workers`` in flight), each delivered as it ends; the lost ones."""
    ray = _import_ray()
    if not ray.is_initialized():
        target = address or os.environ.get("RAY_ADDRESS") or None
        ray.init(address=target) if target else ray.init(include_dashboard=False)
    crashes = tuple(getattr(ray.exceptions, name) for name in RAY_CRASHES if hasattr(ray.exceptions, name))
    remote = ray.remote(num_cpus=1, max_retries=0)(run_task)
    limit = workers or max(1, int(ray.cluster_resources().get("CPU", 1)))
    pending: dict[Any, int] = {}
    lost: list[LostTask] = []
    next_task = 0
    try:
        while next_task < len(tasks) or pending:
            while next_task < len(tasks) and len(pending) < limit:
                pending[remote.remote(tasks[next_task])] = next_task
                next_task += 1
            done, _ = ray.wait(list(pending), num_returns=1)
            for ref in done:
                index = pending.pop(ref)
                try:
                    result = ray.get(ref)
                except crashes as exc:
                    lost.append(LostTask(index, f"died ({type(exc).__name__})"))
                    lose(lost[-1])
                    continue
                deliver(index, result)
    finally:
        for ref in pending:  # Ctrl-C or a failed task: stop what still runs
            with contextlib.suppress(Exception):
                ray.cancel(ref, force=True)
    return lost
