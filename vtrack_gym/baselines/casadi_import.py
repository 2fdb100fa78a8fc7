"""The one lazy import of CasADi (an optional dependency: the ``nmpc`` extra)."""

from __future__ import annotations

import importlib
from typing import Any


def import_casadi() -> Any:
    """The ``casadi`` module, or ``ImportError`` naming the extra that installs it."""
    try:
        return importlib.import_module("casadi")
    except ImportError as exc:
        raise ImportError('the nmpc baseline needs CasADi: pip install "vtrack_gym[nmpc]" (or pip install casadi)'
                          ) from exc
