"""Parsing the TOML and JSON documents a user gives (manifests, profiles, sensors, metadata,
campaign and sweep folders), with a budget on their nesting.

``tomllib`` and ``json`` recurse once per nesting level: a file nested a few thousand deep
(``x = [[[[...]]]]``, 20 kB) exhausts the interpreter's stack and raises ``RecursionError``, which
is no ``ValueError`` and surfaced as an internal error; a document that parsed but is nested
hundreds deep makes every later walk of it (``json.dumps`` of metadata, a deep copy) do the same.
No vrelab file is nested more than a handful of levels (a sensor's ``[[stage]]`` tables, a
campaign document's runs → channels → levels → flags: 5), so :data:`MAX_NESTING` leaves room for
any future layout and refuses the rest in one line, whichever of the two ways it shows.

Decoding errors (``tomllib.TOMLDecodeError``, ``json.JSONDecodeError``, both ``ValueError``)
are left to the callers, who word them for their file.
"""

from __future__ import annotations

import json
import tomllib
from collections.abc import Iterable
from typing import IO, Any, TypeVar

MAX_NESTING = 32

_Doc = TypeVar("_Doc")


def _too_deep(what: str) -> ValueError:
    return ValueError(f"{what}: nested more than {MAX_NESTING} levels deep (no vrelab file is): refused")


def check_nesting(doc: _Doc, what: str) -> _Doc:
    """``doc`` itself when its tables/arrays nest at most :data:`MAX_NESTING` deep; walked with a
    stack of its own (a recursive walk would fail the way the parser does)."""
    stack: list[tuple[object, int]] = [(doc, 0)]
    while stack:
        node, depth = stack.pop()
        children: Iterable[Any]
        if isinstance(node, dict):
            children = node.values()
        elif isinstance(node, list):
            children = node
        else:
            continue
        if depth >= MAX_NESTING:
            raise _too_deep(what)
        stack.extend((c, depth + 1) for c in children if isinstance(c, (dict, list)))
    return doc


def toml_loads(text: str, what: str) -> dict[str, Any]:
    """:func:`tomllib.loads` with the nesting budget; ``what`` names the file in the refusal."""
    try:
        doc = tomllib.loads(text)
    except RecursionError:
        raise _too_deep(what) from None
    return check_nesting(doc, what)


def toml_load(fh: IO[bytes], what: str) -> dict[str, Any]:
    """:func:`tomllib.load` (a binary file, UTF-8) with the nesting budget."""
    return toml_loads(fh.read().decode("utf-8"), what)


def json_loads(text: str | bytes, what: str) -> Any:
    """:func:`json.loads` with the nesting budget."""
    try:
        doc = json.loads(text)
    except RecursionError:
        raise _too_deep(what) from None
    return check_nesting(doc, what)
