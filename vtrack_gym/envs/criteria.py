"""Success criteria: one class per criterion, judging every car live during its episode.

A criterion is a frozen scenario part (its parameters). ``start`` makes its per-batch state (a NamedTuple of named
arrays, one row per car), ``reset_car`` clears one car's row, ``observe_step`` runs after every control step (only
when ``per_step`` is True), ``verdict`` gives each car's verdict if its episode ended now (``info["success"]``) and
``metrics`` the leaderboard figures of one car's episode (e.g. ``cones_hit``).

- ``Lap``: one lap of a closed course within the road (the episode terminated ``completed``).
- ``EndReached``: the end of an open track reached within the road.
- ``ConeGates``: the course completed and every cone gate passed with the body inside it (ISO 3888).
- ``TrackLimits``: the lap or the end reached with a declared track-limit rule held (``wheels``, ``body``,
  ``centre``), judged by ``tracks.judge``.
- ``CircleAtLimit``: ISO 4138 steady-state circle held until the car's own grip limit.
- ``Auto``: ``ConeGates`` if a path has gates, else ``Lap`` (closed paths) / ``EndReached`` (open ones).

A new criterion is one more class with these methods (see ``tests/test_scenario_parts.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar, NamedTuple

import numpy as np

from vtrack_gym._ranges import documented, ranged, validate
from vtrack_gym.vehicle.params import GRAVITY_MPS2


class CarsView(NamedTuple):
    """What a criterion may read of the batch after a step: (n,) column views, updated in place every step."""

    track: np.ndarray              # int64 track index of each car
    steps: np.ndarray              # int64 control steps since reset
    termination: np.ndarray        # int64 termination code of each car (0: running)
    station_m: np.ndarray          # station of the CG's projection [m]
    lateral_error_m: np.ndarray    # e_y [m], left positive
    speed_mps: np.ndarray          # v_x [m/s]
    target_speed_mps: np.ndarray   # the PD-FLC's reference speed [m/s]
    lateral_acc_mps2: np.ndarray   # a_y at the CG [m/s^2]
    x_m: np.ndarray                # CG position [m]
    y_m: np.ndarray
    psi_rad: np.ndarray            # heading [rad]
    completed_code: int            # the termination code of a completed course
    off_road_code: int             # the termination code of a car off the road

    @property
    def completed(self) -> np.ndarray:
        """Bool (n,): the episode terminated ``completed`` (a fresh array)."""
        return self.termination == self.completed_code


class SuccessCriterion:
    """Base of every criterion (frozen dataclass subclasses); the defaults judge by completion alone."""

    name: ClassVar[str] = "completed"
    per_step: ClassVar[bool] = False
    """True when ``observe_step`` must run after every step (False: the verdict needs only the termination)."""

    def resolve(self, paths: tuple) -> SuccessCriterion:
        """The concrete criterion on these paths (``Auto`` chooses; every other criterion is itself)."""
        return self

    @classmethod
    def from_maneuver(cls, spec: Any) -> SuccessCriterion:
        """This criterion as a manoeuvre's ``ManeuverSpec`` names it (``spec.success_criterion == cls.name``; the
        spec's own parameters where the criterion has some)."""
        return cls()

    def start(self, paths: tuple, vehicle: Any, n: int) -> Any:
        """The per-batch state of ``n`` cars on ``paths`` driving ``vehicle`` (``VehicleParams``)."""
        return None

    def reset_car(self, state: Any, i: int, vehicle: Any) -> None:
        """Clear car ``i``'s row for a new episode with its (randomised) ``vehicle``."""

    def observe_step(self, state: Any, cars: CarsView) -> None:
        """Update the state after a control step of every car."""

    def verdict(self, state: Any, cars: CarsView) -> np.ndarray:
        """Each car's verdict if its episode ended now (bool (n,))."""
        return cars.completed

    def metrics(self, state: Any, i: int, track: int) -> dict[str, float]:
        """The leaderboard figures of car ``i``'s episode on path ``track`` (none by default)."""
        return {}

    def off_road_margin_m(self, vehicle: Any) -> float:
        """How far [m] the CG may pass a road edge before the env ends the episode ``off_road`` (0: at the edge)."""
        return 0.0

    def safety(self, state: Any, cars: CarsView) -> tuple[np.ndarray, np.ndarray]:
        """Each car's ``info["cost"]`` (1.0 on a step that broke the scenario's rule, else 0.0) and
        ``info["edge_margin_m"]`` (the body's least clearance to a road edge over the step [m]; +inf where the
        criterion does not measure it). By default the rule is the road at the CG: cost 1.0 on the step that ends
        the episode ``off_road``."""
        return (cars.termination == cars.off_road_code).astype(np.float64), np.full(cars.steps.shape, np.inf)

    def safety_of(self, state: Any, cars: CarsView, i: int) -> tuple[float, float]:
        """``safety`` of car ``i`` alone, as floats (the single env's per-step path): the default rule without
        building the batch's arrays; a criterion with its own ``safety`` is read through it."""
        if type(self).safety is SuccessCriterion.safety:
            return (1.0 if cars.termination[i] == cars.off_road_code else 0.0), math.inf
        cost, margin = self.safety(state, cars)
        return float(cost[i]), float(margin[i])


