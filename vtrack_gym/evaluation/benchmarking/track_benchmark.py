"""Scoring policies on the user's track files: one file (suite ``custom``) or a set of them (suite
``tracks[<name>-<digest>]``), with each track's provenance in every row.

``vtrack benchmark --track`` / ``--tracks`` and ``vtrack eval --track`` use it. A track set's board
(``track_set_board``) ranks the policies across all tracks first (success rate and errors over every track and
seed, with 95 % bootstrap intervals) and keeps the per-track rows below.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from vtrack_gym.evaluation.identity.env_identity import check_driven

TRACK_SUITE = "custom"
"""The suite rows scored on one user track are stored under."""
TRACK_SET_SUITE = "tracks"
"""The base name of a track set's suite (``tracks[<name>-<digest>]``)."""
MAX_TRACKS = 10_000
"""Most track files one track set may hold."""


def with_provenance(rows: list, provenance: Mapping[str, Any]) -> list:
    """Rows with the track's provenance (file, SHA-256, speed profile, how it was read) merged into their
    ``options`` (no store schema change; ``merge_provenance``); the rows themselves when there is none."""
    if not provenance:
        return rows
    return [merge_provenance(r, provenance) for r in rows]


def merge_provenance(row: Any, provenance: Mapping[str, Any]) -> Any:
    """``row`` with ``provenance`` merged into its ``options``. ValueError naming the track file when the row drove
    other content (its ``track_sha256``, the bytes its env read) than the provenance names: the file changed after
    it was registered or read, and a row never claims a hash of content it did not drive."""
    check_driven(row.options.get("track_sha256"), provenance)
    return dataclasses.replace(row, options={**row.options, **provenance})


def track_files(dir_or_glob: str | Path) -> list[Path]:
    """The track files of a folder (every suffix of ``tracks.formats.FORMATS``: ``*.csv``, ``*.xodr``, ``*.osm``,
    ``*.xml``, ``*.gpx``; sorted), or the files a glob pattern matches (sorted; ``**`` for any depth, each real
    folder entered once: ``_io.glob_files``); ``ValueError`` when there is none (or more than ``MAX_TRACKS``)."""
    from vtrack_gym._io import glob_files
    from vtrack_gym.tracks.formats import FORMATS

    text = str(dir_or_glob)
    if Path(text).is_dir():
        suffixes = {s for f in FORMATS.values() for s in f.suffixes}
        files = sorted(p for p in Path(text).iterdir() if p.suffix.lower() in suffixes and p.is_file())
    else:   # each real folder entered once: a symlink loop under ** ends
        try:
            files = glob_files(text, MAX_TRACKS)
        except ValueError:
            raise ValueError(f"--tracks {text}: more than {MAX_TRACKS} files") from None
    if not files:
        raise ValueError(f"--tracks {text}: no track file found (give a folder of track files (.csv, .xodr, .osm, "
                         ".xml, .gpx) or a glob pattern such as 'tracks/*.csv')")
    if len(files) > MAX_TRACKS:
        raise ValueError(f"--tracks {text}: {len(files)} files, more than {MAX_TRACKS}")
    return files


@dataclasses.dataclass(frozen=True)
class CheckedTracks:
    """A track set after every file was read and checked: ``tracks`` (env id, provenance, setup) to run, one
    ``described`` line per accepted file (format, closure, length, minimum radius, widths) and the ``refused``
    files with their reasons."""

    files: list[Path]
    tracks: list[tuple[str, Mapping[str, Any], Any]]
    described: list[tuple[Path, str]]
    refused: list[tuple[Path, str]]


