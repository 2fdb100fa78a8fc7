"""The per-car fitness accumulators of a population rollout: one row per car, columns declared here only.

Both rollout paths (``rollouts.run_compiled`` through ``_kernels``, and ``rollouts.run_stepwise``) fill the same
(n, N_ACC) array, and the (n, samples, N_BUF) body-acceleration buffer; ``population`` reads both by these names.
"""

from __future__ import annotations

import numpy as np

ACC_ITAE = 0         # int t |e_y| dt by the trapezoid rule [m s^2]
ACC_LAST_TE = 1      # t |e_y| at the last step (the trapezoid's previous end) [m s]
ACC_MAX_AY = 2       # max |a_y| over the physics substeps [m/s^2]
ACC_MIN_FZ = 3       # min wheel load F_z [N]
ACC_STEPS = 4        # control steps driven
ACC_MAX_EY = 5       # max |e_y| [m]
N_ACC = 6

BUF_AX, BUF_AY, BUF_AZ = range(3)   # columns of the body-acceleration buffer (comfort scoring) [m/s^2]
N_BUF = 3


def new_accumulators(n: int) -> np.ndarray:
    """Accumulators of ``n`` cars before their first step (zeros; min F_z at +inf)."""
    acc = np.zeros((n, N_ACC))
    acc[:, ACC_MIN_FZ] = np.inf
    return acc


def new_acceleration_buffer(n: int, samples: int) -> np.ndarray:
    """(n, samples, N_BUF) body accelerations a_x, a_y, a_z per physics step, NaN until written (``samples`` 0:
    not recorded)."""
    return np.full((n, samples, N_BUF), np.nan)