@dataclass(frozen=True)
class Lap(SuccessCriterion):
    """One lap of a closed course within the road (the env terminates ``completed``)."""

    name: ClassVar[str] = "lap"


@dataclass(frozen=True)
class EndReached(SuccessCriterion):
    """The end of an open track reached within the road (``completed``: ``end_margin_m`` before its end)."""

    name: ClassVar[str] = "end"


@dataclass(frozen=True)
class Completed(SuccessCriterion):
    """A bank mixing closed and open paths: the lap of a closed one or the end of an open one."""

    name: ClassVar[str] = "completed"


class GateState(NamedTuple):
    """``ConeGates`` state: per gated track its gate rows and station window; per car the gates its body left (and,
    judged exactly, its last pose and least clearance to a cone line)."""

    gated: dict[int, tuple[Any, np.ndarray, float, float]]   # track -> (path, gate rows, s_lo, s_hi)
    hit: np.ndarray            # (n, max gates) bool: gate g left by car i's body
    outline_lon: np.ndarray    # body-outline points in the body frame [m]
    outline_lat: np.ndarray
    reach_m: float             # a Frenet gate is checked while the car's station is this close to it [m]
    row: np.ndarray            # scratch track row
    fresh: np.ndarray          # (n,) bool: the last step left a gate not left before
    exact: dict[int, np.ndarray] | None = None   # exact judge: track -> gate_judge.gate_table of its gates
    body: np.ndarray | None = None               # exact judge: the body row (front, rear, half width [m])
    prev: np.ndarray | None = None               # exact judge: (n, 3) x, y [m], psi [rad] after the last step
    started: np.ndarray | None = None            # exact judge: (n,) bool, ``prev`` holds a pose of this episode
    least: np.ndarray | None = None              # exact judge: (n,) least clearance to a cone line so far [m]


