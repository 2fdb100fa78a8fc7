"""vtrack_gym: Gymnasium environments for driverless-car trajectory tracking.

``import vtrack_gym`` registers the environments and nothing heavier (no numba, no torch).
"""

__version__ = "0.1.0"
