"""Writes the shipped Formula Student cone files (``vtrack_gym/tracks/fs_layouts``) from public team data.

    python benchmarks/fs_layouts.py SOURCES_DIR vtrack_gym/tracks/fs_layouts

``SOURCES_DIR`` holds the upstream files as published (see the layouts' README for their repositories, commits and
licences): ``FSI.yaml`` (AMZ Racing fssim, ``cones_left`` / ``cones_right`` / ``cones_orange`` /
``cones_orange_big`` as lists of ``[x, y]``), ``FSDS_Training.csv`` and ``peanut.csv`` (eufs_sim, CSV
``tag,x,y,...``). Each is written as ``tag,x,y`` (blue left, yellow right, orange / big_orange start; coordinates
kept to the millimetre). Rows of other tags (eufs_sim's ``car_start`` pose) are left out. A loop's side whose cones
start elsewhere than at the start line is rotated to begin at the cone nearest the start cones, so that both cone
lines are listed from the same place (the cones themselves are unchanged).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

TAGS = ("blue", "yellow", "orange", "big_orange")
YAML_KEYS = {"cones_left": "blue", "cones_right": "yellow", "cones_orange": "orange", "cones_orange_big": "big_orange"}
LOOP_GAP_M = 6.0
LAYOUTS = {"amz_fsi": "FSI.yaml", "fsds_training": "FSDS_Training.csv", "eufs_peanut": "peanut.csv"}
"""Shipped name -> upstream file name."""


def read_fssim_yaml(text: str) -> list[tuple[str, float, float]]:
    """(tag, x, y) of an fssim track file: top-level keys, each a list of two-element lists."""
    cones: list[tuple[str, float, float]] = []
    tag, pending = None, []
    for line in text.splitlines():
        if line and not line[0].isspace() and not line.startswith("-"):
            tag = YAML_KEYS.get(line.split(":")[0].strip())
            continue
        item = line.strip()
        while item.startswith("- ") or item == "-":     # list markers, not a number's sign
            item = item[1:].strip()
        if tag is None or not item:
            continue
        pending.append(float(item))
        if len(pending) == 2:
            cones.append((tag, pending[0], pending[1]))
            pending = []
    return cones


def read_tag_csv(text: str) -> list[tuple[str, float, float]]:
    """(tag, x, y) of the cone rows of a ``tag,x,y,...`` CSV with a header."""
    rows = [line.split(",") for line in text.splitlines()[1:] if line.strip()]
    return [(r[0].strip(), float(r[1]), float(r[2])) for r in rows if r[0].strip() in TAGS]


def start_at_the_line(cones: list[tuple[str, float, float]]) -> list[tuple[str, float, float]]:
    """Each side of a loop rotated to begin at its cone nearest the start cones (file order otherwise kept)."""
    start = np.array([(x, y) for t, x, y in cones if t in ("orange", "big_orange")])
    out = [c for c in cones if c[0] not in ("blue", "yellow")]
    for side in ("blue", "yellow"):
        xy = np.array([(x, y) for t, x, y in cones if t == side])
        if start.size and np.hypot(*(xy[-1] - xy[0])) <= LOOP_GAP_M:
            xy = np.roll(xy, -int(np.argmin(np.hypot(*(xy - start.mean(axis=0)).T))), axis=0)
        out += [(side, float(x), float(y)) for x, y in xy]
    return out


def write(cones: list[tuple[str, float, float]], path: Path) -> None:
    path.write_text("tag,x,y\n" + "".join(f"{t},{x:.3f},{y:.3f}\n" for t, x, y in cones))


def main(src: Path, dst: Path) -> None:
    for name, upstream in LAYOUTS.items():
        text = (src / upstream).read_text()
        cones = read_fssim_yaml(text) if upstream.endswith(".yaml") else read_tag_csv(text)
        write(start_at_the_line(cones), dst / f"{name}.csv")


if __name__ == "__main__":
    main(Path(sys.argv[1]), Path(sys.argv[2]))
