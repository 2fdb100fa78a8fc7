"""Finished work is stored before anything else can fail: each row is committed as its episode ends, before any
table is printed; a worker killed with ``kill -9`` costs only its own episode (reported under the table and in the
exit status, no traceback); SIGINT and SIGTERM end every worker within seconds."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from interactive import as_in_a_terminal

from vtrack_gym.evaluation.rollouts.worker_pool import LostTask, run_pool
from vtrack_gym.evaluation.storage.store import ResultStore

ROOT = Path(__file__).resolve().parents[1]

POLICIES = textwrap.dedent('''
    import os, signal, time
    from pathlib import Path

    import numpy as np
    from vtrack_gym.envs import OBS

    PARENT = int(os.environ["VTRACK_TEST_PARENT"])
    MARKS = Path(os.environ["VTRACK_TEST_MARKS"])


    class Steady:
        """Proportional steering on e_y and e_phi."""

        def predict(self, observation, state=None, episode_start=None, deterministic=True):
            obs = np.asarray(observation, dtype=np.float64)
            a = -(0.08 * obs[..., OBS.E_Y] + 0.9 * obs[..., OBS.E_PHI])
            return np.clip(a, -1.0, 1.0).astype(np.float32)[..., None], state


    def _first(name):
        """True once per test: the first worker that claims ``name``."""
        try:
            os.close(os.open(MARKS / name, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
            return True
        except FileExistsError:
            return False


    class KillsOneWorker(Steady):
        """Kills its own worker process (kill -9) in one episode; the parent's warm-up is left alone."""

        def predict(self, observation, state=None, episode_start=None, deterministic=True):
            if os.getpid() != PARENT and _first("killed"):
                os.kill(os.getpid(), signal.SIGKILL)
            return super().predict(observation, state, episode_start, deterministic)


    class FailsInThirdEpisode(Steady):
        """Raises in the third instance built (one per episode; workers=1: counted in one process)."""

        built = 0

        def __init__(self):
            type(self).built += 1
            self.number = type(self).built

        def predict(self, observation, state=None, episode_start=None, deterministic=True):
            if self.number >= 3:
                raise RuntimeError("the policy failed in its third episode")
            return super().predict(observation, state, episode_start, deterministic)


    class Hangs(Steady):
        """Spins forever in a worker (a policy stuck in its own loop), after writing its pid."""

        def predict(self, observation, state=None, episode_start=None, deterministic=True):
            if os.getpid() != PARENT:
                (MARKS / f"worker-{os.getpid()}").write_text("spinning")
                while True:
                    pass
            return super().predict(observation, state, episode_start, deterministic)
