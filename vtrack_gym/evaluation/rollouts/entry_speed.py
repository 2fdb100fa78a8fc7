"""The highest entry speed a policy passes an ISO 3888 lane change at, against the car's physical bound.

``max_entry_speed_kmh(policy, env_id)`` drives the manoeuvre at a few entry speeds (``gym.make(env_id,
entry_speed_kmh=v)``) and judges each run exactly as the leaderboard does (``benchmark.score_episode``: the
scenario's success verdict, i.e. no cone gate left, the end reached, no spin-out). The search is bounded and
bisects on pass/fail:

1. probe ``lo_kmh`` (default half the bound). A fail there is looked into: ``SCAN_POINTS`` speeds evenly inside
   the range and ``hi_kmh`` are probed; none passing ends the search (no passing speed found), a pass among them
   makes the verdict non-monotone (``monotone`` False) and the search goes on from the highest one;
2. probe ``hi_kmh`` (default ``min(200, 1.15 x bound)``): a pass there ends it (``capped``: the policy passes
   the whole range, the true highest speed may be higher);
3. bisect between the highest pass and the lowest fail above it until they are at most ``tol_kmh`` apart;
4. ``checks`` extra probes evenly spaced between ``lo_kmh`` and the speed found: a fail among them means pass/fail
   is not monotone in the entry speed (``monotone`` False), reported, not smoothed over.

The bound is ``tracks.feasibility.entry_speed_bound_kmh``: the highest entry speed at which the car can follow the
planned line within its own steady-state grip. A policy passing at a speed above it is flagged
(``above_physical_bound``), never clipped: it has cut through the physics or the judge, not driven better.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

ENTRY_SPEED_MANEUVERS: dict[str, tuple[str, str]] = {"ISO3888-1": ("iso3888_1", "hold_throttle"),
                                                     "ISO3888-2": ("iso3888_2", "coast")}
"""Manoeuvres with an entry-speed protocol: env name (without namespace and version) -> (manoeuvre name, what the
car does from the entry gate on: ``feasibility.AFTER_ENTRY_PROTOCOLS``)."""
ENTRY_SPEED_ENV_IDS: tuple[str, ...] = ("vtrack/ISO3888-1-v1", "vtrack/ISO3888-2-v1", "vtrack/ISO3888-1-v2",
                                         "vtrack/ISO3888-2-v2")
"""The registered ids that take ``entry_speed_kmh=`` (the ids ``max_entry_speed_kmh`` searches on)."""
EXACT_LINE_ENV_IDS: frozenset[str] = frozenset({"vtrack/ISO3888-1-v2", "vtrack/ISO3888-2-v2"})
"""The ids whose line and bound come from ``tracks.exact_line`` (``planner_version`` 2: exact curvature)."""
MAX_SPEED_KMH = 200.0          # highest entry speed an ISO 3888 env accepts [km/h]
LO_FRACTION = 0.5              # default lowest probe: this fraction of the bound
HI_FRACTION = 1.15             # default highest probe: this fraction of the bound (at most MAX_SPEED_KMH)
DEFAULT_TOL_KMH = 0.5          # default bisection tolerance [km/h]
MIN_TOL_KMH = 0.01             # finest bisection tolerance [km/h]: a finer one would only probe float steps
DEFAULT_CHECKS = 2             # default monotonicity probes below the speed found
MAX_CHECKS = 10
SCAN_POINTS = 4                # probes evenly inside (lo, hi) after a fail at lo (then hi too)
_VERSION = re.compile(r"-v[0-9]+$")


@dataclass(frozen=True)
class EntryProbe:
    """One run at ``speed_kmh`` [km/h]: ``passed`` the success verdict, ``reason`` why it failed ("" if passed:
    ``board.failure_reason``, e.g. ``cones_hit``, ``spin_out``), ``stage`` the search step (lo, hi, bisect, check)."""

    speed_kmh: float
    passed: bool
    reason: str
    stage: str


@dataclass(frozen=True)
class SearchOutcome:
    """What the bisection found: the highest passing speed probed (None: ``lo`` failed), every probe in order,
    whether pass/fail looked monotone and whether ``hi`` passed (``capped``)."""

    max_pass_kmh: float | None
    probes: tuple[EntryProbe, ...]
    monotone: bool
    capped: bool


def check_search(lo_kmh: float, hi_kmh: float, tol_kmh: float, checks: int) -> None:
    """ValueError naming the field and its allowed range when the search bounds are unusable."""
    for name, value in (("lo_kmh", lo_kmh), ("hi_kmh", hi_kmh)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 < value <= MAX_SPEED_KMH:
            raise ValueError(f"{name} must be a number in (0, {MAX_SPEED_KMH:g}] km/h (got {value!r})")
    if not lo_kmh < hi_kmh:
        raise ValueError(f"lo_kmh must be below hi_kmh (got lo_kmh={lo_kmh:g}, hi_kmh={hi_kmh:g} km/h)")
    if isinstance(tol_kmh, bool) or not isinstance(tol_kmh, (int, float)) or \
            not MIN_TOL_KMH <= tol_kmh <= hi_kmh - lo_kmh:
        raise ValueError(f"tol_kmh must be in [{MIN_TOL_KMH:g}, hi_kmh - lo_kmh = {hi_kmh - lo_kmh:g}] km/h (got "
                         f"{tol_kmh!r})")
    if isinstance(checks, bool) or not isinstance(checks, int) or not 0 <= checks <= MAX_CHECKS:
        raise ValueError(f"checks must be an integer in [0, {MAX_CHECKS}] (got {checks!r})")


def planned_probes(lo_kmh: float, hi_kmh: float, tol_kmh: float, checks: int) -> int:
    """The probes a search makes when ``lo_kmh`` passes (lo, hi, the bisection steps, the checks); a fail at lo
    adds up to ``SCAN_POINTS``."""
    return 2 + max(0, math.ceil(math.log2((hi_kmh - lo_kmh) / tol_kmh))) + checks


def bisect_entry_speed(judge: Callable[[float], tuple[bool, str]], lo_kmh: float, hi_kmh: float,
                       tol_kmh: float = DEFAULT_TOL_KMH, checks: int = DEFAULT_CHECKS,
                       on_probe: Callable[[EntryProbe], None] | None = None) -> SearchOutcome:
    """The search of the module docstring with ``judge(speed_kmh) -> (passed, reason)``; ``on_probe`` is called
    after every probe (e.g. a progress bar)."""
    check_search(lo_kmh, hi_kmh, tol_kmh, checks)
    probes: list[EntryProbe] = []

    def probe(speed: float, stage: str) -> bool:
        passed, reason = judge(float(speed))
        found = EntryProbe(float(speed), bool(passed), "" if passed else str(reason), stage)
        probes.append(found)
        if on_probe is not None:
            on_probe(found)
        return found.passed

    monotone = True
    if probe(lo_kmh, "lo"):
        capped = probe(hi_kmh, "hi")
        good, bad = (hi_kmh, hi_kmh) if capped else (lo_kmh, hi_kmh)   # capped: nothing left to bisect
    else:   # a fail at lo: look further up before giving up (a pass up there is a non-monotone verdict)
        scan = [lo_kmh + (hi_kmh - lo_kmh) * j / (SCAN_POINTS + 1) for j in range(1, SCAN_POINTS + 1)] + [hi_kmh]
        passed = [v for v in scan if probe(v, "scan")]
        if not passed:
            return SearchOutcome(None, tuple(probes), True, False)
        monotone, good = False, max(passed)
        capped = good == hi_kmh
        bad = min((v for v in scan if v > good), default=hi_kmh)
    while bad - good > tol_kmh:
        mid = 0.5 * (good + bad)
        if not good < mid < bad:   # no float between them: the search cannot get finer
            break
        if probe(mid, "bisect"):
            good = mid
        else:
            bad = mid
    for j in range(1, checks + 1):
        monotone &= probe(lo_kmh + (good - lo_kmh) * j / (checks + 1), "check")
    return SearchOutcome(good, tuple(probes), monotone, capped)


@dataclass(frozen=True)
class EntrySpeedResult:
    """A policy's highest passing entry speed on an ISO 3888 env.

    ``max_entry_speed_kmh`` [km/h]: the highest speed probed that passed (None: no speed probed passed); the true
    threshold lies below the lowest failing speed above it, at most ``tol_kmh`` higher (unless ``capped``: every
    speed up to ``hi_kmh`` passed). ``entry_speed_bound_kmh`` [km/h]: the car's physical bound.
    ``above_physical_bound``: some probe passed above the bound. ``monotone``: no probe failed below a passing one
    (``lo_kmh`` and the check probes below the speed found all passed). ``probes``: every run in order."""

    env_id: str
    policy_id: str
    vehicle: str | None
    seed: int
    max_entry_speed_kmh: float | None
    entry_speed_bound_kmh: float
    above_physical_bound: bool
    monotone: bool
    capped: bool
    lo_kmh: float
    hi_kmh: float
    tol_kmh: float
    probes: tuple[EntryProbe, ...]

    @property
    def entry_speed_fraction(self) -> float | None:
        """``max_entry_speed_kmh / entry_speed_bound_kmh`` [-] (None when nothing passed)."""
        m = self.max_entry_speed_kmh
        return None if m is None else m / self.entry_speed_bound_kmh

    def to_dict(self) -> dict[str, Any]:
        """JSON data: every field, the fraction and the probes as dicts."""
        return {**asdict(self), "entry_speed_fraction": self.entry_speed_fraction,
                "probes": [asdict(p) for p in self.probes]}

    def metrics(self) -> dict[str, Any]:
        """The leaderboard metrics of a ``maneuvers`` row (``above_physical_bound``, ``entry_speed_monotone`` and
        ``entry_speed_capped`` as 0/1; ``entry_speed_probes`` the runs as ``speed:pass`` / ``speed:reason``)."""
        return {"max_entry_speed_kmh": self.max_entry_speed_kmh, "entry_speed_bound_kmh": self.entry_speed_bound_kmh,
                "entry_speed_fraction": self.entry_speed_fraction,
                "above_physical_bound": int(self.above_physical_bound), "entry_speed_monotone": int(self.monotone),
                "entry_speed_capped": int(self.capped),
                "entry_speed_probes": ",".join(f"{p.speed_kmh:.2f}:{'pass' if p.passed else p.reason}"
                                               for p in self.probes)}


def maneuver_of(env_id: str) -> tuple[str, str]:
    """(manoeuvre, protocol after the entry gate) of an entry-speed env id (``vtrack/`` may be left out), e.g.
    ``("iso3888_2", "coast")``; ValueError listing the valid ids."""
    full = env_id if "/" in str(env_id) else f"vtrack/{env_id}"
    if not isinstance(env_id, str) or full not in ENTRY_SPEED_ENV_IDS:
        raise ValueError(f"env_id must be an ISO 3888 env taking entry_speed_kmh: one of "
                         f"{', '.join(ENTRY_SPEED_ENV_IDS)} (got {env_id!r})")
    return ENTRY_SPEED_MANEUVERS[_VERSION.sub("", full.partition("/")[2])]


def entry_speed_bound(env_id: str, vehicle: Any = None) -> float:
    """The car's physical entry-speed bound [km/h] on ``env_id``'s manoeuvre (``feasibility.entry_speed_bound_kmh``;
    ``vehicle``: a name, a vehicle file, ``VehicleParams`` or None for the default car)."""
    from vtrack_gym.tracks.feasibility import entry_speed_bound_kmh
    from vtrack_gym.vehicle.catalog import resolve_vehicle

    maneuver, after_entry = maneuver_of(env_id)
    full = env_id if "/" in env_id else f"vtrack/{env_id}"
    version = 2 if full in EXACT_LINE_ENV_IDS else 1
    return float(entry_speed_bound_kmh(resolve_vehicle(vehicle), maneuver, after_entry, planner_version=version))


def _factory(policy: Any) -> tuple[Callable[[Any], Any], str | None]:
    """``make(env) -> policy`` and its id (None: taken from the policy) for a spec, a factory or a policy object."""
    if isinstance(policy, str):
        from vtrack_gym.evaluation.rollouts.episode_score import policy_factories

        (name, make), = policy_factories([policy]).items()
        return make, name
    if hasattr(policy, "predict") and not isinstance(policy, type):
        return (lambda env: policy), None
    if callable(policy):
        return policy, None
    raise ValueError(f"policy must be a policy name (e.g. 'mpc'), an object with predict or a callable "
                     f"make(env) -> policy (got {type(policy).__name__})")


def judge_entry_speed(make: Callable[[Any], Any], env_id: str, speed_kmh: float, vehicle: str | None = None,
                      seed: int = 0, policy_id: str = "policy") -> tuple[bool, str]:
    """(passed, failure reason) of one episode at ``speed_kmh`` [km/h]: the env made with ``entry_speed_kmh`` and
    ``vehicle``, a fresh policy from ``make``, scored by ``benchmark.score_episode`` (the leaderboard's verdict)."""
    import gymnasium as gym

    from vtrack_gym.evaluation.leaderboard.board import failure_reason
    from vtrack_gym.evaluation.rollouts.episode_score import score_episode
    from vtrack_gym.evaluation.rollouts.episodes import Episode

    episode = Episode(env_id, seed, vehicle=vehicle)
    env = gym.make(env_id, entry_speed_kmh=speed_kmh, **episode.make_kwargs)
    try:
        row, _ = score_episode(policy_id, make(env), env, episode, "custom")
    finally:
        env.close()
    passed = row.verdict()
    return passed, "" if passed else failure_reason(row.termination, row.metrics)


def search_range(bound_kmh: float, lo_kmh: float | None, hi_kmh: float | None) -> tuple[float, float]:
    """The search's (lo, hi) [km/h]: the given ones, else half the bound and ``min(200, 1.15 x bound)``."""
    lo = round(LO_FRACTION * bound_kmh, 1) if lo_kmh is None else lo_kmh
    hi = round(min(MAX_SPEED_KMH, HI_FRACTION * bound_kmh), 1) if hi_kmh is None else hi_kmh
    return lo, hi


def max_entry_speed_kmh(policy: Any, env_id: str = "vtrack/ISO3888-2-v1", *, vehicle: str | None = None,
                        lo_kmh: float | None = None, hi_kmh: float | None = None,
                        tol_kmh: float = DEFAULT_TOL_KMH, checks: int = DEFAULT_CHECKS, seed: int = 0,
                        policy_id: str | None = None,
                        on_probe: Callable[[EntryProbe], None] | None = None) -> EntrySpeedResult:
    """The highest entry speed [km/h] at which ``policy`` passes ``env_id`` (``ENTRY_SPEED_ENV_IDS``), with the
    car's physical bound (the search: module docstring).

    ``policy``: a policy name (``"mpc"``, ``"lqr:paper"``, ``"ppo"``), a callable ``make(env) -> policy`` (a fresh
    policy per run) or an object with ``predict`` (driven in every run). ``vehicle``: a name of
    ``vehicle.list_vehicles()`` or a vehicle file (default: the default car). ``lo_kmh``/``hi_kmh``: the range
    (default: half the bound and ``min(200, 1.15 x bound)``), in (0, 200] km/h; ``tol_kmh``: the bisection's
    resolution, at least ``MIN_TOL_KMH`` (0.01 km/h); ``checks``: monotonicity probes (0-10); ``seed``: every
    run's reset seed; ``on_probe``: called after each run. ValueError naming the field and its range for bad input."""
    maneuver_of(env_id)
    full_id = env_id if "/" in env_id else f"vtrack/{env_id}"
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0 (got {seed!r})")
    bound = entry_speed_bound(full_id, vehicle)
    lo, hi = search_range(bound, lo_kmh, hi_kmh)
    check_search(lo, hi, tol_kmh, checks)
    make, name = _factory(policy)
    name = policy_id or name or _policy_id(policy)

    def judge(speed: float) -> tuple[bool, str]:
        return judge_entry_speed(make, full_id, speed, vehicle, seed, name)

    found = bisect_entry_speed(judge, lo, hi, tol_kmh, checks, on_probe)
    from vtrack_gym.evaluation.rollouts.episode_score import vehicle_label

    above = any(p.passed and p.speed_kmh > bound for p in found.probes)
    return EntrySpeedResult(full_id, name, vehicle_label(vehicle), seed, found.max_pass_kmh, bound, above,
                            found.monotone, found.capped, float(lo), float(hi), float(tol_kmh), found.probes)


def _policy_id(policy: Any) -> str:
    from vtrack_gym.evaluation.rollouts.rollout import policy_id_of

    return policy_id_of(policy) if hasattr(policy, "predict") else getattr(policy, "__name__", "policy")


def is_entry_speed_env(env_id: str) -> bool:
    """True for the ids the entry-speed search runs on (``ENTRY_SPEED_ENV_IDS``, ``vtrack/`` may be left out)."""
    return (env_id if "/" in env_id else f"vtrack/{env_id}") in ENTRY_SPEED_ENV_IDS


@dataclass(frozen=True)
class EntrySpeedScore:
    """``benchmark.score_episode`` plus, on an ISO 3888 entry-speed env, the search's metrics in the row
    (``EntrySpeedResult.metrics``): how the ``maneuvers`` suite scores an episode. The row's ``success`` stays the
    verdict at the id's default entry speed; the search drives fresh policies from ``make`` on the episode's car
    and seed."""

    make: Callable[[Any], Any]
    tol_kmh: float = DEFAULT_TOL_KMH
    checks: int = DEFAULT_CHECKS

    def __call__(self, name: str, policy: Any, env: Any, ep: Any, suite: str,
                 digest: str | None = None) -> tuple[Any, Any]:
        import dataclasses

        from vtrack_gym.evaluation.rollouts.episode_score import score_episode

        row, trace = score_episode(name, policy, env, ep, suite, digest)
        if not is_entry_speed_env(ep.env_id):
            return row, trace
        found = max_entry_speed_kmh(self.make, ep.env_id, vehicle=ep.vehicle, tol_kmh=self.tol_kmh,
                                    checks=self.checks, seed=ep.seed, policy_id=name)
        return dataclasses.replace(row, metrics={**row.metrics, **found.metrics()}), trace
