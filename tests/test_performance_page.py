"""benchmarks/performance_page.py: its table shows ranges over the rounds, ratios of the same round, the load
average beside each figure and marks the wall-clock figures that need free cores; the kept section survives."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from performance_page import KEPT_SECTION, Rate, Row, fmt, page, table_line


def _row(threaded: bool, peer: bool, lower: bool = False, unit: str = "steps/s") -> Row:
    row = Row("thing", unit, lambda: Rate(0, 0, 0), "peer", (lambda: Rate(0, 0, 0)) if peer else None,
              threaded=threaded, lower_is_better=lower)
    row.results = [(Rate(2000.0, 1000.0, 1.0), Rate(100.0, 100.0, 2.0) if peer else None),
                   (Rate(3000.0, 1500.0, 3.5), Rate(100.0, 100.0, 1.5) if peer else None)]
    return row


def test_a_row_gives_ranges_same_round_ratios_and_the_load() -> None:
    assert table_line(_row(False, True)) == "| thing | 2.5k (2k-3k) | peer 100 | 25x (20x-30x) | 1.0-3.5 |"


def test_a_threaded_row_marks_its_wall_figure() -> None:
    assert table_line(_row(True, False)) == ("| thing | 2.5k (2k-3k); wall 1.25k (1k-1.5k) (needs free cores) | | | "
                                             "1.0-3.5 |")


def test_seconds_compare_the_peer_over_ours() -> None:
    line = table_line(_row(False, True, lower=True, unit="s"))
    assert "2500.00 s (2000.00 s-3000.00 s)" in line and "0.042x (0.033x-0.05x)" in line


def test_the_page_keeps_the_worker_section() -> None:
    text = page([_row(False, True)], 3, 0.5, f"{KEPT_SECTION}\n\nkept text\n")
    assert text.startswith("# Performance") and text.endswith(f"{KEPT_SECTION}\n\nkept text\n")
    assert "--rounds 3 --seconds 0.5" in text and fmt(1.08e6, "steps/s") == "1.08M"
