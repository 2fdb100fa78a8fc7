"""`vtrack reproduce --quick`: the report has every claim row and the corrections, and is byte-stable."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from vtrack_gym.evaluation.reproduction.reproduce import CLAIMS, CORRECTIONS, PAIRS, TIMESTAMP_PREFIX


def _run(out: Path) -> bytes:
    proc = subprocess.run([sys.executable, "-m", "vtrack_gym.cli", "reproduce", "--quick", "--out", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    return (out / "REPRODUCTION.md").read_bytes()


def _without_timestamp(data: bytes) -> list[bytes]:
    return [line for line in data.splitlines() if not line.startswith(TIMESTAMP_PREFIX.encode())]


@pytest.fixture(scope="module")
def one_run(tmp_path_factory) -> tuple[bytes, Path]:
    a = tmp_path_factory.mktemp("repro_a")
    return _run(a), a


def test_report_has_every_claim_row_and_corrections(one_run) -> None:
    text = one_run[0].decode("utf-8")
    assert text.count(f"\n{TIMESTAMP_PREFIX}") == 1
    rows = [line for line in text.splitlines() if line.startswith("| 1 |") or line.startswith("| 2 |")]
    assert len(rows) == len(CLAIMS) * len(PAIRS)
    for claim in CLAIMS:
        mine = [r for r in rows if f"| {claim.text} |" in r]
        assert len(mine) == len(PAIRS), claim.text
        for r in mine:
            assert any(f"**{v}**" in r for v in ("yes", "no", "not comparable")), r
    paper_claims = ("about 15 % lower", "nearly 10 % lower", "below 5 % apart", "below 1 % apart", "SMC 15 % lower",
                    "MPC below 200 deg, SMC over 500 deg", "MPC below 0.7 g, SMC above 0.85 g",
                    "SMC lower on max hand-wheel", "about 20 % lower", "below 0.25 m", "0.81 g", "below 4 deg")
    for phrase in paper_claims:
        assert phrase in text, phrase
    assert "## Errors in the paper that the implementation corrects" in text
    for head, _ in CORRECTIONS:
        assert f"**{head}.**" in text
    for word in ("Eq. (7)", "Eq. (9)", "Eq. (24)", "Eq. (40)", "singular", "Boundary layer", "PD-FLC", "x2"):
        assert word in text, word
    assert "the shipped GA presets" in text and "mpc_tuned.json" in text


def test_report_is_deterministic_apart_from_timestamp(one_run, tmp_path: Path) -> None:
    first, second = one_run[0], _run(tmp_path)
    assert _without_timestamp(first) == _without_timestamp(second)


def test_figures_written(one_run) -> None:
    figs = sorted((one_run[1] / "reproduction").glob("*.png"))
    names = " ".join(f.name for f in figs)
    for fig in ("fig08", "fig09-12", "fig13", "fig15", "fig16-18", "fig19"):
        assert fig in names, fig
    assert len(figs) == 6 * len(PAIRS)