def check_track_files(files: Sequence[Path], speed_profile: Any, read: Mapping[str, Any]) -> CheckedTracks:
    """Read, register and build the env of every file (``register_track`` with ``read``: closed, smoothing_m,
    allow_self_crossing, track_options, track_limits), before any episode: a file that fails is refused with its
    reason, the others are kept. ValueError listing the reasons when every file is refused."""
    import gymnasium as gym

    from vtrack_gym.envs.registration import register_track, track_id_setup
    from vtrack_gym.tracks.formats import describe_path, format_of

    tracks, described, refused, kept = [], [], [], []
    for file in files:
        try:
            env_id, provenance = register_track(file, speed_profile, **read)
            env = gym.make(env_id)
            path = env.unwrapped.paths[0]
            env.close()
            line = describe_path(path, format_of(file, (read.get("track_options") or {}).get("format")))
        except (ValueError, ImportError, OSError) as exc:
            why = str(exc)
            named = why.startswith((f"{file}: ", f"{file}, "))     # the file is named once, by the caller
            refused.append((file, why[len(str(file)) + 2:] if named else why))
            continue
        kept.append(file)
        tracks.append((env_id, provenance, track_id_setup(env_id, file, speed_profile)))
        described.append((file, line))
    if not tracks:
        raise ValueError("every track file was refused: " + "; ".join(f"{f.name}: {why}" for f, why in refused))
    return CheckedTracks(kept, tracks, described, refused)


def track_set_suite(name: str, provenances: Sequence[Mapping[str, Any]], seeds: Sequence[int]) -> str:
    """``tracks[<name>-<digest>]``: ``digest`` hashes every track's provenance (content, speed profile, how it
    is read) and the seeds, so two different track sets never share a board."""
    digest = hashlib.sha256(json.dumps([list(provenances), list(seeds)], sort_keys=True,
                                       default=str).encode()).hexdigest()[:8]
    slug = "".join(c if c.isalnum() or c in "_.-" else "_" for c in name)[:40].strip("._") or "tracks"
    return f"{TRACK_SET_SUITE}[{slug}-{digest}]"


def benchmark_track(env_id: str, provenance: Mapping[str, Any], factories: Mapping[str, Any], seeds: Sequence[int],
                    vehicle: str | None = None, figures_dir: str | Path | None = None, workers: int | None = 1,
                    backend: str = "local", show_progress: bool = False, store: Any = None) -> dict[str, Any]:
    """Every policy of ``factories`` (``{id: make(env)}``) on the track env ``env_id``, one episode per seed.

    Returns ``{"rows", "traces": {env_id: [...]}, "figures", "suite": "custom", "lost"}``, like ``run_benchmark``
    (``store``: each row committed as its episode ends); the figures (written in the run's folder under
    ``figures_dir`` when it is given) show the first seed's episodes.
    """
    return _benchmark([(env_id, provenance, None)], factories, seeds, TRACK_SUITE, vehicle, figures_dir, workers,
                      backend, show_progress, store)


def benchmark_tracks(dir_or_glob: str | Path, factories: Mapping[str, Any], seeds: Sequence[int] = (0,),
                     speed_profile: Any = None, closed: bool | None = None, smoothing_m: float | None = None,
                     track_limits: str | None = None, vehicle: str | None = None,
                     figures_dir: str | Path | None = None, workers: int | None = 1, backend: str = "local",
                     show_progress: bool = False, store: Any = None, allow_self_crossing: bool = False,
                     track_options: Mapping[str, Any] | None = None,
                     on_checked: Callable[[CheckedTracks], None] | None = None) -> dict[str, Any]:
    """Every policy on every track file of ``dir_or_glob`` (``track_files``), one episode per track and seed.

    Every file is first read and checked (``check_track_files``): each is registered with ``speed_profile``
    (default: what ``vtrack benchmark --track`` drives, the friction-ellipse ``EnvelopeLimited`` within 40 km/h and
    0.7 g, checked against the car), read with ``closed`` / ``smoothing_m`` / ``allow_self_crossing`` /
    ``track_options`` and judged by the ``track_limits`` rule (``"wheels"``, ``"body"``, ``"centre"``; None: the
    centre) as ``register_track`` does; a file that cannot be read or driven is refused and the rest run. Rows go to
    suite ``track_set_suite(...)`` of the tracks run; rank them with ``track_set_board``. ``on_checked``: called with
    the ``CheckedTracks`` before any episode (to list the refused files). ``workers`` / ``backend``: see
    ``vtrack_gym.evaluation.rollouts.parallel.run_tasks``; ``store``: each row committed as its episode ends. Returns
    ``{"rows", "traces", "figures", "suite", "lost", "tracks": [files run], "refused": [(file, reason)],
    "described": [(file, line)]}``.
    """
    from vtrack_gym.tracks.speed_limits import speed_profile_from_limits

    speed_profile = speed_profile_from_limits() if speed_profile is None else speed_profile
    read = {k: v for k, v in (("closed", closed), ("smoothing_m", smoothing_m),
                              ("allow_self_crossing", allow_self_crossing or None),
                              ("track_options", dict(track_options) if track_options else None),
                              ("track_limits", track_limits)) if v is not None}
    checked = check_track_files(track_files(dir_or_glob), speed_profile, read)
    if on_checked is not None:
        on_checked(checked)
    name = Path(str(dir_or_glob)).name if Path(str(dir_or_glob)).is_dir() else Path(str(dir_or_glob)).parent.name
    suite = track_set_suite(name, [p for _, p, _ in checked.tracks], seeds)
    result = _benchmark(checked.tracks, factories, seeds, suite, vehicle, figures_dir, workers, backend,
                        show_progress, store)
    return {**result, "tracks": checked.files, "refused": checked.refused, "described": checked.described}