@dataclass(frozen=True)
class ConeGates(SuccessCriterion):
    """The course completed and every cone gate passed with the body inside it; metric ``cones_hit`` (gates left).

    ``exact=False`` (the ids registered before the exact judge): every body-outline point (corners and sides,
    sampled every 0.25 m) is projected on the path after each control step while the car is within a body length
    of the gated stretch, like ``tracks.gate_violations`` on a whole trajectory (compiled). ``exact=True``: the
    body rectangle against every anchored gate's cone lines, swept between control steps, exact to 1 mm
    (``tracks.gate_judge``); metric ``min_gate_clearance_m`` too (the body's least clearance to a cone line near
    it, exact below 5 cm, negative when it crossed one; absent when no gate came within the body's reach)."""

    name: ClassVar[str] = "gates"
    per_step: ClassVar[bool] = True
    exact: bool = False

    def start(self, paths: tuple, vehicle: Any, n: int) -> GateState:
        from vtrack_gym.tracks.dlc import car_outline
        from vtrack_gym.tracks.kernels import gate_rows
        from vtrack_gym.tracks.table import N_COLS

        c = vehicle.chassis
        lon, lat = car_outline(0.0, 0.0, 0.0, c.body_length_m, c.body_width_m, c.cg_to_front_end_m)
        gated = {t: (p, gate_rows(p.gates), min(g.s_start_m for g in p.gates) - c.body_length_m,
                     max(g.s_end_m for g in p.gates) + c.body_length_m) for t, p in enumerate(paths) if p.gates}
        most = max((len(p.gates) for p in paths), default=0)
        state = GateState(gated, np.zeros((n, max(most, 1)), dtype=bool), lon.ravel(), lat.ravel(), c.body_length_m,
                          np.zeros(N_COLS), np.zeros(n, dtype=bool))
        if not self.exact:
            return state
        from vtrack_gym.tracks.gate_judge import gate_table

        body = np.array([c.cg_to_front_end_m, c.cg_to_front_end_m - c.body_length_m, 0.5 * c.body_width_m])
        return state._replace(exact={t: gate_table(p.gates) for t, p in enumerate(paths) if p.gates}, body=body,
                              prev=np.zeros((n, 3)), started=np.zeros(n, dtype=bool), least=np.full(n, np.inf))

    def reset_car(self, state: GateState, i: int, vehicle: Any) -> None:
        state.hit[i] = False
        state.fresh[i] = False
        if state.started is not None and state.least is not None:
            state.started[i] = False
            state.least[i] = np.inf

    def _observe_exact(self, state: GateState, cars: CarsView) -> None:
        """The exact judge: each car's body swept from its last pose to this one against its track's gates."""
        from vtrack_gym.tracks.gate_judge import judge_gates
        from vtrack_gym.tracks.judge import SWEEP_TOL_M

        assert state.exact is not None and state.prev is not None and state.started is not None
        on = cars.steps > 0
        pose = np.column_stack((cars.x_m, cars.y_m, cars.psi_rad))
        first = on & ~state.started      # no pose before this step: judged at its end
        state.prev[first] = pose[first]
        before = np.count_nonzero(state.hit, axis=1)
        for track, gates in state.exact.items():
            idx = np.flatnonzero(on & (cars.track == track))
            if idx.size:
                hit = np.ascontiguousarray(state.hit[:, :gates.shape[0]])
                judge_gates(gates, state.body, idx, state.prev, cars.x_m, cars.y_m, cars.psi_rad, SWEEP_TOL_M, hit,
                            state.least)
                state.hit[:, :gates.shape[0]] = hit
        state.fresh[:] = np.count_nonzero(state.hit, axis=1) > before
        state.prev[on] = pose[on]
        state.started[on] = True

    def observe_step(self, state: GateState, cars: CarsView) -> None:
        from vtrack_gym.tracks.kernels import body_outside_gates

        if self.exact:
            self._observe_exact(state, cars)
            return
        s = cars.station_m
        before = np.count_nonzero(state.hit, axis=1)
        for track, (path, gates, lo, hi) in state.gated.items():
            sel = np.flatnonzero((cars.track == track) & (s >= lo) & (s <= hi))
            if sel.size == 0:
                continue
            hit = state.hit[sel, :gates.shape[0]]
            body_outside_gates(path.table, path.ds_m, path.length_m, path.closed, gates, cars.x_m[sel],
                               cars.y_m[sel], cars.psi_rad[sel], s[sel], state.outline_lon, state.outline_lat,
                               state.reach_m, hit, state.row)
            state.hit[sel, :gates.shape[0]] = hit
        state.fresh[:] = np.count_nonzero(state.hit, axis=1) > before

    def safety(self, state: GateState, cars: CarsView) -> tuple[np.ndarray, np.ndarray]:
        """Cost 1.0 on a step whose body left a gate it had not left before (or ended the episode off the road)."""
        cost, margin = super().safety(state, cars)
        return np.maximum(cost, state.fresh.astype(np.float64)), margin

    def verdict(self, state: GateState, cars: CarsView) -> np.ndarray:
        return cars.completed & ~state.hit.any(axis=1)

    def metrics(self, state: GateState, i: int, track: int) -> dict[str, float]:
        if track not in state.gated:
            return {}
        out = {"cones_hit": float(np.count_nonzero(state.hit[i]))}
        if state.least is not None and np.isfinite(state.least[i]):   # a gate came within the body's reach
            out["min_gate_clearance_m"] = float(state.least[i])
        return out


TRACK_LIMIT_RULES: tuple[str, ...] = ("wheels", "body", "centre")
"""The track-limit rules (``TrackLimits.rule``): motorsport's (a car is off the track when all four wheel contact
points are beyond an edge line), the strict tracking rule (no part of the body beyond an edge) and the car's centre
(the CG beyond an edge: the rule the ids registered before track limits keep)."""
_RULE_MEASURES: dict[str, int] = {"centre": 0, "wheels": 1, "body": 2}   # tracks.judge.MEASURE_*


