"""Documentation examples are tests: every ```python block of the docs site (docs/**/*.md) runs, each in a fresh
namespace and a temporary working directory, exactly as tests/test_readme.py runs the README's. A block is
skipped only when the line right before it is ``<!-- docs-test: skip REASON -->`` (reasons are listed by
``test_docs_skips_have_reasons``)."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"
SKIP = re.compile(r"<!--\s*docs-test:\s*skip\s+(?P<reason>.*?)\s*-->")
FENCE = re.compile(r"^```python[ \t]*\n(?P<code>.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)


def python_blocks(text: str) -> list[tuple[int, str, str | None]]:
    """``(line number, code, skip reason or None)`` of every ```python block of ``text``."""
    blocks = []
    for match in FENCE.finditer(text):
        line = text.count("\n", 0, match.start()) + 1
        before = text[: match.start()].rstrip("\n").rsplit("\n", 1)[-1]
        skip = SKIP.fullmatch(before.strip())
        blocks.append((line, match.group("code"), skip.group("reason") if skip else None))
    return blocks


def _all_blocks() -> list[tuple[str, int, str, str | None]]:
    if not DOCS.is_dir():
        return []
    return [(str(page.relative_to(DOCS)), line, code, reason)
            for page in sorted(DOCS.rglob("*.md"))
            for line, code, reason in python_blocks(page.read_text(encoding="utf-8"))]


BLOCKS = _all_blocks()


def test_docs_have_python_blocks() -> None:
    assert len(BLOCKS) >= 5


def test_docs_skips_have_reasons() -> None:
    for page, line, _, reason in BLOCKS:
        if reason is not None:
            print(f"docs/{page}:{line}: skipped: {reason}")
            assert reason.strip()


@pytest.mark.parametrize(("page", "line", "code", "reason"), BLOCKS, ids=[f"{b[0]}:{b[1]}" for b in BLOCKS])
def test_docs_block_runs(page: str, line: int, code: str, reason: str | None, tmp_path, monkeypatch) -> None:
    if reason is not None:
        pytest.skip(f"docs/{page}:{line}: {reason}")
    monkeypatch.chdir(tmp_path)
    with contextlib.redirect_stdout(io.StringIO()):
        exec(compile(code, f"docs/{page}:{line}", "exec"), {"__name__": "__docs__"})
