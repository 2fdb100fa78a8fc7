"""``Plant``: N vehicles integrated together by the compiled kernel (N = 1 is the single env)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from vtrack_gym.vehicle import layout as L
from vtrack_gym.vehicle.numerics import check_numerics
from vtrack_gym.vehicle.packing import pack_params_batch
from vtrack_gym.vehicle.params import VehicleParams
from vtrack_gym.vehicle.threads import PARALLEL_MIN_N, use_parallel

PARALLEL_THRESHOLD = PARALLEL_MIN_N
"""The default size from which batches are stepped by the multi-threaded kernel (identical results; the one
rule, with its override, is ``vehicle.threads.use_parallel``)."""


def _kernels():
    from vtrack_gym.vehicle import kernels

    return kernels


class Plant:
    """A batch of ``n`` vehicles with fixed-step RK4 physics.

    Args:
        params: one ``VehicleParams`` shared by all vehicles, or one per vehicle.
        n: number of vehicles.
        model: ``"nonlinear"`` (default plant) or ``"linear"`` (paper eq. 5), or one name per vehicle.
        physics_dt_s: physics step [s]; at most 1/500 s (>= 500 Hz).
        numerics: ``"default"`` or ``"fast"`` (``vehicle.numerics``: the SIMD kernel, bounded-error maths).

    ``step`` holds the inputs over ``n_sub`` physics steps (one control period) and returns the per-substep
    outputs ``(n, n_sub, N_OUTPUT)`` (a_x, a_y, a_z [m/s^2], F_z of FL, FR, RL, RR [N]).
    """

    def __init__(self, params: VehicleParams | Sequence[VehicleParams] | None = None, n: int = 1,
                 model: str | Sequence[str] = "nonlinear", physics_dt_s: float = 0.002,
                 numerics: str = "default") -> None:
        if not isinstance(n, (int, np.integer)) or n < 1:
            raise ValueError(f"n must be a positive integer (got {n!r})")
        if not (0.0 < physics_dt_s <= 1.0 / 500.0):
            raise ValueError(f"physics_dt_s must be in (0, 0.002] s, i.e. >= 500 Hz (got {physics_dt_s})")
        self.n = int(n)
        self.physics_dt_s = float(physics_dt_s)
        self.params: VehicleParams | list[VehicleParams] = (
            params if isinstance(params, VehicleParams) else list(params) if params is not None
            else VehicleParams())
        self.param_rows = pack_params_batch(self.params, self.n)
        self.models = np.empty(self.n, dtype=np.int64)
        self.set_model(model)
        self.state = np.zeros((self.n, L.N_STATE), dtype=np.float64)
        self._road = np.zeros((self.n, L.N_ROAD), dtype=np.float64)
        self._out_cache: dict[int, np.ndarray] = {}
        self.numerics = check_numerics(numerics)
        if self.numerics == "fast":
            from vtrack_gym.vehicle import fast_kernels as fk

            self._work = fk.workspace(self.n)
            fast = fk.step_batch_fast_parallel if use_parallel(self.n) else fk.step_batch_fast
            unscheduled = (np.zeros((self.n, 1)), np.zeros((self.n, 1)), 0)
            self._step = lambda *args: fast(*args, *unscheduled)
            return
        k = _kernels()
        self._work = np.empty((self.n, k.WORKSPACE_SIZE), dtype=np.float64)
        self._step = k.step_batch_parallel if use_parallel(self.n) else k.step_batch_serial

    @property
    def workspace(self) -> np.ndarray:
        """The plant's scratch array (n, WORKSPACE_SIZE), for a compiled step that advances this plant's cars."""
        return self._work

    def set_model(self, model: str | Sequence[str]) -> None:
        """Select ``"nonlinear"`` or ``"linear"`` for all vehicles or per vehicle."""
        names = [model] * self.n if isinstance(model, str) else list(model)
        if len(names) != self.n:
            raise ValueError(f"model: expected 1 or {self.n} names, got {len(names)}")
        for i, name in enumerate(names):
            if name not in L.MODEL_IDS:
                raise ValueError(f"model must be one of {sorted(L.MODEL_IDS)} (got {name!r})")
            self.models[i] = L.MODEL_IDS[name]

    def set_vehicle_params(self, index: int, params: VehicleParams) -> None:
        """Replace the parameters of one vehicle (e.g. domain randomisation at reset)."""
        from vtrack_gym.vehicle.packing import pack_params

        self.param_rows[index] = pack_params(params)

    def reset(self, index: int | slice | np.ndarray | None = None, *, x: float = 0.0, y: float = 0.0,
              psi: float = 0.0, v_x: float = 0.0) -> None:
        """Put the selected vehicles (default: all) at rest or at speed ``v_x`` [m/s] on a pose."""
        idx = slice(None) if index is None else index
        self.state[idx] = 0.0
        self.state[idx, L.S_X] = x
        self.state[idx, L.S_Y] = y
        self.state[idx, L.S_PSI] = psi
        self.state[idx, L.S_VX] = v_x

    def step(self, inputs: np.ndarray, n_sub: int, road: np.ndarray | None = None,
             outputs: np.ndarray | None = None) -> np.ndarray:
        """Advance all vehicles by ``n_sub`` physics steps with ``inputs`` (n, 3) held.

        ``road`` (n, 2) is the grade [rad] and road vertical acceleration [m/s^2] (default flat).
        Returns the outputs array (reused between calls of the same ``n_sub`` unless ``outputs`` is given).
        """
        if outputs is None:
            outputs = self._out_cache.get(n_sub)
            if outputs is None:
                outputs = np.empty((self.n, n_sub, L.N_OUTPUT), dtype=np.float64)
                self._out_cache[n_sub] = outputs
        self._step(self.state, inputs, self._road if road is None else road, self.param_rows, self.models,
                   self.physics_dt_s, n_sub, outputs, self._work)
        return outputs
