"""The HTML pieces every part of the report is built from: escaping, cells, key-value tables and
tables with a heading. One owner, so the results' sections and the test-report frame
(:mod:`vrelab.report.testreport`) render a table the same way."""

from __future__ import annotations

import html
from dataclasses import dataclass
from typing import Any, Sequence


@dataclass(frozen=True)
class ReportTable:
    """A table of text cells under a heading (cells are escaped; ``numeric`` columns align right).

    A cell may be ``(text, "#anchor")``: a link within the report."""

    title: str
    header: Sequence[str]
    rows: Sequence[Sequence[Any]]
    numeric: Sequence[int] = ()


def esc(x: Any) -> str:
    return html.escape(str(x), quote=True)


def cell(v: Any) -> str:
    if isinstance(v, tuple) and len(v) == 2 and str(v[1]).startswith("#"):
        return f'<a href="{esc(v[1])}">{esc(v[0])}</a>'  # (text, "#anchor"): a link within the report
    text = ("yes" if v else "no") if isinstance(v, bool) else str(v)
    if len(text) <= 160:
        return esc(text)
    # Long values (a sensor description in provenance) fold away on screen (<details> needs no
    # script); print opens them (the print CSS), so paper holds the whole value.
    return f"<details><summary>{esc(text[:80])}…</summary><code>{esc(text)}</code></details>"


def kv_table(rows: Sequence[tuple[str, Any]]) -> str:
    """Rows of (label, value); rows whose value is None, "" or {} are left out."""
    body = "".join(f"<tr><th>{esc(k)}</th><td>{cell(v)}</td></tr>" for k, v in rows if v not in (None, "", {}))
    return f'<table class="kv">{body}</table>' if body else ""


def table_html(t: ReportTable, level: int = 4) -> str:
    """The table under its title as an ``<h{level}>`` heading."""

    def cls(j: int) -> str:
        return ' class="num"' if j in t.numeric else ""

    th = "".join(f"<th{cls(j)}>{esc(h)}</th>" for j, h in enumerate(t.header))
    body = "".join("<tr>" + "".join(f"<td{cls(j)}>{cell(c)}</td>" for j, c in enumerate(row)) + "</tr>" for row in t.rows)
    head = f"<h{level}>{esc(t.title)}</h{level}>" if t.title else ""
    return f'{head}<div class="scroll"><table><thead><tr>{th}</tr></thead><tbody>{body}</tbody></table></div>'
