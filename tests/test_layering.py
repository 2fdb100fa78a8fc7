"""Architecture: imports flow one way between subpackages, and no module imports itself back through others.

Layers, bottom to top (DESIGN.md section 2): ``vehicle`` and ``tracks`` know nothing of Gymnasium; ``envs`` (with
the PD-FLC speed loop and the registration) uses them; ``interop`` adapts other simulators to the envs' contract;
``baselines`` read observations (scripted controllers, presets, the torch-free weights-only agent);
``evaluation`` and ``tuning`` drive envs and policies; ``agents`` is the only place that imports SB3/torch;
``cli`` sits on top. Every import counts, including the lazy ones inside functions.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE_DIR = Path(__file__).resolve().parents[1] / "vtrack_gym"

LAYER: dict[str, int] = {
    "_version": 0, "_ranges": 0, "_io": 0, "_jit": 0, "_kernel_sources": 0, "_array_views": 0, "_progress": 0,
    "_plugins": 0,
    "vehicle": 1, "tracks": 1,
    "envs": 2,
    "interop": 3,
    "baselines": 4,
    "evaluation": 5, "tuning": 5,
    "agents": 6,
    "cli": 7,
}
"""Subpackage (or top-level module) -> layer. An import may go to a lower layer, or to the same layer
when no cycle results between the two subpackages. The package root (``vtrack_gym/__init__``: registration)
may be imported by ``cli`` only."""


EVALUATION_ORDER: tuple[str, ...] = ("scoring", "identity", "leaderboard", "rollouts", "suite", "storage", "figures",
                                     "benchmarking", "reproduction")
"""The subpackages of ``evaluation`` in import order (``docs/architecture.md``): each imports only those before it;
the modules at the ``evaluation`` root (``api.py``, the Python entry) sit above them all."""


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE_DIR.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_module(name: str) -> bool:
    where = PACKAGE_DIR.parent / Path(*name.split("."))
    return where.with_suffix(".py").is_file() or (where / "__init__.py").is_file()


def _imports(path: Path) -> set[str]:
    """Every ``vtrack_gym`` module ``path`` imports (``from pkg import sub`` counts as ``pkg.sub``)."""
    module = _module_name(path)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            subs = [f"{target}.{a.name}" for a in node.names if _is_module(f"{target}.{a.name}")]
            found.update(subs if subs and len(subs) == len(node.names) else [target, *subs])
    return {m for m in found if m == "vtrack_gym" or m.startswith("vtrack_gym.")}


def _graph() -> dict[str, set[str]]:
    return {_module_name(p): _imports(p) for p in sorted(PACKAGE_DIR.rglob("*.py"))}


def _part(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "<root>"


def test_every_subpackage_has_a_layer():
    parts = {_part(m) for m in _graph()} - {"<root>"}
    assert parts <= set(LAYER), f"give these a layer in LAYER: {sorted(parts - set(LAYER))}"


def test_no_upward_import():
    upward = []
    for module, targets in _graph().items():
        src = _part(module)
        for target in targets:
            dst = _part(target)
            if src == dst or src == "<root>":
                continue
            if dst == "<root>" and src != "cli":
                upward.append(f"{module} -> {target} (the package root registers envs; import a submodule)")
            elif dst != "<root>" and LAYER[dst] > LAYER[src]:
                upward.append(f"{module} (layer {LAYER[src]}) -> {target} (layer {LAYER[dst]})")
    assert not upward, "upward imports:\n" + "\n".join(sorted(upward))


def _evaluation_part(module: str) -> str | None:
    """The ``evaluation`` subpackage of ``module`` (``<root>`` for a module at the package's root; None outside)."""
    parts = module.split(".")
    if parts[:2] != ["vtrack_gym", "evaluation"] or len(parts) < 3:
        return None
    return parts[2] if len(parts) > 3 or (PACKAGE_DIR / "evaluation" / parts[2] / "__init__.py").is_file() \
        else "<root>"


def test_evaluation_subpackages_import_downward():
    rank = {name: i for i, name in enumerate(EVALUATION_ORDER)} | {"<root>": len(EVALUATION_ORDER)}
    found = {p.parent.name for p in (PACKAGE_DIR / "evaluation").glob("*/__init__.py")}
    assert found == set(EVALUATION_ORDER), f"list every evaluation subpackage once in EVALUATION_ORDER: {sorted(found)}"
    upward = []
    for module, targets in _graph().items():
        src = _evaluation_part(module)
        for dst, target in ((_evaluation_part(t), t) for t in targets):
            if src is not None and dst is not None and src != dst and rank[dst] > rank[src]:
                upward.append(f"{module} ({src}) -> {target} ({dst})")
    assert not upward, "evaluation imports against EVALUATION_ORDER:\n" + "\n".join(sorted(upward))


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one node (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    counter = 0
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph.get(root, ()))))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_no_cycle_between_subpackages():
    graph: dict[str, set[str]] = {}
    for module, targets in _graph().items():
        graph.setdefault(_part(module), set()).update(_part(t) for t in targets if _part(t) != _part(module))
    assert not _cycles(graph), f"subpackage cycles: {_cycles(graph)}"


def test_no_cycle_between_modules():
    """Package ``__init__`` files are facades that re-export their modules; edges into them are skipped."""
    graph = {m: {t for t in ts if not (PACKAGE_DIR.parent / Path(*t.split(".")) / "__init__.py").is_file()}
             for m, ts in _graph().items()}
    assert not _cycles(graph), f"module cycles: {_cycles(graph)}"


@pytest.mark.parametrize("bad", [{"a": {"b"}, "b": {"a"}}, {"a": {"b"}, "b": {"c"}, "c": {"a"}}])
def test_cycle_finder_finds_cycles(bad):
    assert _cycles(bad) and not _cycles({"a": {"b"}, "b": {"c"}})
