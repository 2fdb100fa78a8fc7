"""Run-time MPC gain tables of a whole population at once (one weight vector per individual).

The prediction matrices F, Phi, tau do not depend on the weights, so they are built once per speed and cached;
per individual only the (N_c x N_c) Hessian solve and the folded preview row are computed, for all rows at once.
The full speed grid of the config is kept. Row p equals ``vtrack_gym.baselines.mpc.gain_table`` of the config
with ``weights[p]`` (to rounding).
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from vtrack_gym.baselines.mpc import MPCConfig, measured_outputs, mpc_model, preview_slope_difference, speed_grid
from vtrack_gym.envs.observation import OBS, ObservationLayout
from vtrack_gym.vehicle.params import DesignModel


@functools.lru_cache(maxsize=4)
def _weight_free_models(design: DesignModel, config: MPCConfig, layout: ObservationLayout) -> tuple:
    """Prediction matrices stacked over the speed grid, independent of the weights: (speeds (S,), phi
    (S, R, N_c), f (S, R, n_x), tau (S, R, n_d), preview slope difference (S, N_p - 1, n_preview + 2) or None)."""
    speeds = speed_grid(config)
    phis, fs, taus, slopes = [], [], [], []
    for v in speeds:
        mdl = mpc_model(design, float(v), config)
        phis.append(mdl.phi)
        fs.append(mdl.f)
        taus.append(mdl.tau)
        slope_diff = preview_slope_difference(layout, float(v), config)
        if slope_diff is not None:
            slopes.append(slope_diff)
    slope_diff = np.stack(slopes) if slopes else None
    return speeds, np.stack(phis), np.stack(fs), np.stack(taus), slope_diff


def population_gain_tables(design: DesignModel, config: MPCConfig, weights: np.ndarray,
                           layout: ObservationLayout = OBS) -> tuple[np.ndarray, np.ndarray]:
    """(speeds (S,), run-time gain rows (P, S, width)) for weight vectors ``weights`` (P, 12).

    Row p equals ``gain_table(design, replace(config, weights=weights[p]), layout).runtime`` (to rounding). All
    speeds and individuals are computed at once; only the first row of the receding-horizon gain
    K = (Phi' W Phi + r I)^-1 Phi' W is needed, and as the Hessian H is symmetric that row is
    (H^-1 e_1)' Phi' W: one small solve per speed and individual instead of one with R right-hand sides.
    """
    w = np.atleast_2d(np.asarray(weights, dtype=np.float64))
    if w.shape[1] != 12 or not np.all(np.isfinite(w)) or np.any(w < 0):
        raise ValueError("weights must be finite, >= 0, of shape (P, 12)")
    speeds, phi, f, tau, slope_diff = _weight_free_models(design, dataclasses.replace(config, weights=(0.0,) * 12),
                                                          layout)
    npred, nc = config.prediction_horizon, config.control_horizon
    w1 = np.tile(w, (1, npred)) if config.interpretation == "augmented_outputs" else w     # (P, R)
    measured = measured_outputs(config)
    # H = Phi' diag(w) Phi + r I for every speed and individual: one product with the weight-free Phi_c Phi_d.
    outer = (phi[..., :, None] * phi[..., None, :]).reshape(phi.shape[0], phi.shape[1], nc * nc)  # (S, R, N_c^2)
    # einsum, not BLAS matmul: BLAS rounding depends on how many rows (individuals) it gets, and a row's gains
    # must not depend on the batch it is evaluated in (local and Ray backends give the same bits).
    hess = np.einsum("pr,srk->spk", w1, outer).reshape(phi.shape[0], w.shape[0], nc, nc) \
        + config.input_weight * np.eye(nc)
    e1 = np.zeros((*hess.shape[:-1], 1))
    e1[..., 0, 0] = 1.0
    first = np.linalg.solve(hess, e1)[..., 0]                                             # (S, P, N_c)
    k_mpc = np.einsum("spc,src->spr", first, phi) * w1                                    # (S, P, R)
    kx = np.einsum("spr,srx->spx", k_mpc, f)                                              # (S, P, n_x)
    kd = np.einsum("spr,srd->spd", k_mpc, tau)                                            # (S, P, n_d)
    if slope_diff is not None:
        kd_next = np.concatenate((kd[..., 1:], np.zeros((*kd.shape[:-1], 1))), axis=-1)
        preview = np.einsum("spj,sjq->spq", (kd - kd_next)[..., 1:], slope_diff)          # (S, P, n_preview + 2)
    else:
        preview = np.zeros((*kd.shape[:-1], layout.n_preview + 2))
    table = np.concatenate((kx[..., :8], kx[..., measured], kd[..., :1], preview), axis=-1)  # (S, P, width)
    return speeds, np.ascontiguousarray(table.transpose(1, 0, 2))
