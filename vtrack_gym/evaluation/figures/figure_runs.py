"""Figures belong to their run: each benchmark run writes its figures in its own folder, named by the suite, the
policy set, the car and the envs (``run_folder``), and every row of the run records that folder (relative to the
figures root) in ``options["figures"]``. A board then embeds a run's figures only when every stored row of that
run is one the board aggregates (``figures_of_rows``): a run whose rows were replaced by a newer run, or that
scored policies the board does not show, contributes no figure.
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

FIGURES_OPTION = "figures"
"""The key of a row's ``options`` naming its run's figure folder (relative to the figures root)."""
MAX_NAMED_POLICIES = 3
"""A folder name lists up to this many policy ids; larger sets are named by their count."""


def _slug(text: str, limit: int = 40) -> str:
    return re.sub(r"[^A-Za-z0-9_.+-]", "_", text).strip("._")[:limit] or "x"


def run_folder(suite: str, policy_ids: Iterable[str], vehicle: str | None = None,
               env_ids: Iterable[str] = ()) -> str:
    """The figure folder of a run, relative to the figures root: ``<suite>/<policies>-<digest>``.

    ``<policies>`` lists the sorted policy ids (``lqr+smc``), or ``<n>-policies`` for more than
    ``MAX_NAMED_POLICIES``; ``<digest>`` hashes the suite, every policy id, the car and the envs, so two runs
    that differ in any of them never share a folder (rerunning the same run replaces its own figures).
    """
    ids = sorted(set(policy_ids))
    envs = sorted(set(env_ids))
    named = "+".join(_slug(p, 20) for p in ids) if len(ids) <= MAX_NAMED_POLICIES else f"{len(ids)}-policies"
    digest = hashlib.sha256(json.dumps([suite, ids, vehicle, envs]).encode()).hexdigest()[:8]
    car = f"-{_slug(vehicle, 24)}" if vehicle else ""
    return f"{_slug(suite, 60)}/{named}{car}-{digest}"


def _row_key(row: Mapping[str, Any]) -> tuple[Any, ...]:
    return (row["id"],) if "id" in row else (row["env_id"], row["policy_id"], row.get("seed"), row.get("created_utc"))


def figure_runs(shown_rows: Sequence[Mapping[str, Any]], suite_rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The run folders whose figures belong to the board: every stored row of the suite recording the folder
    (``suite_rows``) is among the rows the board aggregates (``shown_rows``); sorted."""
    shown = {_row_key(r) for r in shown_rows}
    runs: dict[str, bool] = {}
    for r in suite_rows:
        folder = (r.get("options") or {}).get(FIGURES_OPTION)
        if isinstance(folder, str) and folder:
            runs[folder] = runs.get(folder, True) and _row_key(r) in shown
    return sorted(folder for folder, complete in runs.items() if complete)


def safe_folder(root: Path, folder: str) -> Path | None:
    """``root / folder`` when it stays inside ``root`` (a stored folder name is data: no ``..`` or absolute
    path escapes the figures root); None otherwise."""
    parts = Path(folder).parts
    if not parts or Path(folder).is_absolute() or any(p in ("..", "") for p in parts):
        return None
    return root / folder


def run_figures(root: Path, folders: Sequence[str], max_bytes: int) -> tuple[list[Path], list[str]]:
    """The PNGs of ``folders`` under ``root`` (regular files of at most ``max_bytes``) and the folders that are
    missing or unsafe."""
    files: list[Path] = []
    missing: list[str] = []
    for folder in folders:
        path = safe_folder(root, folder)
        if path is None or not path.is_dir():
            missing.append(folder)
            continue
        files += sorted(f for f in path.glob("*.png") if f.is_file() and f.stat().st_size <= max_bytes)
    return files, missing


def policy_figure_notes(shown_rows: Sequence[Mapping[str, Any]], complete_runs: Sequence[str],
                        missing_runs: Sequence[str] = ()) -> list[str]:
    """One sentence per reason, naming the board's policies it applies to: whose figures are embedded, whose rows
    were scored without figures (``--no-figures``, ``vtrack eval``, Python), whose run also holds rows this board
    does not show (replaced by a newer run, or policies of another board) and whose run folder is missing."""
    complete, missing = set(complete_runs) - set(missing_runs), set(missing_runs)
    status: dict[str, str] = {}
    order = ("embedded", "missing", "partial", "none")
    for r in shown_rows:
        folder = (r.get("options") or {}).get(FIGURES_OPTION)
        state = ("embedded" if folder in complete else "missing" if folder in missing else "partial"
                 if isinstance(folder, str) and folder else "none")
        policy = str(r["policy_id"])
        if order.index(state) < order.index(status.get(policy, "none")) or policy not in status:
            status[policy] = state
    text = {"embedded": "Figures shown for: {}.",
            "none": "No figures for {}: their rows were scored without figures (vtrack benchmark --no-figures, "
                    "vtrack eval or Python).",
            "partial": "No figures for {}: the benchmark run that drew them also scored rows this board does not "
                       "show (a newer run replaced some, or it scored other policies or suites).",
            "missing": "No figures for {}: their run's figure folder is not under --figures."}
    return [text[state].format(", ".join(sorted(p for p, s in status.items() if s == state)))
            for state in order if any(s == state for s in status.values())]
