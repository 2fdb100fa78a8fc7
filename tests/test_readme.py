"""README examples are tests: every ```python block of README.md runs, each in a fresh namespace and a temporary
working directory. A block is skipped only when the line right before it is ``<!-- readme-test: skip REASON -->``;
the reasons are listed by ``test_readme_skips_have_reasons``."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
SKIP = re.compile(r"<!--\s*readme-test:\s*skip\s+(?P<reason>.*?)\s*-->")
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


BLOCKS = python_blocks(README.read_text(encoding="utf-8"))


def test_block_finder_sees_skips():
    text = "x\n<!-- readme-test: skip needs a GPU -->\n```python\nraise SystemExit\n```\n\n```python\na = 1\n```\n"
    assert [(code, reason) for _, code, reason in python_blocks(text)] == [("raise SystemExit\n", "needs a GPU"),
                                                                         ("a = 1\n", None)]


def test_readme_has_python_blocks():
    assert len(BLOCKS) >= 1  # the example; the tutorials' blocks run in tests/test_docs.py


def test_readme_skips_have_reasons():
    """Every skipped block, with its reason (printed with -rA / -s)."""
    skipped = [(line, reason) for line, _, reason in BLOCKS if reason is not None]
    for line, reason in skipped:
        print(f"README.md:{line}: skipped: {reason}")
    assert all(reason.strip() for _, reason in skipped)


def _run(code: str, line: int) -> str:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, f"README.md:{line}", "exec"), {"__name__": "__readme__"})
    return out.getvalue()


@pytest.mark.parametrize(("line", "code", "reason"), BLOCKS, ids=[f"line{b[0]}" for b in BLOCKS])
def test_readme_block_runs(line, code, reason, tmp_path, monkeypatch):
    if reason is not None:
        pytest.skip(f"README.md:{line}: {reason}")
    monkeypatch.chdir(tmp_path)
    printed = _run(code, line)
    if 'make_policy("mpc", env)' in code and 'gym.make("DLC120-v0")' in code:  # the "Use it" example
        assert printed.split()[0] == "completed", printed
