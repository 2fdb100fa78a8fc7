"""Scoring policies on one user track file (suite ``custom``), with the track's provenance in every row.

``vtrack benchmark --track`` and ``vtrack eval --track`` use it; from Python: register the track with
``vtrack_gym.envs.registration.register_track`` and pass its id and provenance here.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

TRACK_SUITE = "custom"
"""The suite rows scored on a user's track are stored under."""


def with_provenance(rows: list, provenance: Mapping[str, Any]) -> list:
    """Rows with the track's provenance (file, SHA-256, speed profile, how it was read) merged into their
    ``options`` (no store schema change); the rows themselves when there is none."""
    if not provenance:
        return rows
    return [dataclasses.replace(r, options={**r.options, **provenance}) for r in rows]


def benchmark_track(env_id: str, provenance: Mapping[str, Any], factories: Mapping[str, Any], seeds: Sequence[int],
                    vehicle: str | None = None, figures_dir: str | Path | None = None) -> dict[str, Any]:
    """Every policy of ``factories`` (``{id: make(env)}``) on the track env ``env_id``, one episode per seed.

    Returns ``{"rows", "traces": {env_id: [...]}, "figures", "suite": "custom"}``, like ``run_benchmark``; the
    figures (written when ``figures_dir`` is given) show the first seed's episodes.
    """
    from vtrack_gym.evaluation.benchmark import score_policy, write_figures
    from vtrack_gym.evaluation.suites import Episode

    episodes = [Episode(env_id, int(s), vehicle=vehicle) for s in seeds]
    rows, traces = [], []
    for name, make in factories.items():
        r, t = score_policy(name, make, episodes, TRACK_SUITE)
        rows += with_provenance(r, provenance)
        traces += [tr for tr in t if tr.seed == episodes[0].seed]
    figures = [] if figures_dir is None else write_figures({env_id: traces}, rows, figures_dir, vehicle=vehicle)
    return {"rows": rows, "traces": {env_id: traces}, "figures": figures, "suite": TRACK_SUITE}
