"""vtrack_gym: Gymnasium environments for driverless-car trajectory tracking.

``import vtrack_gym`` registers ``LateralTracking-v0``, ``DLC120-v0`` and ``LateralTrackingRandom-v0`` and
loads nothing heavier than Gymnasium's registry (no numba, no torch).
"""

from vtrack_gym._version import __version__
from vtrack_gym.envs.registration import ENV_IDS, register_envs
from vtrack_gym.interop import register_highway_envs

__all__ = ["ENV_IDS", "__version__", "register_envs"]

register_envs()
register_highway_envs()  # the id only; highway-env loads on gym.make
