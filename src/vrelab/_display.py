"""How a result shows itself: a short repr, a notebook table, a DataFrame of its levels.

One rule for every result class, from the description the class gives (no copy per class):

* ``_SHOW``: the attributes (or properties) a repr shows, in order. ``None`` and empty ones are
  left out; an :class:`~vrelab.results.Estimate` shows as ``value ± u unit`` (GUM 7.2.6 rounding,
  :mod:`vrelab._format`), a number with four significant digits, a sequence (levels, warnings)
  as its count (a few numbers, a vector: the numbers), a mapping as ``name = value`` pairs (its
  None values left out), a shown object in brackets.
  A class with more to say (a fit's parameters) overrides ``display_fields``.
* ``_ROWS``: the attribute holding its levels, each a mapping or with ``to_dict()``; one row a level,
  the columns named as ``to_dict`` (and so ``--json``) names them, units in the names
  (``rms_g``, ``vre_g``, ``u_vre_g``, ``U_vre_g``, ``k``, ``vrc_ug_per_g2``), a prediction's
  shares spread into their own columns, the flags or notes joined into ``note``. A class whose
  levels sit deeper (per axis) overrides ``display_rows``.

A class sets ``_SHOW`` and ``_ROWS`` without an annotation: a dataclass lists even a ``ClassVar``
in ``__dataclass_fields__``, which code iterates to copy a result's fields.

``__repr__`` is one line: ``<Type name=value, ...>`` (``levels=5``: the count);
``_repr_html_`` is the same as a small HTML table, the levels as a second one (what Jupyter
shows); ``to_dataframe()`` the rows as a :class:`pandas.DataFrame` (pandas is imported on the
call, not with vrelab: ``pip install 'vrelab[dataframe]'``).
"""

from __future__ import annotations

import html
import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, ClassVar, cast

from vrelab._format import MISSING, format_value

if TYPE_CHECKING:
    import pandas

# A field's text in a repr is cut at this many characters (a long note, many parameters): the
# repr stays a line or two, the whole is in ``to_dict()`` and ``_repr_html_``.
FIELD_CHARS = 90
# A mapping shows its first few pairs in a repr.
MAPPING_ITEMS = 4
# A sequence of this many numbers or fewer (a vector, a few levels) shows its numbers, a longer one its count.
VECTOR_ITEMS = 6
# A notebook table lists at most this many levels (the DataFrame has them all).
HTML_ROWS = 60


def _number(x: object) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) or type(x).__module__ == "numpy"


def text(value: object) -> str | None:
    """``value`` as a repr shows it; None when it is left out (None, an empty sequence)."""
    if value is None:
        return None
    if isinstance(value, Shown):
        return value.as_field()
    if isinstance(value, (str, bool)):
        return str(value)
    if _number(value):
        try:
            return format_value(float(cast(float, value)))
        except (TypeError, ValueError):
            return str(value)
    if isinstance(value, Mapping):
        items = [(k, v) for k, v in value.items() if v is not None]
        if not items:
            return None
        pairs = [f"{k} = {text(v) or MISSING}" for k, v in items[:MAPPING_ITEMS]]
        return ", ".join(pairs) + (", …" if len(items) > MAPPING_ITEMS else "")
    if isinstance(value, Sequence):
        if value and len(value) <= VECTOR_ITEMS and all(_number(v) for v in value):
            return "(" + ", ".join(format_value(float(v)) for v in value) + ")"
        return str(len(value)) if len(value) else None
    return str(value)


def _cut(s: str) -> str:
    return s if len(s) <= FIELD_CHARS else s[: FIELD_CHARS - 1] + "…"


def flat_row(d: Mapping[str, Any]) -> dict[str, Any]:
    """A level's ``to_dict()`` as one table row: scalars kept, ``shares`` spread into columns,
    ``flags`` / ``notes`` joined into ``note``, other nested entries (a budget's terms, the
    drive's harmonics) left to ``to_dict``. None stays None (a DataFrame makes it NaN)."""
    row: dict[str, Any] = {}
    for key, value in d.items():
        if key in ("flags", "notes"):
            row["note"] = "; ".join(str(v) for v in value)
        elif key == "shares" and isinstance(value, Mapping):
            row.update(value)
        elif value is None or isinstance(value, (str, bool, int, float)):
            row[key] = value
    return row


