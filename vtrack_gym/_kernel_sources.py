"""Which source files the compiled kernels depend on: the files whose edit must recompile them, and no others.

A static scan (``ast``, nothing imported). Compiled code is a function decorated with ``@kernel`` (or
``@kernel(...)``), a function passed to ``kernel(...)`` at a module's top level, and every function such code
names. What it depends on:

- its own module (the whole file);
- the package modules it takes names from: a name read inside compiled code, or by the definition of a global
  that compiled code reads (globals such as layout indices are frozen into the machine code), that comes from a
  top-level ``from vtrack_gym... import`` (or ``import vtrack_gym... as``) line;
- in such a module, again the definitions of the names taken from it, and so on.

Names read only by ordinary functions (a policy's ``predict``, a lazy import inside a helper), by a class's methods,
by annotations or by top-level statements that define nothing compiled code reads (a registration call) do not
count: editing ``evaluation/figures/plots.py``, ``baselines/mpc.py`` or a registry line leaves the kernels' cache valid.
A top-level statement that changes a global in place (``TABLE[0] = ...``) is not followed: define globals in one
assignment.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from pathlib import Path

__all__ = ["kernel_sources"]

KERNEL_DECORATOR = "kernel"
"""The name of the compiling decorator (``vtrack_gym._jit.kernel``)."""
_MENTIONS_KERNEL = re.compile(rf"^[ \t]*@{KERNEL_DECORATOR}\b|(?<![\w.]){KERNEL_DECORATOR}\(", re.MULTILINE)
"""Text every module that compiles a function contains: only those files, and what they lead to, are parsed."""


ALL = "*"
"""A root that stands for every top-level name of a module (the module itself was imported, ``import ... as m``)."""


@dataclass(frozen=True)
class _Module:
    """The parts of one parsed module the scan needs."""

    imports: dict[str, tuple[str, str | None]]
    """Local name -> (module, attribute or None) for the top-level package imports."""
    defs: dict[str, frozenset[str]]
    """Top-level name -> the names its defining statements read (a function: its whole body)."""
    compiled: frozenset[str]
    """Top-level functions compiled in this module (decorated, or passed to ``kernel``)."""


def _is_kernel_call(node: ast.AST) -> bool:
    """``kernel`` or ``kernel(...)`` (a decorator or a call)."""
    target = node.func if isinstance(node, ast.Call) else node
    return isinstance(target, ast.Name) and target.id == KERNEL_DECORATOR


def _names(node: ast.AST | None) -> set[str]:
    """Names read under ``node``, annotations excluded."""
    if node is None:
        return set()
    found: set[str] = set()
    stack = [node]
    while stack:
        current = stack.pop()
        if isinstance(current, ast.Name) and isinstance(current.ctx, ast.Load):
            found.add(current.id)
        for name, child in ast.iter_fields(current):
            if name in ("annotation", "returns"):
                continue
            stack.extend(c for c in (child if isinstance(child, list) else [child]) if isinstance(c, ast.AST))
    return found


def _defs(tree: ast.Module) -> dict[str, set[str]]:
    """Top-level name -> names read where it is defined: a function's decorators, defaults and body; a class's
    bases, decorators and the values assigned in its body (not its methods); an assignment's value; any other
    statement (``if``, ``for``, ``try``) reads all it contains for every name it binds."""
    defs: dict[str, set[str]] = {}
    for stmt in tree.body:
        if isinstance(stmt, (ast.FunctionDef, ast.AsyncFunctionDef)):
            bound, read = [stmt.name], _names(stmt)
        elif isinstance(stmt, ast.ClassDef):
            values = [s.value for s in stmt.body if isinstance(s, (ast.Assign, ast.AnnAssign))]
            bound, read = [stmt.name], set().union(*map(_names, (*stmt.bases, *stmt.decorator_list, *values)))
        elif isinstance(stmt, (ast.Import, ast.ImportFrom)):
            continue
        else:
            bound = [n.id for n in ast.walk(stmt) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store)]
            read = _names(stmt.value) if isinstance(stmt, (ast.Assign, ast.AnnAssign, ast.AugAssign)) else _names(stmt)
        for name in bound:
            defs.setdefault(name, set()).update(read)
    return defs


def _imports(tree: ast.Module, package: str, is_module: Callable[[str], bool]) -> dict[str, tuple[str, str | None]]:
    """Local name -> (module, attribute) for the top-level imports from ``package``."""
    found: dict[str, tuple[str, str | None]] = {}
    for stmt in tree.body:
        if isinstance(stmt, ast.ImportFrom) and (stmt.module or "").split(".")[0] == package and not stmt.level:
            for alias in stmt.names:
                sub = f"{stmt.module}.{alias.name}"
                found[alias.asname or alias.name] = (sub, None) if is_module(sub) else (stmt.module, alias.name)
        elif isinstance(stmt, ast.Import):
            for alias in stmt.names:
                if alias.name.split(".")[0] == package and alias.asname:
                    found[alias.asname] = (alias.name, None)
    return found


def _parse(path: Path, package: str, is_module: Callable[[str], bool]) -> _Module:
    """The parts of the module at ``path`` the scan needs."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    compiled = {s.name for s in tree.body if isinstance(s, (ast.FunctionDef, ast.AsyncFunctionDef))
                and any(_is_kernel_call(d) for d in s.decorator_list)}
    for stmt in tree.body:  # name = kernel(function) or kernel(options)(function), at the top level
        call = stmt.value if isinstance(stmt, (ast.Assign, ast.Expr)) else None
        if isinstance(call, ast.Call) and (_is_kernel_call(call) or _is_kernel_call(call.func)):
            compiled |= {a.id for a in call.args if isinstance(a, ast.Name)}
    defs = {name: frozenset(read) for name, read in _defs(tree).items()}
    return _Module(_imports(tree, package, is_module), defs, frozenset(compiled))


