"""The documentation's examples are tests: the ```python blocks of each page under docs/ run in order, in one
namespace per page and a temporary working directory. A block is skipped only when the line right before it is
``<!-- docs-test: skip REASON -->``."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"
SKIP_MARK = re.compile(r"<!--\s*docs-test:\s*skip\s+(?P<reason>.*?)\s*-->")
PYTHON_FENCE = re.compile(r"^```python[ \t]*\n(?P<code>.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)
PAGES = sorted(p for p in DOCS.rglob("*.md") if PYTHON_FENCE.search(p.read_text(encoding="utf-8")))


def page_blocks(text: str) -> list[tuple[int, str, str | None]]:
    """``(line, code, skip reason or None)`` of each ```python block of a page, in order."""
    found = []
    for match in PYTHON_FENCE.finditer(text):
        previous = text[: match.start()].rstrip("\n").rsplit("\n", 1)[-1].strip()
        mark = SKIP_MARK.fullmatch(previous)
        found.append((text.count("\n", 0, match.start()) + 1, match.group("code"),
                      mark.group("reason") if mark else None))
    return found


def test_skip_marks_are_read() -> None:
    text = "<!-- docs-test: skip needs a cluster -->\n```python\nraise SystemExit\n```\n```python\nb = 2\n```\n"
    assert [(code, why) for _, code, why in page_blocks(text)] == [("raise SystemExit\n", "needs a cluster"),
                                                                 ("b = 2\n", None)]


def test_the_tutorial_has_examples() -> None:
    assert DOCS / "tutorials" / "evaluate-your-agent.md" in PAGES


@pytest.mark.parametrize("page", PAGES, ids=[str(p.relative_to(DOCS)) for p in PAGES])
def test_page_examples_run(page: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": "__docs__"}
    blocks = page_blocks(page.read_text(encoding="utf-8"))
    assert all(why.strip() for _, _, why in blocks if why is not None), "a skip mark without a reason"
    for line, code, why in blocks:
        if why is None:
            exec(compile(code, f"{page.relative_to(DOCS)}:{line}", "exec"), namespace)
