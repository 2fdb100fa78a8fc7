"""Entry points of installed packages: how a suite or a policy written outside the package reaches every command.

A registry calls ``load_group(group, register, seen)`` before it lists its names: each entry point of ``group`` not
in ``seen`` is loaded once per process and handed to ``register`` (which checks its type and returns the name it
was registered under); ``seen`` maps ``"name=value"`` of each loaded entry point to that name, and remembers the
import path it last scanned (a registry's lookups cost nothing until ``sys.path`` changes).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

_SCANNED = "\0import path scanned"
"""Key of ``seen`` holding the import path the group was last scanned on."""


def load_group(group: str, register: Callable[[Any, str], str], seen: dict[str, str]) -> None:
    """Load every entry point of ``group`` not in ``seen`` and register it (``register(obj, where)``, ``where``
    naming the entry point for error messages)."""
    import sys
    from importlib.metadata import entry_points

    where = repr(sys.path)  # installed packages are found on the import path: scanned again only when it changes
    if seen.get(_SCANNED) == where:
        return
    for ep in entry_points(group=group):
        key = f"{ep.name}={ep.value}"
        if key not in seen:
            seen[key] = register(ep.load(), f"entry point {ep.name} = {ep.value} of group {group}")
    seen[_SCANNED] = where


def add_named(table: dict[str, Any], name: str, item: Any, kind: type, what: str, replace: bool = False) -> Any:
    """Put ``item`` (an instance of ``kind``) into the registry ``table`` under ``name``; ``ValueError`` for another
    type, or for a name taken by another item unless ``replace``. ``what`` names the item in errors (``suite``).
    Returns ``item``."""
    if not isinstance(item, kind):
        raise ValueError(f"register a {kind.__name__} as a {what} (got {type(item).__name__})")
    if name in table and not replace and table[name] is not item:
        raise ValueError(f"a {what} named {name!r} is registered already; pass replace=True to replace it")
    table[name] = item
    return item


def forget(seen: dict[str, str], name: str) -> None:
    """Drop the entry points that registered ``name`` from ``seen`` (they load again while still installed)."""
    for key in [k for k, v in seen.items() if v == name]:
        del seen[key]
    seen.pop(_SCANNED, None)
