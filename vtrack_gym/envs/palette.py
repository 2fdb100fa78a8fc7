"""One colour per policy, shared by the figures (``evaluation.figures.plots``) and the videos (``envs.render``)."""

from __future__ import annotations

import zlib

KNOWN_POLICY_COLOURS: dict[str, str] = {
    "smc": "#1f77b4",           # blue
    "mpc_osqp": "#8c564b",      # brown
    "mpc": "#ff7f0e",           # orange
    "lqr": "#2ca02c",           # green
    "stanley": "#d62728",       # red
    "pure_pursuit": "#9467bd",  # purple
    "ppo": "#e377c2",           # pink
    "sac": "#17becf",           # cyan
    "td3": "#bcbd22",           # olive
    "ppo_bc": "#f7b6d2",        # light pink (the imitation PPO)
    "sac_bc": "#9edae5",        # light cyan (the imitation SAC)
}
"""Colours of the shipped policies (matplotlib's tab10 without its grey, kept for the reference path)."""

FALLBACK_COLOURS: tuple[str, ...] = ("#000080", "#b8860b", "#006400", "#8b008b", "#2f4f4f", "#ff1493")
"""Colours for other policy names, picked by a stable hash of the name."""


def policy_colour(policy_id: str) -> str:
    """``#rrggbb`` colour of a policy; the same name gets the same colour in every figure and video.

    A name starting with a known policy (``mpc_tuned``, ``smc (paper)``) takes that policy's colour;
    the longest matching prefix wins (``mpc_osqp`` before ``mpc``).
    """
    name = policy_id.strip().lower()
    for key in sorted(KNOWN_POLICY_COLOURS, key=len, reverse=True):
        if name == key or (name.startswith(key) and not name[len(key)].isalnum()):
            return KNOWN_POLICY_COLOURS[key]
    return FALLBACK_COLOURS[zlib.crc32(name.encode()) % len(FALLBACK_COLOURS)]


def hex_to_rgb(colour: str) -> tuple[int, int, int]:
    """``#rrggbb`` -> (r, g, b) in 0..255."""
    c = colour.lstrip("#")
    if len(c) != 6:
        raise ValueError(f"colour must be '#rrggbb' (got {colour!r})")
    return int(c[0:2], 16), int(c[2:4], 16), int(c[4:6], 16)
