"""Gymnasium envs: single env, native vector env, SB3 adapter, observation layout, rendering."""

from vtrack_gym.envs.observation import OBS, ObservationLayout

__all__ = ["OBS", "ObservationLayout"]
