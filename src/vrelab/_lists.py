"""The list syntax of the CLI reference, shared by the CLI and by sweep files.

``parse_list`` implements the list syntax of the CLI reference: comma-separated numbers and ranges
``a:b:step``, a range inclusive of both ends when they fall on the grid.
"""

from __future__ import annotations

import math

# A range end counts as "on the grid" when it is this close to a grid point, in steps: decimal
# steps such as 0.1 are not exact in binary, and 0:1:0.1 must still end at 1.
_GRID_TOL = 1e-9
# The longest list a range may expand to: a typo such as 0:10:0.0001 should fail, not hang.
_MAX_POINTS = 100_000


def number(token: str, name: str) -> float:
    """One finite number of a list option, or a ValueError naming the option."""
    try:
        x = float(token)
    except ValueError:
        raise ValueError(f"{name}: bad number {token!r}") from None
    if not math.isfinite(x):
        raise ValueError(f"{name}: value must be finite, got {token!r}")
    return x


def _tidy(x: float) -> float:
    """Remove binary noise from grid points so that 0:1:0.1 prints 0.3, not 0.30000000000000004."""
    return float(f"{x:.12g}")


def _expand_range(token: str, name: str) -> list[float]:
    parts = token.split(":")
    if len(parts) != 3:
        raise ValueError(f"{name}: bad range {token!r} (expected start:stop:step)")
    start, stop, step = (number(p.strip(), name) for p in parts)
    if step == 0:
        raise ValueError(f"{name}: range step must not be zero in {token!r}")
    if (stop - start) * step < 0:
        raise ValueError(f"{name}: range {token!r} is empty (step goes away from stop)")
    n_steps = (stop - start) / step
    n = math.floor(n_steps + _GRID_TOL)
    if n + 1 > _MAX_POINTS:
        raise ValueError(f"{name}: range {token!r} has more than {_MAX_POINTS} points")
    return [_tidy(start + i * step) for i in range(n + 1)]


def parse_list(text: str, name: str) -> list[float]:
    """Parse ``"0.5,1,2:4:0.5"`` into ``[0.5, 1.0, 2.0, 2.5, 3.0, 3.5, 4.0]``.

    Parameters
    ----------
    text : str
        Comma-separated tokens; each is a number or a range ``start:stop:step``. A range includes
        ``start`` and every ``start + i·step`` up to ``stop``; ``stop`` itself is included when it
        falls on the grid (to 1e-9 of a step), so ``0:1:0.25`` ends at 1 and ``0:1:0.3`` at 0.9.
    name : str
        Option name for messages, e.g. ``"--rms"``.

    Returns
    -------
    list of float
        The values in the order given (duplicates kept).

    Raises
    ------
    ValueError
        One line naming the option and the offending token: empty list, a non-number, NaN/inf,
        a zero step, an empty range or one with more than 100 000 points.
    """
    if text is None or not str(text).strip():
        raise ValueError(f"{name}: empty list")
    values: list[float] = []
    for raw in str(text).split(","):
        token = raw.strip()
        if not token:
            raise ValueError(f"{name}: empty item in list {text!r}")
        if ":" in token:
            values.extend(_expand_range(token, name))
        else:
            values.append(number(token, name))
        if len(values) > _MAX_POINTS:
            raise ValueError(f"{name}: list has more than {_MAX_POINTS} values")
    return values