def _benchmark(tracks: Sequence[tuple[str, Mapping[str, Any], Any]], factories: Mapping[str, Any],
               seeds: Sequence[int], suite: str, vehicle: str | None, figures_dir: str | Path | None,
               workers: int | None, backend: str, show_progress: bool, store: Any = None) -> dict[str, Any]:
    """Score every (policy, track, seed) task; rows with their track's provenance (stored in ``store`` as each
    episode ends), figures per track."""
    from vtrack_gym.baselines.resolve import recorded_id
    from vtrack_gym.evaluation.benchmarking.benchmark import score_episode, score_tasks, write_figures
    from vtrack_gym.evaluation.rollouts.episodes import Episode
    from vtrack_gym.evaluation.rollouts.parallel import EpisodeTask
    from vtrack_gym.vehicle.catalog import read_vehicle_once

    seeds = [int(s) for s in seeds]
    vehicle = read_vehicle_once(vehicle)   # a vehicle file: its envs and rows use the bytes read here
    provenance = {env_id: prov for env_id, prov, _ in tracks}
    tasks = [EpisodeTask(recorded_id(name, make), make, Episode(env_id, s, vehicle=vehicle), suite,
                         score_episode, keep_trace=s == seeds[0], setup=setup)
             for name, make in factories.items() for env_id, _, setup in tracks for s in seeds]
    label = f"vtrack benchmark ({suite})" if show_progress else None
    scored = score_tasks(tasks, figures_dir, vehicle, workers, backend, label, store=store,
                         finish=lambda r: merge_provenance(r, provenance[r.env_id]))
    figures = [] if scored.folder is None else write_figures(scored.traces_by_env, scored.rows, scored.folder,
                                                             vehicle=vehicle)
    return {"rows": scored.rows, "traces": scored.traces_by_env, "figures": figures, "suite": suite,
            "lost": scored.lost, "store_error": scored.store_error}


def is_track_set(suite: str) -> bool:
    """``suite`` is a track set's (``tracks[...]``)."""
    return suite.startswith(TRACK_SET_SUITE + "[")


def across_tracks_label(n_tracks: int) -> str:
    """The env name of a track set's aggregate rows."""
    return f"all {n_tracks} tracks"


def track_set_board(rows: Sequence[Mapping[str, Any]], columns: Sequence[str], primary: str) -> list[dict[str, Any]]:
    """A track set's board: per policy key over all tracks (env ``all <n> tracks``), then per track.

    ``rows``: stored rows as dicts (``ResultStore.board_rows``), aggregated as
    ``evaluation.leaderboard.board.build_board`` does (success rate first, intervals over every track and seed)."""
    from vtrack_gym.evaluation.identity.env_names import canonical_env_id
    from vtrack_gym.evaluation.leaderboard.board import build_board

    rows = list(rows)
    label = across_tracks_label(len({canonical_env_id(str(r["env_id"])) for r in rows}))   # an alias: one track
    pooled = [{**r, "env_id": label} for r in rows]
    return build_board(pooled, columns, primary) + build_board(rows, columns, primary)
