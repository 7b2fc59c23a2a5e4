"""The HTML pieces every part of the report is built from: escaping, cells, key-value tables and
tables with a heading. One owner, so the results' sections and the test-report frame
(:mod:`vrelab.report.testreport`) render a table the same way.

Every string that reaches the page (a file's channel names, a manifest's name, ``--metadata``
values) is text, in each of the page's three contexts, and has one escape for each: HTML
(:func:`esc`), a CSS string (:func:`css_string`) and JSON inside a ``<script>`` element
(:func:`script_json`). Control characters are shown, not passed on: a form feed is a line break
to CSS (it ended the report number's string and let the rest be rules)."""

from __future__ import annotations

import html
from dataclasses import dataclass
from typing import Any, Sequence


@dataclass(frozen=True)
class ReportTable:
    """A table of text cells under a heading (cells are escaped; ``numeric`` columns align right).

    A cell may be ``(text, "#anchor")``: a link within the report. ``breakable`` columns hold
    long unbroken tokens (a SHA-256, a path) that may break anywhere to fit the paper; every
    other cell breaks between words only."""

    title: str
    header: Sequence[str]
    rows: Sequence[Sequence[Any]]
    numeric: Sequence[int] = ()
    breakable: Sequence[int] = ()


def _shown(ch: str) -> str:
    o = ord(ch)
    if o < 0x20 and ch not in "\t\n\r":
        return chr(0x2400 + o)  # the control picture: \f shows as ␌
    if o == 0x7F:
        return "\u2421"
    return "\ufffd"  # C1 controls; bidi embeddings, overrides and isolates (they reorder the text shown)


_CONTROLS = {c: _shown(chr(c)) for c in (*(c for c in range(0x20) if chr(c) not in "\t\n\r"), *range(0x7F, 0xA0),
                                         *range(0x202A, 0x202F), *range(0x2066, 0x206A))}


def shown_text(x: object) -> str:
    """``str(x)`` with its control characters made visible and inert (the report's one rule):
    C0 controls but tab and line breaks as their pictures (U+2400 block: a form feed is ␌),
    DEL as ␡, C1 controls and bidirectional embeddings, overrides and isolates as U+FFFD (an
    override would show "SSAP" for "PASS")."""
    return str(x).translate(_CONTROLS)


def esc(x: object) -> str:
    """``x`` as HTML text or a quoted attribute value: :func:`shown_text`, then ``& < > " '``
    escaped."""
    return html.escape(shown_text(x), quote=True)


def css_string(s: str) -> str:
    """``s`` as a quoted CSS string: :func:`shown_text`, then every character that could end the
    string or the style element (quotes, backslash, ``< > &``, line breaks, U+2028/9) as a CSS
    hex escape (CSS Syntax 3, 4.3.7: ``\\hex`` ended by one space)."""
    def safe(ch: str) -> bool:
        o = ord(ch)
        return 0x20 <= o < 0x7F and ch not in "\\\"'<>&" or o >= 0xA0 and ch not in "\u2028\u2029"

    return '"' + "".join(ch if safe(ch) else f"\\{ord(ch):x} " for ch in shown_text(s)) + '"'


def script_json(text: str) -> str:
    """JSON text made safe inside a ``<script>`` element: ``<``, ``>``, ``&`` and U+2028/9 as
    ``\\uXXXX`` (they occur only inside JSON strings, where the escape means the same), so
    neither ``</script`` nor ``<!--`` can end or change the element."""
    for ch in "<>&\u2028\u2029":
        text = text.replace(ch, f"\\u{ord(ch):04x}")
    return text


def cell(v: object) -> str:
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

    def td_cls(j: int) -> str:
        return ' class="any"' if j in t.breakable else cls(j)

    th = "".join(f"<th{cls(j)}>{esc(h)}</th>" for j, h in enumerate(t.header))
    body = "".join("<tr>" + "".join(f"<td{td_cls(j)}>{cell(c)}</td>" for j, c in enumerate(row)) + "</tr>" for row in t.rows)
    head = f"<h{level}>{esc(t.title)}</h{level}>" if t.title else ""
    return f'{head}<div class="scroll"><table><thead><tr>{th}</tr></thead><tbody>{body}</tbody></table></div>'
