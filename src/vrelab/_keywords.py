"""Keyword options of the model functions: one check shared by every function that takes them.

A model function whose call needs more than 8 parameters (the code's limit, issue 31) names its
leading ones and takes the rest as ``**options`` typed by a ``TypedDict`` (PEP 692), so the
keywords a user wrote before (``shape=``, ``kind=``, ``tone_peaks_g=``, ...) still work and
mypy still checks them. Those a user gave by position before are accepted for one release
through ``*legacy``, with a ``DeprecationWarning`` whose words match the suite's
``filterwarnings`` error (``pyproject.toml``), so vrelab's own code cannot rely on them.
"""

from __future__ import annotations

import warnings
from typing import Any, Mapping, Sequence


def merged(where: str, names: Sequence[str], legacy: Sequence[object], options: Mapping[str, object]) -> dict[str, Any]:
    """``options`` with the positional ``legacy`` values named by ``names`` (in order), checked
    as Python checks a call: too many positional values, a value given twice and an unknown
    keyword are each a ``TypeError``."""
    if len(legacy) > len(names):
        raise TypeError(f"{where}() takes at most {len(names)} optional positional arguments after its named "
                        f"ones, got {len(legacy)}")
    unknown = sorted(set(options) - set(names))
    if unknown:
        raise TypeError(f"{where}() got an unexpected keyword argument {unknown[0]!r}")
    given = dict(zip(names, legacy))
    twice = sorted(set(given) & set(options))
    if twice:
        raise TypeError(f"{where}() got multiple values for argument {twice[0]!r}")
    if given:
        warnings.warn(
            f"{where}(): the keywords {', '.join(given)} given by position are deprecated and will be removed in "
            f"the next release: pass them by name ({', '.join(f'{k}=...' for k in given)})",
            DeprecationWarning,
            stacklevel=3,
        )
    return {**given, **options}
