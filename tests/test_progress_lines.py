"""Progress bars write whole lines, not carriage-return redraws, when stderr is a file or a CI log."""

from __future__ import annotations

import io
import os
import subprocess
import sys
from pathlib import Path

from vtrack_gym._progress import LineStream

ROOT = Path(__file__).resolve().parents[1]


class FakeClock:
    def __init__(self) -> None:
        self.now_s = 0.0

    def __call__(self) -> float:
        return self.now_s


def test_line_stream_writes_a_line_per_interval_and_the_last_state() -> None:
    out, clock = io.StringIO(), FakeClock()
    stream = LineStream(out, interval_s=30.0, clock=clock)
    stream.write("\rrun:   0%|   | 0/4")
    clock.now_s = 10.0
    stream.write("\rrun:  25%|   | 1/4")  # within 30 s of the last line: held
    stream.write("\r" + " " * 20 + "\r")  # a log line's clearing of the bar: nothing
    clock.now_s = 31.0
    stream.write("\rrun:  50%|   | 2/4")
    stream.write("\rrun:  50%|   | 2/4")  # the same line again (a refresh after a log line): dropped
    clock.now_s = 35.0
    stream.write("\rrun: 100%|   | 4/4 [00:35<00:00, 8.8s/it]")
    stream.write("\n")  # the bar closed: its last state
    clock.now_s = 70.0
    stream.write("\rrun: 100%|   | 4/4 [01:10<00:00, 17.5s/it]")  # only the timing moved: nothing new
    stream.write("\n")
    assert out.getvalue().splitlines() == ["run:   0%|   | 0/4", "run:  50%|   | 2/4",
                                           "run: 100%|   | 4/4 [00:35<00:00, 8.8s/it]"]


def test_benchmark_progress_in_a_log_file_is_whole_lines(tmp_path: Path) -> None:
    """What a CI log of the README's main job shows: no carriage returns; the bar's first and last states."""
    err = tmp_path / "stderr.log"
    argv = [sys.executable, "-m", "vtrack_gym.cli", "benchmark", "--policies", "lqr", "--no-figures",
            "--store", str(tmp_path / "s.sqlite")]
    with err.open("w") as stderr:
        proc = subprocess.run(argv, stdout=subprocess.PIPE, stderr=stderr, text=True, timeout=600,
                              env={**os.environ, "PYTHONPATH": str(ROOT)})
    text = err.read_text()
    assert proc.returncode == 0, text
    assert "\r" not in text
    bars = [line for line in text.splitlines() if line.startswith("vtrack benchmark (paper):")]
    assert bars[0].split(":", 1)[1].lstrip().startswith("0%") and "100%" in bars[-1], bars


def test_the_bar_counts_lost_and_failed_episodes() -> None:
    """Each episode advances the bar, done, lost or failed; once one was lost or failed the bar's line says how
    many of each (``12 done, 2 lost``), also the last line a log file gets."""
    from tqdm import tqdm

    from vtrack_gym._progress import EpisodeCounts

    out, clock = io.StringIO(), FakeClock()
    with tqdm(total=14, desc="run", file=LineStream(out, interval_s=30.0, clock=clock)) as bar:
        counts = EpisodeCounts(bar)
        for outcome in ["done"] * 6 + ["lost"] + ["done"] * 6 + ["lost"]:
            counts.add(outcome)
    assert counts.text() == "12 done, 2 lost"
    last = out.getvalue().splitlines()[-1]
    assert "14/14" in last and "12 done, 2 lost" in last
    quiet = EpisodeCounts(None)
    for outcome in ("done", "done", "failed"):
        quiet.add(outcome)
    assert quiet.text() == "2 done, 1 failed" and EpisodeCounts().text() == "0 done"


def test_run_tasks_counts_a_failed_episode_on_the_bar() -> None:
    """An episode that raises ends ``run_tasks``; the bar has counted it as failed beside the ones done."""
    import pytest
    from tqdm import tqdm

    from vtrack_gym.evaluation.rollouts.episode_failure import episode_of
    from vtrack_gym.evaluation.rollouts.episodes import Episode
    from vtrack_gym.evaluation.rollouts.parallel import EpisodeTask, run_tasks

    def score(policy_id, policy, env, episode, suite):
        if episode.seed == 2:
            raise RuntimeError("boom")
        return type("Row", (), {"termination": "completed"})(), None

    tasks = [EpisodeTask("p", lambda env: object(), Episode("DLC120-v0", s), "custom", score) for s in range(4)]
    out = io.StringIO()
    with tqdm(total=4, desc="run", file=LineStream(out, interval_s=0.0)) as bar, \
            pytest.raises(RuntimeError, match="boom") as raised:
        run_tasks(tasks, workers=1, progress=bar)
    assert episode_of(raised.value) == {"policy": "p", "env": "DLC120-v0", "seed": 2}
    assert "3/4" in out.getvalue().splitlines()[-1] and "2 done, 1 failed" in out.getvalue().splitlines()[-1]
