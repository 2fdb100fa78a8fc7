"""Release hygiene: the version has one source, the citation and changelog name it, the licence is there, and a
missing PyTorch is explained with the CPU/GPU choice."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest
import yaml

from vtrack_gym._version import __version__

ROOT = Path(__file__).resolve().parents[1]


def test_version_has_one_source() -> None:
    text = (ROOT / "pyproject.toml").read_text()
    assert 'dynamic = ["version"]' in text and 'version = { attr = "vtrack_gym._version.__version__" }' in text
    assert not re.search(r'(?m)^version\s*=\s*"', text)


def test_citation_and_changelog_name_this_version() -> None:
    citation = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert citation["cff-version"] == "1.2.0" and citation["version"] == __version__
    assert citation["license"] == "MIT" and citation["authors"]
    paper = citation["references"][0]
    assert paper["type"] == "article" and paper["title"].startswith("Navigation System Designs Based on Model")
    changelog = (ROOT / "CHANGELOG.md").read_text()
    release = __version__.split(".dev")[0]
    if ".dev" in __version__:   # a development version: its changes are listed as unreleased, after the release before
        assert "## [Unreleased]" in changelog and "keepachangelog.com" in changelog
        assert f"## [{release}]" not in changelog
    else:                       # a release: dated in the changelog, and the citation names the same date
        assert f"## [{release}] - {citation['date-released']}" in changelog and "keepachangelog.com" in changelog
    assert "MIT License" in (ROOT / "LICENSE").read_text()


def test_missing_torch_message_explains_cpu_and_gpu_builds(monkeypatch: pytest.MonkeyPatch) -> None:
    from vtrack_gym.cli import build_parser, train
    from vtrack_gym.cli._extras import missing_packages

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "torch" else real(name, *a))
    args = build_parser().parse_args(["train", "--algo", "ppo", "--run-dir", "x"])
    message = missing_packages(args, train.needed_modules)
    assert 'pip install "vtrack_gym[rl]"' in message
    assert "--index-url https://download.pytorch.org/whl/cpu" in message
    assert "https://pytorch.org/get-started/locally/" in message


def test_package_metadata_is_complete() -> None:
    """What a packager checks: version classifiers from the lowest supported Python, ``Typing :: Typed`` (the
    package ships ``py.typed``), links to the documentation, source, issues and changelog; an "Unreleased"
    section in the changelog; build outputs ignored."""
    tomllib = pytest.importorskip("tomllib")
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    lowest = int(re.fullmatch(r">=3\.(\d+)", project["requires-python"]).group(1))
    classifiers = set(project["classifiers"])
    assert {f"Programming Language :: Python :: 3.{minor}" for minor in range(lowest, 13)} <= classifiers
    assert "Typing :: Typed" in classifiers and (ROOT / "vtrack_gym" / "py.typed").is_file()
    package_data = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]
    assert "py.typed" in package_data["vtrack_gym"]
    urls = project["urls"]
    assert {"Documentation", "Source", "Issues", "Changelog"} <= set(urls)
    assert all(url.startswith("https://") for url in urls.values())
    assert "## [Unreleased]" in (ROOT / "CHANGELOG.md").read_text()
    ignored = (ROOT / ".gitignore").read_text().split()
    assert {"site/", "build/", "dist/", "*.egg-info/"} <= set(ignored)