class EdgeState(NamedTuple):
    """``TrackLimits`` state: per track its edge polylines; per car its last pose and its record so far."""

    edges: dict[int, tuple[np.ndarray, float, bool]]   # track -> (tracks.judge.edge_polylines, ds [m], closed)
    body: np.ndarray           # tracks.judge.body_row of the car
    prev: np.ndarray           # (n, 4) x, y [m], psi [rad], station [m] after the last step
    fresh: np.ndarray          # (n,) bool: no step since the reset (``prev`` not yet set)
    outside: np.ndarray        # (n,) bool: the rule was broken at the end of the last step
    violations: np.ndarray     # (n,) int64 excursions so far (a step breaking the rule after one keeping it)
    min_margin: np.ndarray     # (n,) the body's least clearance to an edge so far [m]
    cost: np.ndarray           # (n,) float 1.0 where the last step broke the rule
    margin: np.ndarray         # (n,) the body's least clearance to an edge over the last step [m]
    rule_min: np.ndarray       # (n,) scratch: the rule's least measure over the step [m]
    rule_end: np.ndarray       # (n,) the rule's measure at the end of the last step [m]
    body_end: np.ndarray       # (n,) the body's edge clearance at the end of the last step [m]
    cones: dict[int, np.ndarray]   # track -> its cones (K, 3): x, y, radius [m] (cone-lined tracks only)
    cone_hit: np.ndarray       # (n, max K) bool: cone k touched by car i's body


FS_CONE_PENALTY_S = 2.0
"""Formula Student: a cone down or out costs 2 s."""
FS_OFF_COURSE_PENALTY_S = 10.0
"""Formula Student: off course (all four wheels beyond the track's edge) costs 10 s."""


@documented
@dataclass(frozen=True, kw_only=True)
class TrackLimits(SuccessCriterion):
    """Track limits as a declared rule: the lap (closed track) or the end (open one) reached, and ``rule`` held.

    ``rule`` (``TRACK_LIMIT_RULES``): ``"wheels"``, off the track when all four wheel contact points are beyond an
    edge; ``"body"``, any part of the body rectangle beyond an edge; ``"centre"``, the CG beyond an edge. Each
    excursion (a step that breaks the rule after one that kept it) is counted; success means none. Judged by the
    exact geometry judge (``tracks.judge``: edges as polylines, the car's own body and wheel points, exact to 1 mm
    between control steps). With ``"wheels"`` and ``"body"`` an excursion does not end the episode: the env ends it
    ``off_road`` only once the CG is a body reach (the farthest corner from the CG) beyond an edge, the whole car
    off. Metrics: ``track_limit_violations`` and ``min_edge_margin_m`` (the body's least clearance to an edge,
    negative when the body crossed one). On a cone-lined track (``Path.cones_m``) the body is also judged against
    every cone as a disc: ``cones_hit`` (cones touched) and ``fs_penalty_s`` (Formula Student's 2 s a cone, plus
    10 s an excursion under the wheels rule, FS's off course); a touched cone is a penalty, not a failed lap. Not
    for courses with cone gates (their rule is the gates)."""

    name: ClassVar[str] = "track_limits"
    per_step: ClassVar[bool] = True
    rule: str = "wheels"   # CHOICE: motorsport's rule when a TrackLimits part is composed without one

    def __post_init__(self) -> None:
        if self.rule not in TRACK_LIMIT_RULES:
            raise ValueError(f"track_limits must be one of {', '.join(TRACK_LIMIT_RULES)} (got {self.rule!r})")

    def resolve(self, paths: tuple) -> SuccessCriterion:
        if any(p.gates for p in paths):
            raise ValueError("track_limits applies to tracks without cone gates; this course is judged by its "
                             "gates (ConeGates)")
        return self

    def off_road_margin_m(self, vehicle: Any) -> float:
        if self.rule == "centre":
            return 0.0
        from vtrack_gym.tracks.judge import body_row, reach_m

        return float(reach_m(body_row(vehicle.chassis)))

    def start(self, paths: tuple, vehicle: Any, n: int) -> EdgeState:
        from vtrack_gym.tracks.judge import body_row, edge_polylines

        edges = {t: (edge_polylines(p), p.ds_m, p.closed) for t, p in enumerate(paths)}
        cones = {t: p.cones_m for t, p in enumerate(paths) if p.cones_m is not None}
        most = max((c.shape[0] for c in cones.values()), default=1)
        z = np.zeros(n)
        return EdgeState(edges, body_row(vehicle.chassis), np.zeros((n, 4)), np.ones(n, dtype=bool),
                         np.zeros(n, dtype=bool), np.zeros(n, dtype=np.int64), np.full(n, np.inf), z.copy(),
                         np.full(n, np.inf), z.copy(), z.copy(), z.copy(), cones, np.zeros((n, most), dtype=bool))

    def reset_car(self, state: EdgeState, i: int, vehicle: Any) -> None:
        state.fresh[i] = True
        state.outside[i] = False
        state.violations[i] = 0
        state.min_margin[i] = np.inf
        state.cost[i] = 0.0
        state.margin[i] = np.inf
        state.cone_hit[i] = False

    def observe_step(self, state: EdgeState, cars: CarsView) -> None:
        from vtrack_gym.tracks.judge import SWEEP_TOL_M, judge_edges

        on = cars.steps > 0
        first = on & state.fresh    # no pose before this step: judged at its end
        state.prev[first] = np.column_stack((cars.x_m, cars.y_m, cars.psi_rad, cars.station_m))[first]
        for track, (edges, ds, closed) in state.edges.items():
            idx = np.flatnonzero(on & (cars.track == track))
            if idx.size:
                judge_edges(_RULE_MEASURES[self.rule], edges, ds, closed, state.body, idx, state.prev, cars.x_m,
                            cars.y_m, cars.psi_rad, cars.station_m, SWEEP_TOL_M, state.rule_min, state.rule_end,
                            state.margin, state.body_end, ~first)
                if track in state.cones:
                    from vtrack_gym.tracks.judge import judge_cones

                    judge_cones(state.cones[track], state.body, idx, state.prev, cars.x_m, cars.y_m, cars.psi_rad,
                                SWEEP_TOL_M, state.cone_hit)
        broke = on & (state.rule_min < 0.0)
        state.violations[:] += broke & ~state.outside
        state.outside[:] = np.where(on, state.rule_end < 0.0, state.outside)
        state.cost[:] = np.where(on, broke.astype(np.float64), 0.0)
        state.min_margin[:] = np.where(on, np.minimum(state.min_margin, state.margin), state.min_margin)
        state.prev[on] = np.column_stack((cars.x_m, cars.y_m, cars.psi_rad, cars.station_m))[on]
        state.fresh[on] = False

    def verdict(self, state: EdgeState, cars: CarsView) -> np.ndarray:
        return cars.completed & (state.violations == 0)

    def metrics(self, state: EdgeState, i: int, track: int) -> dict[str, float]:
        out = {"track_limit_violations": float(state.violations[i]), "min_edge_margin_m": float(state.min_margin[i])}
        if track in state.cones:   # a cone-lined track: Formula Student's penalties
            hit = float(np.count_nonzero(state.cone_hit[i]))
            off = out["track_limit_violations"] if self.rule == "wheels" else 0.0
            out |= {"cones_hit": hit, "fs_penalty_s": FS_CONE_PENALTY_S * hit + FS_OFF_COURSE_PENALTY_S * off}
        return out

    def safety(self, state: EdgeState, cars: CarsView) -> tuple[np.ndarray, np.ndarray]:
        """Cost 1.0 on a step that broke the rule (an excursion's every step), the body's least edge clearance."""
        return state.cost.copy(), state.margin.copy()


