"""Formula Student layouts shipped as cone files (``tag,x,y``: blue left, yellow right, orange / big_orange at the
start; ``tracks.cones``), converted from public team data by ``benchmarks/fs_layouts.py``; sources and licences in
``README.md`` next to them. All three are closed loops:

* ``amz_fsi.csv``: AMZ Racing's fssim track "FSI" (215 m, 3.2-5.0 m wide, tightest centre-line radius 3.5 m);
* ``eufs_peanut.csv``: Edinburgh University Formula Student's eufs_sim track "peanut" (100 m, 3.8-5.0 m wide,
  a figure-of-eight-like waist, tightest centre-line radius 2.8 m);
* ``fsds_training.csv``: the FS Driverless Simulator's training track as shipped with eufs_sim (382 m, 3.3-3.5 m
  wide, tightest centre-line radius 6.2 m).
"""

from __future__ import annotations

from pathlib import Path

FS_LAYOUTS: tuple[str, ...] = tuple(sorted(p.name for p in Path(__file__).resolve().parent.glob("*.csv")))
"""The shipped Formula Student cone files (every ``.csv`` next to this module)."""


def fs_layout(name: str) -> Path:
    """The path of the shipped cone file ``name`` (one of ``FS_LAYOUTS``); ValueError naming them otherwise."""
    if name not in FS_LAYOUTS:
        raise ValueError(f"unknown Formula Student layout {name!r}; shipped: {', '.join(FS_LAYOUTS)}")
    return Path(__file__).resolve().parent / name


__all__ = ["FS_LAYOUTS", "fs_layout"]
