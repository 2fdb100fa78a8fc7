"""The documentation site builds with ``mkdocs build --strict`` (broken links, missing pages, a failing env-page
generator or API reference are errors), as a user building the docs would run it."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.skipif(shutil.which("mkdocs") is None and not (Path(sys.executable).parent / "mkdocs").exists(),
                    reason="mkdocs is not installed (extra 'docs')")
def test_docs_site_builds_strict(tmp_path: Path) -> None:
    mkdocs = Path(sys.executable).parent / "mkdocs"
    command = [str(mkdocs) if mkdocs.exists() else "mkdocs", "build", "--strict", "-d", str(tmp_path / "site")]
    env = {**os.environ, "PYTHONPATH": str(ROOT), "NO_MKDOCS_2_WARNING": "1", "DISABLE_MKDOCS_2_WARNING": "true"}
    done = subprocess.run(command, cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-4000:]
    site = tmp_path / "site"
    for page in ("index.html", "envs/DLC120-v0/index.html", "envs/TrainingMix20Hz-v0/index.html",
                 "baselines/nmpc/index.html", "api/index.html"):
        assert (site / page).is_file(), page
    assert "Version history" in (site / "envs/ISO3888-2-v0/index.html").read_text(encoding="utf-8")