class Shown:
    """Mixin: ``__repr__``, ``_repr_html_`` and ``to_dataframe`` from the class's ``_SHOW`` and
    ``_ROWS`` (the module docstring). A dataclass using it is declared with ``repr=False``."""

    _SHOW: ClassVar[tuple[str, ...]] = ()
    _ROWS: ClassVar[str | None] = None

    def display_fields(self) -> list[tuple[str, Any]]:
        """(name, value) of what the repr shows."""
        return [(name, getattr(self, name)) for name in self._SHOW]

    def display_rows(self) -> list[dict[str, Any]] | None:
        """One row per level (None: the result has no levels)."""
        if self._ROWS is None:
            return None
        return [flat_row(level if isinstance(level, Mapping) else level.to_dict()) for level in getattr(self, self._ROWS)]

    def _shown_fields(self) -> list[tuple[str, str]]:
        out = []
        for name, value in self.display_fields():
            t = text(value)
            if t is not None:
                out.append((name, _cut(t)))
        return out

    def _inline_(self) -> str:
        """The fields as ``name=value, ...`` (a result inside another's repr)."""
        return ", ".join(f"{name}={t}" for name, t in self._shown_fields())

    def as_field(self) -> str:
        """How this result shows inside another's repr (an Estimate: ``value ± u unit``)."""
        return f"({self._inline_()})"

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self._inline_()}>"

    def _repr_html_(self) -> str:
        head = "".join(f"<tr><th style='text-align:left'>{html.escape(n)}</th><td style='text-align:left'>"
                       f"{html.escape(t)}</td></tr>" for n, t in self._shown_fields())
        out = f"<div><table><caption>{html.escape(type(self).__name__)}</caption><tbody>{head}</tbody></table>"
        rows = self.display_rows()
        if rows:
            out += _html_table(rows)
        return out + "</div>"

    def to_dataframe(self) -> pandas.DataFrame:
        """One row per level, the columns named with their units as ``to_dict()`` names them
        (``rms_g``, ``vre_g``, ``u_vre_g``, ...; the flags or notes in ``note``)."""
        rows = self.display_rows()
        if rows is None:
            raise TypeError(f"{type(self).__name__} has no levels: no to_dataframe() (its to_dict() has it all)")
        try:
            import pandas
        except ImportError:
            raise ImportError("to_dataframe() needs pandas: pip install 'vrelab[dataframe]' (or pandas)") from None
        columns = list(dict.fromkeys(k for row in rows for k in row))
        return pandas.DataFrame(rows, columns=columns)


def _cell(value: object) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return MISSING
    if _number(value):
        return format_value(float(cast(float, value)))
    return str(value)


def _html_table(rows: Sequence[Mapping[str, Any]]) -> str:
    """The levels as an HTML table (at most ``HTML_ROWS``; a last row says how many more)."""
    columns = list(dict.fromkeys(k for row in rows for k in row))
    head = "".join(f"<th>{html.escape(c)}</th>" for c in columns)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(_cell(row.get(c)))}</td>" for c in columns) + "</tr>"
                   for row in rows[:HTML_ROWS])
    if len(rows) > HTML_ROWS:
        body += f"<tr><td colspan='{len(columns)}'>… {len(rows) - HTML_ROWS} more (to_dataframe() has all)</td></tr>"
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def per_axis(results: Mapping[str, Shown]) -> tuple[list[tuple[str, Any]], list[dict[str, Any]]]:
    """A result of several DUT axes (a triaxial test or analysis) shown through each axis's own:
    a field per axis (its fits, else its count of levels) and the axes' rows, each with its
    ``axis`` first."""
    fields: list[tuple[str, Any]] = []
    rows: list[dict[str, Any]] = []
    for axis, result in results.items():
        own = dict(result.display_fields())
        fields.append((axis, own.get("fits") or f"{len(own.get('levels') or ())} levels"))
        rows += [{"axis": axis, **row} for row in result.display_rows() or ()]
    return fields, rows
