"""The ``vtrack`` command ends quietly and never lets data drive the terminal.

SIGPIPE (``vtrack leaderboard | head -1``) exits 141 and Ctrl-C exits 130, each without a traceback; control
characters, ANSI escapes, bidi controls and zero-width characters from a store or a file name are shown escaped
(``vtrack_gym.cli._terminal.terminal_safe``, the one function every line goes through).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from interactive import as_in_a_terminal

from vtrack_gym.cli import main
from vtrack_gym.cli._terminal import terminal_safe
from vtrack_gym.evaluation.storage.store import ResultRow, ResultStore

ROOT = Path(__file__).resolve().parents[1]
HOSTILE = "evil\x1b[2J\x1b]0;owned\x07\u202eright\u200bzw\x9bend"
"""An id with a screen clear, a window-title OSC, a right-to-left override, a zero-width space and C1 CSI."""
UNSAFE_CHARS = ("\x1b", "\x07", "\u202e", "\u200b", "\x9b")


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(ROOT)}


def _store(path: Path, policy_id: str = "p", suite: str = "paper", n: int = 1) -> Path:
    rows = [ResultRow(suite, "DLC120-v0", f"{policy_id}{k}", f"h{k}", 0, {"max_e_y_m": 0.1 + k, "rms_e_y_m": 0.01,
                                                                       "cones_hit": 0.0}, "completed", 1e-5)
            for k in range(n)]
    ResultStore(path).add(rows)
    return path


def test_terminal_safe_escapes_exactly_the_unsafe_characters() -> None:
    assert terminal_safe("a\tb\nc | d é 中") == "a\tb\nc | d é 中"  # layout and printable text kept
    shown = terminal_safe(HOSTILE)
    assert not any(c in shown for c in UNSAFE_CHARS)
    assert "\\x1b[2J" in shown and "\\u202e" in shown and "\\u200b" in shown and "\\x9b" in shown
    for ch in ("\r", "\x00", "\x7f", "\u2028", "\u2066", "\ufeff", "\u061c"):
        assert ch not in terminal_safe(f"x{ch}y")


def test_leaderboard_into_a_closed_pipe_exits_141_without_traceback(tmp_path: Path) -> None:
    store = _store(tmp_path / "s.sqlite", n=3000)  # a board several times longer than a 64 KiB pipe buffer
    proc = subprocess.Popen([sys.executable, "-m", "vtrack_gym.cli", "leaderboard", "--store", str(store),
                             "--format", "csv"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=_env())
    assert proc.stdout is not None and proc.stderr is not None
    first = proc.stdout.readline()  # like `head -1`: read one line, then go away
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 141, err
    assert first.startswith(b"env_id,policy_id")
    assert "Traceback" not in err and "BrokenPipeError" not in err and "Exception ignored" not in err


def test_shell_pipe_to_head(tmp_path: Path) -> None:
    store = _store(tmp_path / "s.sqlite", n=3000)  # 287 KB: several times a 64 KiB pipe buffer
    script = (f"{sys.executable} -m vtrack_gym.cli leaderboard --store {store} --format csv 2>{tmp_path / 'err'} "
              "| head -1; echo \"exit ${PIPESTATUS[0]}\"")
    out = subprocess.run(["bash", "-c", script], capture_output=True, text=True, env=_env(), timeout=120).stdout
    assert out.splitlines()[0].startswith("env_id,policy_id") and out.splitlines()[-1] == "exit 141"
    assert "Traceback" not in (tmp_path / "err").read_text()


def test_ctrl_c_in_process_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                       monkeypatch: pytest.MonkeyPatch) -> None:
    from vtrack_gym.cli import leaderboard

    def interrupted(args: object) -> int:
        raise KeyboardInterrupt

    monkeypatch.setattr(leaderboard, "run", interrupted)
    assert main(["leaderboard", "--store", str(_store(tmp_path / "s.sqlite"))]) == 130
    err = capsys.readouterr().err
    assert err.strip().splitlines() == ["vtrack: interrupted (Ctrl-C)"]


def test_sigint_during_a_run_exits_130_without_traceback(tmp_path: Path) -> None:
    argv = [sys.executable, "-m", "vtrack_gym.cli", "-v", "eval", "--policy", "lqr", "--env", "LateralTracking-v0",
            "--seeds", "0-999", "--store", str(tmp_path / "s.sqlite")]
    proc = subprocess.Popen(as_in_a_terminal(argv), stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=_env())
    assert proc.stderr is not None
    proc.stderr.readline()  # the command is running (it announced the kernels)
    time.sleep(1.0)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    text = err.decode()
    assert proc.returncode == 130, text
    assert "Traceback" not in text and text.strip().splitlines()[-1] == "vtrack: interrupted (Ctrl-C)"


COUNT_EPISODES = """\
import os
from vtrack_gym.evaluation.rollouts import parallel

_run_task = parallel.run_task


def _counted(task):
    result = _run_task(task)
    with open(os.environ["EPISODE_LOG"], "a") as log:
        log.write("episode\\n")
    return result