''')


def _road(file: Path) -> Path:
    """A 100 m road with a gentle left arc (short episodes)."""
    s = np.arange(0.0, 100.0, 2.0)
    kappa = np.where((s > 30.0) & (s < 60.0), 1.0 / 60.0, 0.0)
    psi = np.concatenate([[0.0], np.cumsum(kappa[1:] * np.diff(s))])
    x = np.concatenate([[0.0], np.cumsum(np.cos(psi[:-1]) * np.diff(s))])
    y = np.concatenate([[0.0], np.cumsum(np.sin(psi[:-1]) * np.diff(s))])
    file.write_text("x_m,y_m\n" + "\n".join(f"{a:.4f},{b:.4f}" for a, b in zip(x, y, strict=True)) + "\n")
    return file


def _vtrack(tmp_path: Path, *argv: str, stdout: int | None = subprocess.PIPE, **popen: object) -> subprocess.Popen:
    """``vtrack ARGV`` (``main`` in a fresh interpreter) from ``tmp_path`` (the policies module importable there),
    started as from a terminal (Ctrl-C armed even when this test run ignores SIGINT)."""
    (tmp_path / "user_policies.py").write_text(POLICIES)
    (tmp_path / "marks").mkdir(exist_ok=True)
    env = {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{tmp_path}", "VTRACK_TEST_MARKS": str(tmp_path / "marks")}
    process = subprocess.Popen(as_in_a_terminal([sys.executable, "-c", "import os, sys; os.environ["
                                                 "'VTRACK_TEST_PARENT'] = str(os.getpid()); from vtrack_gym.cli "
                                                 "import main; sys.exit(main(sys.argv[1:]))", *argv]),
                               cwd=tmp_path, env=env, stdout=stdout, stderr=subprocess.PIPE, text=True, **popen)
    return process


def _benchmark(tmp_path: Path, policy: str, workers: int, seeds: str = "0-3") -> list[str]:
    return ["benchmark", "--track", str(_road(tmp_path / "road.csv")), "--policies", f"user_policies:{policy}",
            "--trust-code", "--seeds", seeds, "--workers", str(workers), "--no-figures",
            "--store", str(tmp_path / "s.sqlite")]


def _work(i: int) -> int:
    if i == 2:
        os.kill(os.getpid(), signal.SIGKILL)
    return i * i


def test_pool_loses_only_the_killed_task() -> None:
    done: dict[int, int] = {}
    lost = run_pool(6, 2, _work, done.__setitem__)
    assert lost == [LostTask(2, "killed by SIGKILL")]
    assert done == {i: i * i for i in range(6) if i != 2}


def test_pool_starts_only_the_workers_it_needs() -> None:
    pids: dict[int, int] = {}
    run_pool(1, 8, lambda i: os.getpid(), pids.__setitem__)
    assert len(pids) == 1 and pids[0] != os.getpid()
    with pytest.raises(ValueError, match="workers must be an integer >= 1"):
        run_pool(1, 0, _work, pids.__setitem__)


def test_kill_9_of_a_worker_keeps_every_finished_episode(tmp_path: Path) -> None:
    process = _vtrack(tmp_path, *_benchmark(tmp_path, "KillsOneWorker", workers=2))
    stdout, stderr = process.communicate(timeout=600)
    assert process.returncode == 3, stderr[-3000:]
    assert "Traceback" not in stderr and "BrokenProcessPool" not in stderr
    assert "lost episodes: 1" in stdout and "killed by SIGKILL" in stdout
    bar = [line for line in stderr.splitlines() if line.startswith("vtrack benchmark")]
    assert bar and "4/4" in bar[-1] and "3 done, 1 lost" in bar[-1], stderr[-3000:]   # the bar counts the lost one
    rows = ResultStore(tmp_path / "s.sqlite", read_only=True).rows()
    assert len(rows) == 3 and len({r["seed"] for r in rows}) == 3


def test_a_failed_episode_is_one_line_and_counted_on_the_bar(tmp_path: Path) -> None:
    """``vtrack benchmark`` whose policy raises in its third episode: the two finished rows are stored, the error is
    one line naming the episode and what was stored, the bar's last line counts the failed episode, exit status 2."""
    process = _vtrack(tmp_path, *_benchmark(tmp_path, "FailsInThirdEpisode", workers=1))
    stdout, stderr = process.communicate(timeout=600)
    assert process.returncode == 2, stderr[-3000:]
    assert "Traceback" not in stderr and stdout == ""
    errors = [line for line in stderr.splitlines() if line.startswith("vtrack benchmark: error:")]
    assert len(errors) == 1 and "the episode of FailsInThirdEpisode on" in errors[0], stderr[-3000:]
    assert "seed 2 failed: RuntimeError: the policy failed in its third episode" in errors[0]
    assert "2 of 4 episodes are stored in" in errors[0]
    bar = [line for line in stderr.splitlines() if line.startswith("vtrack benchmark")
           and not line.startswith("vtrack benchmark:")]
    assert bar and "3/4" in bar[-1] and "2 done, 1 failed" in bar[-1], stderr[-3000:]
    rows = ResultStore(tmp_path / "s.sqlite", read_only=True).rows()
    assert sorted(r["seed"] for r in rows) == [0, 1]


def test_rows_are_stored_when_the_reader_of_the_table_goes_away(tmp_path: Path) -> None:
    """``vtrack benchmark ... | head -1``: the table's reader is gone (here before the first line: the pipe's read
    end is closed, the harshest case); every row is stored and the exit status says the pipe closed."""
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        process = _vtrack(tmp_path, *_benchmark(tmp_path, "Steady", workers=1, seeds="0-2"), stdout=write_end)
    finally:
        os.close(write_end)
    _, stderr = process.communicate(timeout=600)
    assert process.returncode == 141, stderr[-3000:]
    assert "Traceback" not in stderr
    rows = ResultStore(tmp_path / "s.sqlite", read_only=True).rows()
    assert sorted(r["seed"] for r in rows) == [0, 1, 2]


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie waiting for its parent is not running
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.parametrize(("sig", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_signal_ends_every_hanging_worker_within_seconds(tmp_path: Path, sig: int, code: int) -> None:
    process = _vtrack(tmp_path, *_benchmark(tmp_path, "Hangs", workers=2), start_new_session=True)
    try:
        marks = tmp_path / "marks"
        deadline = time.monotonic() + 300
        while len(list(marks.glob("worker-*"))) < 2 and time.monotonic() < deadline and process.poll() is None:
            time.sleep(0.2)
        workers = [int(p.name.split("-")[1]) for p in marks.glob("worker-*")]
        assert len(workers) == 2, process.communicate(timeout=10)[1][-3000:]
        sent = time.monotonic()
        process.send_signal(sig)   # to vtrack alone (kill PID), not to its process group
        _, stderr = process.communicate(timeout=30)
        assert time.monotonic() - sent < 10.0
        assert process.returncode == code, stderr[-3000:]
        assert "Traceback" not in stderr
        time.sleep(0.5)
        assert not [pid for pid in workers if _alive(pid)]
    finally:   # a failed run must not leave vtrack or its hanging workers spinning on the machine
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGKILL)
        process.wait(timeout=30)
