"""The parameters the steering NMPC (``nmpc.NMPCConfig``) and the coupled NMPC (``nmpc_coupled.CoupledNMPCConfig``)
share, declared once: frozen dataclass groups, each a run of fields that stands in both configs in the same order.

A config is a frozen dataclass built on these groups and on groups of its own fields. A dataclass lists its
bases' fields in reverse order of the bases (the last base's first), then its own: a config names its groups last
field first, so that its fields (``dataclasses.fields``, ``repr``, the positional order, the docstring's table of
ranges) keep the order they always had. The policy fingerprint reads a config by field name
(``dataclasses.asdict`` with sorted keys, the instance ``__dict__``) and its class's qualified name.
"""

from __future__ import annotations

from dataclasses import dataclass

from vtrack_gym._ranges import ranged


@dataclass(frozen=True)
class HorizonFields:
    """N stages of ``stage_time_s`` [s], RK4 steps per stage."""

    horizon_steps: int = ranged(40, ge=5, le=100, integer=True)
    stage_time_s: float = ranged(0.05, ge=0.01, le=0.2, unit="s")
    rk4_substeps: int = ranged(2, ge=1, le=10, integer=True)

    @property
    def horizon_s(self) -> float:
        """N x stage length [s]."""
        return self.horizon_steps * self.stage_time_s


@dataclass(frozen=True)
class LateralWeightFields:
    """Stage costs of the lateral state: e_y [1/m^2], e_phi [1/rad^2], yaw rate against v kappa [s^2/rad^2]."""

    weight_e_y: float = ranged(10.0, ge=0.0, le=1e6, unit="1/m^2")
    weight_e_phi: float = ranged(10.0, ge=0.0, le=1e6, unit="1/rad^2")
    weight_yaw_rate: float = ranged(0.1, ge=0.0, le=1e6, unit="s^2/rad^2")


@dataclass(frozen=True)
class MoveWeightFields:
    """Cost of the steering command's moves [1/rad^2]."""

    weight_move: float = ranged(200.0, ge=1e-6, le=1e8, unit="1/rad^2")


@dataclass(frozen=True)
class IterationFields:
    """Factor on the last stage's state weights, eps added to the Gauss-Newton Hessian, Gauss-Newton steps per
    decision (1: the real-time iteration)."""

    terminal_scale: float = ranged(3.0, ge=0.0, le=100.0)
    regularisation: float = ranged(1e-6, ge=0.0, le=1e3)
    sqp_iterations: int = ranged(1, ge=1, le=20, integer=True)


@dataclass(frozen=True)
class SpeedFloorFields:
    """Speed floor of the lateral model [m/s]."""

    min_speed_mps: float = ranged(4.0, ge=1.0, le=30.0, unit="m/s")


@dataclass(frozen=True)
class PlantModelFields:
    """How fast the predicted speed approaches the target [s], the steering actuator's time constant [s], and the
    Pacejka shape (C, D) per axle."""

    speed_time_constant_s: float = ranged(2.0, gt=0.0, le=100.0, unit="s")
    actuator_lag_s: float = ranged(0.03, ge=0.005, le=1.0, unit="s")
    front_shape_c: float = ranged(1.367, ge=1.0, lt=2.0)
    front_peak_d: float = ranged(0.962, gt=0.0, le=2.0)
    rear_shape_c: float = ranged(1.365, ge=1.0, lt=2.0)
    rear_peak_d: float = ranged(0.974, gt=0.0, le=2.0)