class CircleState(NamedTuple):
    """``CircleAtLimit`` state, one entry per car."""

    left: np.ndarray           # bool: |e_y| exceeded the band
    reached: np.ndarray        # bool: the reference speed reached the grip-limit speed
    steady_a_y: np.ndarray     # peak |a_y| while still in the band [m/s^2]
    steady_v: np.ndarray       # speed at that peak [m/s]
    peak_a_y: np.ndarray       # peak |a_y| over the whole episode [m/s^2]
    min_peak_a_y: np.ndarray   # least peak showing the car reached its limit (CIRCLE_MIN_PEAK_G mu g) [m/s^2]
    radius_m: float            # the circle's radius (smallest radius of the first path) [m]
    vehicle: Any               # the nominal car (its grip limit is a metric)


CIRCLE_MIN_PEAK_G = 0.5
"""``CircleAtLimit``: a car whose peak |a_y| stays below this share of mu g never reached its grip limit."""


@documented
@dataclass(frozen=True, kw_only=True)
class CircleAtLimit(SuccessCriterion):
    """ISO 4138 circle: |e_y| <= ``lateral_tolerance_m`` at every step until the reference speed reaches
    ``grip_limit_speed_mps`` = sqrt(mu g R) (or the course is completed), or the car leaves the band only at its own
    grip limit: its peak |a_y| in the band is at least ``limit_share`` of its peak |a_y| on the whole circle, and
    that peak is at least ``CIRCLE_MIN_PEAK_G`` mu g. The plant's limit lies below mu g (Pacejka peak factors below
    1, load transfer, drive force), so a criterion fixed at a share of mu g would judge the car, not the driver.

    Metrics: ``max_steady_a_y_mps2`` (peak |a_y| in the band), ``max_steady_v_mps`` (the speed there),
    ``grip_limit_a_y_mps2`` (the plant's steady-state limit on the circle's radius, ``vehicle.steady_state``) and
    ``mu_g_mps2``."""

    name: ClassVar[str] = "circle"
    per_step: ClassVar[bool] = True
    lateral_tolerance_m: float = ranged(gt=0.0, le=5.0, unit="m")
    grip_limit_speed_mps: float = ranged(gt=0.0, le=100.0, unit="m/s")
    limit_share: float = ranged(0.95, gt=0.0, le=1.0)   # CHOICE

    def __post_init__(self) -> None:
        validate(self)

    @classmethod
    def from_maneuver(cls, spec: Any) -> SuccessCriterion:
        """The circle of an ISO 4138 spec: its lateral tolerance [m] and grip-limit speed [m/s]."""
        return cls(lateral_tolerance_m=spec.lateral_tolerance_m, grip_limit_speed_mps=spec.grip_limit_speed_mps)

    def start(self, paths: tuple, vehicle: Any, n: int) -> CircleState:
        from vtrack_gym.tracks.table import COL_KAPPA

        radius = 1.0 / float(np.max(np.abs(paths[0].table[:, COL_KAPPA])))
        return CircleState(np.zeros(n, dtype=bool), np.zeros(n, dtype=bool), np.zeros(n), np.zeros(n), np.zeros(n),
                           np.zeros(n), radius, vehicle)

    def reset_car(self, state: CircleState, i: int, vehicle: Any) -> None:
        state.left[i] = state.reached[i] = False
        state.steady_a_y[i] = state.steady_v[i] = state.peak_a_y[i] = 0.0
        state.min_peak_a_y[i] = CIRCLE_MIN_PEAK_G * vehicle.tyres.friction_mu * GRAVITY_MPS2

    def observe_step(self, state: CircleState, cars: CarsView) -> None:
        on = cars.steps > 0
        a_y = np.abs(cars.lateral_acc_mps2)
        state.reached[:] |= on & (cars.target_speed_mps >= self.grip_limit_speed_mps)
        state.left[:] |= on & (np.abs(cars.lateral_error_m) > self.lateral_tolerance_m)
        state.peak_a_y[:] = np.where(on, np.maximum(state.peak_a_y, a_y), state.peak_a_y)
        higher = on & ~state.left & (a_y > state.steady_a_y)
        state.steady_a_y[:] = np.where(higher, a_y, state.steady_a_y)
        state.steady_v[:] = np.where(higher, cars.speed_mps, state.steady_v)

    def verdict(self, state: CircleState, cars: CarsView) -> np.ndarray:
        at_limit = ((state.steady_a_y >= self.limit_share * state.peak_a_y)
                    & (state.peak_a_y >= state.min_peak_a_y))
        return np.where(state.left, at_limit, state.reached | cars.completed)

    def metrics(self, state: CircleState, i: int, track: int) -> dict[str, float]:
        from vtrack_gym.vehicle.steady_state import grip_limit

        vehicle = state.vehicle
        return {"max_steady_a_y_mps2": float(state.steady_a_y[i]), "max_steady_v_mps": float(state.steady_v[i]),
                "grip_limit_a_y_mps2": grip_limit(vehicle, state.radius_m).a_y_mps2,
                "mu_g_mps2": float(vehicle.tyres.friction_mu * GRAVITY_MPS2)}


@dataclass(frozen=True)
class Auto(SuccessCriterion):
    """``ConeGates`` when any path has gates, else ``Lap`` (closed paths), ``EndReached`` (open ones) or
    ``Completed`` (a bank of both)."""

    name: ClassVar[str] = "auto"

    def resolve(self, paths: tuple) -> SuccessCriterion:
        if any(p.gates for p in paths):
            return ConeGates()
        closed = {bool(p.closed) for p in paths}
        if closed == {True}:
            return Lap()
        return EndReached() if closed == {False} else Completed()


CRITERIA: dict[str, type[SuccessCriterion]] = {c.name: c for c in (Auto, Lap, EndReached, ConeGates, CircleAtLimit,
                                                                   TrackLimits)}
"""Criterion name -> class (the names ``info`` docs and the CLI use)."""
