"""Optional packages: which a command needs (from its arguments alone) and how to install the missing ones."""

from __future__ import annotations

import argparse
from collections.abc import Callable

EXTRAS: dict[str, tuple[str, str]] = {
    "matplotlib": ("benchmark", "the figures"), "osqp": ("benchmark", "the mpc_osqp baseline"),
    "casadi": ("nmpc", "the nmpc baseline's casadi and converged presets"),
    "highway_env": ("highway", "highway-env's lane-keeping-v0"), "stable_baselines3": ("rl", "SB3 training"),
    "torch": ("rl", "SB3 training"), "yaml": ("rl", "the hyperparameter files"), "pymoo": ("tuning", "the GA"),
    "minari": ("dataset", "Minari datasets"), "h5py": ("dataset", "Minari's HDF5 files"),
}
"""Importable module -> (extra that installs it, what needs it)."""
TORCH_HINT = ("The rl extra brings PyTorch: without an NVIDIA GPU, install its CPU build first (pip install torch "
              "--index-url https://download.pytorch.org/whl/cpu); for a GPU build pick your platform and CUDA "
              "version at https://pytorch.org/get-started/locally/ (a plain `pip install torch` pulls the CUDA "
              "build, several GB, on Linux).")
"""Said with every message that names the ``rl`` extra."""


def osqp_for(policies: list[str]) -> list[str]:
    """The solver packages of the policies: ``"osqp"`` for the OSQP MPC, ``"casadi"`` for the nonlinear MPC's
    presets that run on CasADi (``nmpc:casadi``, ``nmpc:converged``; its default is compiled by the package)."""
    from vtrack_gym.baselines.nmpc import NMPC_PRESETS

    needed = []
    for spec in policies:
        name, _, preset = spec.partition(":")
        if name == "mpc_osqp":
            needed.append("osqp")
        elif name == "nmpc" and preset in NMPC_PRESETS and NMPC_PRESETS[preset].method == "casadi":
            needed.append("casadi")
    return list(dict.fromkeys(needed))


def missing_packages(args: argparse.Namespace, needed_modules: Callable[[argparse.Namespace], list[str]]) -> str:
    """'' if every optional package the command needs is installed, else which are missing and the extra."""
    import importlib.util

    missing = [m for m in dict.fromkeys(needed_modules(args)) if importlib.util.find_spec(m) is None]
    if not missing:
        return ""
    extras = sorted({EXTRAS[m][0] for m in missing})
    what = "; ".join(f"{m} ({EXTRAS[m][1]})" for m in missing)
    hint = " or pass --no-figures" if args.command == "benchmark" and "matplotlib" in missing else ""
    torch = f". {TORCH_HINT}" if "rl" in extras else ""
    return (f"missing optional packages: {what}. Install them with: pip install "
            + " ".join(f'"vtrack_gym[{e}]"' for e in extras) + hint + torch)