def _read(module: _Module, roots: set[str]) -> set[str]:
    """The names ``roots`` depend on in ``module`` (themselves included), following its top-level definitions."""
    pending = list(module.defs) if ALL in roots else list(roots)
    done: set[str] = set()
    while pending:
        name = pending.pop()
        if name not in done:
            done.add(name)
            pending.extend(module.defs.get(name, ()))
    return done


@cache
def kernel_sources(package_dir: Path) -> tuple[Path, ...]:
    """The source files the compiled kernels under ``package_dir`` depend on (see the module docstring), sorted."""
    package = package_dir.name

    def file_of(dotted: str) -> Path | None:
        base = package_dir.joinpath(*dotted.split(".")[1:])
        return next((p for p in (base.with_suffix(".py"), base / "__init__.py") if p.is_file()), None)

    def is_module(dotted: str) -> bool:
        return file_of(dotted) is not None

    parsed: dict[Path, _Module] = {}

    def module_at(path: Path) -> _Module:
        if path not in parsed:
            parsed[path] = _parse(path, package, is_module)
        return parsed[path]

    candidates = [p for p in sorted(package_dir.rglob("*.py"))
                  if _MENTIONS_KERNEL.search(p.read_text(encoding="utf-8"))]
    wanted: dict[Path, set[str]] = {p: set(module_at(p).compiled) for p in candidates if module_at(p).compiled}
    expanded: dict[Path, set[str]] = {}
    while True:
        todo = [(p, roots) for p, roots in wanted.items() if expanded.get(p) != roots]
        if not todo:
            return tuple(sorted(wanted))
        for path, roots in todo:
            expanded[path] = set(roots)
            module = module_at(path)
            for name in _read(module, roots | set(module.compiled)):
                target = module.imports.get(name)
                found = file_of(target[0]) if target else None
                if found is not None:
                    wanted.setdefault(found, set()).add(target[1] or ALL)
