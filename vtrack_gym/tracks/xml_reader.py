"""A bounded, entity-free XML reader for map files (OpenDRIVE, GPX, OSM pre-scans): every element keeps the line it
starts on, so errors can name it.

Built on the standard library's expat parser. A document type declaration or an entity declaration is refused
(maps need neither; this closes entity-expansion attacks), as are files over ``MAX_XML_BYTES`` and documents of
more than ``MAX_ELEMENTS`` elements, so a hostile or huge file costs bounded time and memory.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path as FsPath
from xml.parsers import expat

MAX_XML_BYTES = 64 * 2**20
"""Largest map file read [bytes]."""
MAX_ELEMENTS = 2_000_000
"""Most XML elements one map file may hold."""


@dataclass
class Element:
    """One XML element: ``tag`` (namespace prefix dropped), ``attrib``, ``children`` and the ``line`` it starts on."""

    tag: str
    attrib: dict[str, str]
    line: int
    children: list[Element] = field(default_factory=list)

    def find_all(self, tag: str) -> list[Element]:
        """The direct children named ``tag``."""
        return [c for c in self.children if c.tag == tag]

    def find(self, tag: str) -> Element | None:
        """The first direct child named ``tag``, or None."""
        return next((c for c in self.children if c.tag == tag), None)

    def iter(self, tag: str) -> Iterator[Element]:
        """Every descendant (and this element) named ``tag``, in document order."""
        stack = [self]
        while stack:
            node = stack.pop()
            if node.tag == tag:
                yield node
            stack.extend(reversed(node.children))


def _local(tag: str) -> str:
    """``tag`` without its namespace (expat's ``uri tag`` form or a ``prefix:tag``)."""
    return tag.rsplit(" ", 1)[-1].rsplit(":", 1)[-1]


def read_xml(file: str | os.PathLike[str], data: bytes, what: str) -> Element:
    """The root element of the XML document ``data`` read from ``file`` (``what`` names the format in errors).

    ValueError naming the file and line for malformed XML, a DOCTYPE or entity declaration, or too many elements.
    """
    if len(data) > MAX_XML_BYTES:
        raise ValueError(f"{file}: the file is {len(data) / 2**20:.1f} MiB; at most {MAX_XML_BYTES // 2**20} MiB of "
                         f"{what} is read")
    parser = expat.ParserCreate(namespace_separator=" ")
    stack: list[Element] = []
    root: list[Element] = []
    count = [0]

    def start(tag: str, attrib: dict[str, str]) -> None:
        count[0] += 1
        if count[0] > MAX_ELEMENTS:
            raise ValueError(f"{file}, line {parser.CurrentLineNumber}: more than {MAX_ELEMENTS} XML elements")
        node = Element(_local(tag), {_local(k): v for k, v in attrib.items()}, parser.CurrentLineNumber)
        (stack[-1].children if stack else root).append(node)
        stack.append(node)

    def refuse(*_: object) -> None:
        raise ValueError(f"{file}, line {parser.CurrentLineNumber}: a document type or entity declaration; "
                         f"{what} needs none (refused)")

    parser.StartElementHandler = start
    parser.EndElementHandler = lambda tag: stack.pop()
    parser.StartDoctypeDeclHandler = refuse
    parser.EntityDeclHandler = refuse
    try:
        parser.Parse(data, True)
    except expat.ExpatError as exc:
        raise ValueError(f"{FsPath(file)}, line {exc.lineno}, column {exc.offset + 1}: malformed XML "
                         f"({expat.ErrorString(exc.code)}); expected {what} XML") from None
    if not root:
        raise ValueError(f"{file}: no XML element; expected {what} XML")
    return root[0]


def number(node: Element, name: str, file: object, default: float | None = None) -> float:
    """Attribute ``name`` of ``node`` as a finite float; ValueError naming the file, line, element and attribute."""
    import math

    text = node.attrib.get(name)
    if text is None:
        if default is not None:
            return default
        raise ValueError(f"{file}, line {node.line}: <{node.tag}> needs the attribute {name}= (a number)")
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise ValueError(f"{file}, line {node.line}: <{node.tag} {name}={text[:40]!r}> is not a finite number")
    return value
