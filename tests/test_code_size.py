"""Size limits of the package's code: no function over 100 lines, no class over 350, no module over 600.

Small units are what a contributor reading the code for the first time can hold in their head; a unit that grows
past these limits is split (by its phases or its concepts), not exempted.
"""

from __future__ import annotations

import ast
from pathlib import Path

import vtrack_gym

PACKAGE = Path(vtrack_gym.__file__).parent
MAX_FUNCTION_LINES = 100
MAX_CLASS_LINES = 350
MAX_MODULE_LINES = 600


def _sources() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


def _span(node: ast.AST) -> int:
    return node.end_lineno - node.lineno + 1  # type: ignore[attr-defined]


def test_modules_are_small() -> None:
    too_long = {str(p.relative_to(PACKAGE)): n for p in _sources()
                if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES}
    assert not too_long, f"modules over {MAX_MODULE_LINES} lines: {too_long}"


def test_functions_and_classes_are_small() -> None:
    too_long: list[str] = []
    for path in _sources():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and _span(node) > MAX_FUNCTION_LINES:
                too_long.append(f"{path.relative_to(PACKAGE)}:{node.lineno} def {node.name} ({_span(node)} lines)")
            elif isinstance(node, ast.ClassDef) and _span(node) > MAX_CLASS_LINES:
                too_long.append(f"{path.relative_to(PACKAGE)}:{node.lineno} class {node.name} ({_span(node)} lines)")
    assert not too_long, "units over the limits (functions 100, classes 350 lines):\n" + "\n".join(too_long)


def test_the_limits_see_the_package() -> None:
    """The walk reads the installed package's own sources (a guard against a vacuous pass)."""
    assert len(_sources()) > 50
