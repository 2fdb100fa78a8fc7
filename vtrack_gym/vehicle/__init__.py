"""Vehicle parameters, the shipped cars as data (``load_vehicle``/``list_vehicles``) and the batched plant.

``Plant`` and the numba kernels are imported lazily; importing this package only loads dataclasses.
"""

from vtrack_gym.vehicle.catalog import VehicleFileError, list_vehicles, load_vehicle, resolve_vehicle
from vtrack_gym.vehicle.params import (
    GRAVITY_MPS2,
    BrakeParams,
    ChassisParams,
    DesignModel,
    LowSpeedParams,
    PowertrainParams,
    RollParams,
    SteeringParams,
    TyreParams,
    VehicleParams,
    paper_vehicle,
)

__all__ = [
    "GRAVITY_MPS2",
    "BrakeParams",
    "ChassisParams",
    "DesignModel",
    "LowSpeedParams",
    "Plant",
    "PowertrainParams",
    "RollParams",
    "SteeringParams",
    "TyreParams",
    "VehicleFileError",
    "VehicleParams",
    "list_vehicles",
    "load_vehicle",
    "paper_vehicle",
    "resolve_vehicle",
]


def __getattr__(name: str):
    if name == "Plant":
        from vtrack_gym.vehicle.plant import Plant

        return Plant
    raise AttributeError(f"module 'vtrack_gym.vehicle' has no attribute {name!r}")
