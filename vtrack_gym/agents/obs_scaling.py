"""Fixed physical observation scaling for RL: ``(obs - centre) / scale`` per named field, clipped at +-``CLIP``.

The scales are the observation table's ``centre`` and ``scale`` columns (``vtrack_gym.envs.observation``).

Why not running statistics: ``VecNormalize`` learns each field's spread from the data, and once an agent tracks
well the spread of ``e_y`` is a few centimetres, so with its clip of 10 standard deviations every lateral error
beyond about +-0.4 m reads the same (the imitation agents saw exactly that). Fixed scales keep the
resolution and the visible range stable through training and in the exported agent: ``e_y`` at 0.25 m per unit
is visible up to +-2.5 m (a 1 cm error is 0.04), curvature at 0.02 1/m per unit up to 0.2 1/m (a 5 m hairpin).

The scaling is written into a ``VecNormalize`` whose observation statistics never update
(``freeze_observation_scaling``), so SB3's training loop, saving and the weights-only export
(``obs_mean``/``obs_var``/``clip_obs``) carry it unchanged.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.running_mean_std import RunningMeanStd

from vtrack_gym.envs.observation import SCALARS, SERIES, TRACKING_ERRORS, scale_columns

CLIP = 10.0
"""Scaled observations are clipped at +-CLIP (the visible range of a field is centre +- CLIP x scale)."""

FIELD_SCALES: dict[str, tuple[float, float]] = scale_columns(SCALARS + TRACKING_ERRORS)
"""Field name -> (centre, scale) in the field's SI unit (the observation table's scale columns)."""
PREFIX_SCALES: dict[str, tuple[float, float]] = scale_columns(SERIES)
"""Name prefix -> (centre, scale) for the preview samples (the table's series rows)."""


class FrozenStatistics(RunningMeanStd):
    """Running statistics that ignore updates: the fixed scaling (module level, so ``VecNormalize.save`` pickles
    it)."""

    def update(self, arr: np.ndarray) -> None:
        return None


def field_scale(name: str) -> tuple[float, float]:
    """``(centre, scale)`` of one observation field; ``ValueError`` for a name without a scale."""
    if name in FIELD_SCALES:
        return FIELD_SCALES[name]
    for prefix, value in PREFIX_SCALES.items():
        if name.startswith(prefix):
            return value
    raise ValueError(f"no fixed observation scale for field {name!r}; known: {', '.join(FIELD_SCALES)}, "
                     f"{', '.join(p + 'k' for p in PREFIX_SCALES)}")


def fixed_statistics(names: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    """``(mean, var)`` arrays such that ``(obs - mean) / sqrt(var)`` is the fixed scaling of ``names``."""
    pairs = [field_scale(n) for n in names]
    mean = np.array([c for c, _ in pairs], dtype=np.float64)
    var = np.array([s * s for _, s in pairs], dtype=np.float64)
    return mean, var


def freeze_observation_scaling(vecnormalize: Any, names: Sequence[str]) -> None:
    """Make ``vecnormalize`` (an SB3 ``VecNormalize`` with ``norm_obs``) scale observations by the fixed table
    and never update its observation statistics (reward normalisation, if on, keeps learning)."""
    if not getattr(vecnormalize, "norm_obs", False):
        raise ValueError("fixed observation scaling needs a VecNormalize with norm_obs=True")
    mean, var = fixed_statistics(names)
    if mean.shape != vecnormalize.observation_space.shape:
        raise ValueError(f"{len(names)} names for an observation of shape {vecnormalize.observation_space.shape}")
    frozen = FrozenStatistics(shape=mean.shape)
    frozen.mean, frozen.var, frozen.count = mean, var, 1.0
    vecnormalize.obs_rms = frozen
    vecnormalize.clip_obs = CLIP


class FixedObservationScaling(BaseCallback):
    """The fixed scales as an SB3 callback, for rl_zoo3 (``callback:`` in a hyperparameter file): when learning
    starts, the model's ``VecNormalize`` takes the fixed scaling (``freeze_observation_scaling``, with the env's
    observation names) and the first observation, normalised at reset, is rescaled with it. ``vtrack train``
    applies the same scaling before it builds the model."""

    def _init_callback(self) -> None:
        vecnorm = self.model.get_vec_normalize_env()
        if vecnorm is None:
            raise ValueError("FixedObservationScaling needs normalize: {norm_obs: true} in the hyperparameters")
        layout = vecnorm.get_attr("observation_layout", [0])[0]
        freeze_observation_scaling(vecnorm, layout.names)
        if getattr(self.model, "_last_obs", None) is not None:
            self.model._last_obs = vecnorm.normalize_obs(vecnorm.get_original_obs())

    def _on_step(self) -> bool:
        return True
