"""The HTML leaderboard report in a real headless Chromium (Debian's ``chromium``; skipped where absent):
no console messages (errors, CSP violations), the table is on the screenshot, and the header click sorts."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from vtrack_gym.cli import main
from vtrack_gym.evaluation.storage.store import ResultRow, ResultStore

CHROMIUM = next((p for p in map(shutil.which, ("chromium", "chromium-browser", "google-chrome")) if p), None)
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="no chromium installed (apt-get install chromium)")
HEADER_RGB = (0xDD, 0xE4, 0xF0)  # th background in html_report._STYLE


def _chromium(page: Path, workdir: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    assert CHROMIUM is not None
    return subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                           "--enable-logging=stderr", "--v=0", f"--user-data-dir={workdir / 'profile'}",
                           "--window-size=1200,900", *extra, page.as_uri()],
                          capture_output=True, text=True, timeout=120, check=False)


def _console(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if ":CONSOLE" in line]


@pytest.fixture
def report(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> Path:
    image = pytest.importorskip("PIL.Image")
    store = ResultStore(tmp_path / "s.sqlite")
    store.add([ResultRow("paper", "DLC120-v0", pid, "h" + pid, s, {"max_e_y_m": e_y, "itae": float("nan")},
                         "completed", 1e-5, options={"figures": "paper/run"})
               for pid, e_y in (("mpc", 0.3), ("smc", 0.1), ("<b>x</b>|y", 0.2)) for s in range(2)])
    figures = tmp_path / "figs"
    (figures / "paper" / "run").mkdir(parents=True)
    image.new("RGB", (300, 120), (30, 120, 200)).save(figures / "paper" / "run" / "dlc_trajectories.png")
    out = tmp_path / "board.html"
    assert main(["leaderboard", "--store", str(tmp_path / "s.sqlite"), "--format", "html", "--out", str(out),
                 "--figures", str(figures)]) == 0
    capsys.readouterr()
    return out


def test_console_probe_is_seen(tmp_path: Path) -> None:
    """Positive control: the console check below does see a script error."""
    bad = tmp_path / "bad.html"
    bad.write_text("<!DOCTYPE html><html><body><script>throw new Error('probe-19');</script></body></html>")
    assert any("probe-19" in line for line in _console(_chromium(bad, tmp_path, "--dump-dom").stderr))


def test_report_renders_without_console_messages(report: Path, tmp_path: Path) -> None:
    image = pytest.importorskip("PIL.Image")
    shot = tmp_path / "shot.png"
    proc = _chromium(report, tmp_path, f"--screenshot={shot}")
    assert shot.is_file(), proc.stderr[-2000:]
    assert _console(proc.stderr) == []
    pixels = list(image.open(shot).convert("RGB").getdata())
    header = sum(p == HEADER_RGB for p in pixels)
    figure = sum(p == (30, 120, 200) for p in pixels)
    dark = sum(max(p) < 80 for p in pixels)
    assert header > 2000, "the table header is not on the screenshot"
    assert figure > 10000, "the embedded figure is not on the screenshot"
    assert dark > 500, "no text on the screenshot"


def test_header_click_sorts_rows(report: Path, tmp_path: Path) -> None:
    html = report.read_text(encoding="utf-8")
    probe = ("<script>var th = document.querySelectorAll('#board th');"
             "for (var i = 0; i < th.length; i++) { if (th[i].textContent === 'max_e_y_m') { th[i].click(); } }"
             "</script></body>")
    clicked = tmp_path / "clicked.html"
    clicked.write_text(html.replace("</body>", probe), encoding="utf-8")
    proc = _chromium(clicked, tmp_path, "--dump-dom")
    assert _console(proc.stderr) == []
    rows = re.findall(r"<tr><td>DLC120-v0</td><td>(.*?)</td>", proc.stdout)
    assert rows == ["smc", "&lt;b&gt;x&lt;/b&gt;|y", "mpc"], rows  # ascending max_e_y_m: 0.1, 0.2, 0.3