parallel.run_task = _counted
"""


def test_sigint_during_a_forked_run_drops_the_queued_episodes(tmp_path: Path) -> None:
    """Ctrl-C in a run on worker processes ends after the episodes already running, not after the whole queue
    (200 episodes here; the workers count theirs in a file)."""
    (tmp_path / "sitecustomize.py").write_text(COUNT_EPISODES)
    episodes = tmp_path / "episodes.txt"
    env = {**_env(), "PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT)]), "EPISODE_LOG": str(episodes)}
    argv = [sys.executable, "-m", "vtrack_gym.cli", "-v", "benchmark", "--policies", "lqr", "--no-figures",
            "--seeds", "0-99", "--workers", "2", "--store", str(tmp_path / "s.sqlite")]
    proc = subprocess.Popen(as_in_a_terminal(argv), stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    assert proc.stderr is not None
    for line in proc.stderr:  # wait until the first episode's result is back
        if b": completed" in line:
            break
    proc.send_signal(signal.SIGINT)
    proc.communicate(timeout=300)
    assert proc.returncode == 130
    # the few done before the signal, 2 running and 3 handed to the workers' queue at most after it
    assert len(episodes.read_text().splitlines()) <= 12


INTERRUPT_IN_EXEC = """\
from vtrack_gym.cli import leaderboard


def _interrupted(args):
    exec("raise KeyboardInterrupt")  # as when Ctrl-C lands in a Cython module's init: code run by PyRun_String


leaderboard.run = _interrupted
"""


@pytest.mark.parametrize("entry", ["module", "script"])
def test_ctrl_c_inside_extension_code_still_exits_130(tmp_path: Path, entry: str) -> None:
    """A KeyboardInterrupt that passed through code an extension ran by ``PyRun_String`` leaves CPython's
    process-wide "unhandled Ctrl-C" flag set; the command still exits 130, under ``python -m`` and as the script."""
    (tmp_path / "sitecustomize.py").write_text(INTERRUPT_IN_EXEC)
    env = {**_env(), "PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT)])}
    args = ["leaderboard", "--store", str(_store(tmp_path / "s.sqlite"))]
    if entry == "module":
        argv = [sys.executable, "-m", "vtrack_gym.cli", *args]
    else:
        argv = [sys.executable, "-c", "import sys; from vtrack_gym.cli import main; sys.exit(main())", *args]
    proc = subprocess.run(argv, capture_output=True, text=True, env=env, timeout=120)
    assert proc.returncode == 130, proc.stderr
    assert proc.stderr.strip().splitlines() == ["vtrack: interrupted (Ctrl-C)"]


def test_store_strings_are_escaped_on_stdout_and_stderr(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A store refuses terminal-unsafe text on write (so none reaches a board); text the user types that is echoed
    back (an unknown suite) is escaped."""
    with pytest.raises(ValueError, match="control, format or separator characters"):
        _store(tmp_path / "hostile.sqlite", policy_id=HOSTILE)
    store = _store(tmp_path / "s.sqlite", policy_id="evil-right")
    for fmt in ("md", "csv", "json", "latex"):
        assert main(["leaderboard", "--store", str(store), "--format", fmt]) == 0
        captured = capsys.readouterr()
        assert "evil-right" in captured.out, fmt
    assert main(["leaderboard", "--store", str(store), "--suite", f"nope{HOSTILE}"]) == 2
    err = capsys.readouterr().err
    assert "no suite" in err and "\\x1b" in err and not any(c in err for c in UNSAFE_CHARS)


def test_file_names_and_argparse_errors_are_escaped(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["leaderboard", "--store", str(tmp_path / f"m{HOSTILE}.sqlite")]) == 2
    err = capsys.readouterr().err
    assert "no store at" in err and not any(c in err for c in UNSAFE_CHARS)
    with pytest.raises(SystemExit):
        main(["leaderboard", "--format", f"md{HOSTILE}"])  # argparse echoes the invalid choice
    err = capsys.readouterr().err
    assert "invalid choice" in err and not any(c in err for c in UNSAFE_CHARS)
    assert main(["eval", "--policy", HOSTILE, "--env", "DLC120-v0", "--store", str(tmp_path / "s.sqlite")]) == 2
    err = capsys.readouterr().err
    assert "unknown policy" in err and not any(c in err for c in UNSAFE_CHARS)


def test_log_lines_and_warnings_are_escaped_in_a_real_process(tmp_path: Path) -> None:
    track = tmp_path / f"t{HOSTILE}.csv"
    track.write_text("x_m,y_m\n" + "".join(f"{x},{0.0}\n" for x in range(0, 400, 5)), encoding="utf-8")
    proc = subprocess.run([sys.executable, "-m", "vtrack_gym.cli", "-v", "eval", "--policy", "lqr", "--track",
                           str(track), "--store", str(tmp_path / "s.sqlite")], capture_output=True, text=True,
                          env=_env(), timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "\\x1b[2J" in proc.stderr, proc.stderr  # the file name is shown, escaped ...
    assert not any(c in proc.stderr + proc.stdout for c in UNSAFE_CHARS)  # ... in every line
