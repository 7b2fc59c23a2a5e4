"""A package's names imported on first use (PEP 562's module ``__getattr__``): one rule for
``vrelab.models``, ``vrelab.analysis`` and ``vrelab.triaxial``, whose modules bring scipy, the
readers' libraries or the simulator, none of which a command that does not use them should pay
for at start-up."""

from __future__ import annotations

import importlib
from typing import Any, Callable, Mapping


def lazy_getattr(package: str, table: Mapping[str, str], namespace: dict[str, Any]) -> Callable[[str], Any]:
    """The module ``__getattr__`` of ``package``: a name in ``table`` (name -> module) is imported
    from its module at its first use and bound in ``namespace`` (the package's ``globals()``), so
    later reads find it there; any other name is an AttributeError, as Python's own."""

    def __getattr__(name: str) -> Any:
        if name in table:
            value = getattr(importlib.import_module(table[name]), name)
            namespace[name] = value
            return value
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    return __getattr__
