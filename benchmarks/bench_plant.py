"""Plant throughput: physics steps per second for N = 1 and N = 4096 vehicles.

Peer measured in the same run: highway-env's ``BicycleVehicle.step`` (its RK4 single-track model), if
installed. Run: ``python benchmarks/bench_plant.py``.
"""

from __future__ import annotations

import numpy as np
from _timing import rate

from vtrack_gym.vehicle.plant import Plant

N_SUB = 5  # physics steps per call (one 10 ms control period at 500 Hz)


def plant_rate(n: int, model: str) -> float:
    """Vehicle-physics-steps per second of the compiled plant."""
    plant = Plant(n=n, model=model)
    rng = np.random.default_rng(0)
    plant.state[:, 3] = rng.uniform(5.0, 30.0, n)
    inputs = np.column_stack([rng.uniform(-0.05, 0.05, n), np.full(n, 0.2), np.zeros(n)])
    return rate(lambda: plant.step(inputs, N_SUB), n * N_SUB)


def highway_env_rate() -> float | None:
    """Physics steps per second of highway-env's BicycleVehicle (one vehicle), or None if absent."""
    try:
        from highway_env.road.road import Road, RoadNetwork
        from highway_env.vehicle.dynamics import BicycleVehicle
    except ImportError:
        return None
    road = Road(RoadNetwork.straight_road_network(), np_random=np.random.default_rng(0))
    vehicle = BicycleVehicle(road, [0.0, 0.0], speed=10.0)
    vehicle.act({"steering": 0.01, "acceleration": 0.0})
    return rate(lambda: vehicle.step(0.002), 1)


def main() -> None:
    peer = highway_env_rate()
    rows = []
    for model in ("nonlinear", "linear"):
        for n in (1, 4096):
            rows.append((model, n, plant_rate(n, model)))
    print(f"{'model':<10} {'N':>5} {'vehicle-steps/s':>16} {'vs highway-env':>15}")
    for model, n, r in rows:
        ratio = f"{r / peer:,.0f}x" if peer else "n/a"
        print(f"{model:<10} {n:>5} {r:>16,.0f} {ratio:>15}")
    if peer:
        print(f"{'highway-env BicycleVehicle':<27} {peer:>11,.0f}  (peer, same run)")
    print("targets (issue 2): N=1 >= 50,000 steps/s; N=4096 >= 5,000,000 vehicle-steps/s")


if __name__ == "__main__":
    main()
