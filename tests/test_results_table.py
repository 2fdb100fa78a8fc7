"""The results table of the README (and of the docs pages that show it) is what ``vtrack benchmark`` prints."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
HEADER = "| env_id | policy_id | rank | success_rate | max_e_y_m | rms_e_y_m | failure_reasons |"
PAGES = ("README.md", "docs/index.md", "docs/benchmark.md")


def first_table(text: str) -> list[str]:
    """The lines of the first markdown table of ``text`` that starts with ``HEADER``."""
    lines = text.splitlines()
    start = lines.index(HEADER)
    end = next((k for k in range(start, len(lines)) if not lines[k].startswith("|")), len(lines))
    return lines[start:end]


@pytest.mark.slow
def test_the_published_results_table_is_what_vtrack_benchmark_prints(tmp_path: Path) -> None:
    done = subprocess.run([sys.executable, "-m", "vtrack_gym.cli", "benchmark", "--no-figures",
                           "--store", str(tmp_path / "board.sqlite")], capture_output=True, text=True, cwd=tmp_path,
                          timeout=1800)
    assert done.returncode == 0, done.stderr[-3000:]
    printed = [line for line in done.stdout.splitlines() if line.startswith("|")]
    assert printed[0] == HEADER
    for page in PAGES:
        assert first_table((ROOT / page).read_text(encoding="utf-8")) == printed, f"{page}: rerun vtrack benchmark"
