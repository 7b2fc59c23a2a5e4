"""The demo, a campaign and a sweep report laid out in a real browser: on a 1400 px screen and printed on
A4, no table, figure or heading runs out of its box, and no text of an interactive figure (tick
labels, axis titles, panel titles and annotations, legends) lies on another, nor a legend on a
data point; every log axis
labels its ticks with their whole value ("20000", "5×10⁻⁴"), never a bare digit.

Measured by the page itself (getBoundingClientRect, scrollWidth against clientWidth) in headless
Chromium, driven as tests/test_report_browser.py drives it.
"""

from __future__ import annotations

import base64
import json
import re
import time
from pathlib import Path

import pytest

from test_report_browser import A4_IN, CDP, CONTENT_WIDTH_PX, _chromium, _eval, _wait_for, open_page

pytestmark = [pytest.mark.browser, pytest.mark.slow, pytest.mark.timeout(300)]

SCREEN_PX = 1400

# Every table's, figure's and heading's content inside its box (a table is measured against its
# scrolling container: a table that needs its scroll bar is a table cut on paper).
_OVERFLOW_JS = """
JSON.stringify((function () {
  var over = [], W = document.documentElement.clientWidth;
  document.querySelectorAll("table, figure, h1, h2, h3, h4").forEach(function (e) {
    var box = e.tagName === "TABLE" ? e.parentElement : e;
    var r = e.getBoundingClientRect();
    if (getComputedStyle(e).display === "none") return;
    if (e.scrollWidth > box.clientWidth + 0.5 || r.right > W + 0.5)
      over.push({tag: e.tagName, scroll: e.scrollWidth, box: box.clientWidth, right: r.right,
                 text: e.textContent.slice(0, 70)});
  });
  return {width: W, page: document.documentElement.scrollWidth, over: over,
          tables: document.querySelectorAll("table").length, figures: document.querySelectorAll("figure").length};
})())
"""

# In each drawn interactive figure: the boxes of its texts, and every pair that intersects.
_OVERLAP_JS = """
JSON.stringify((function () {
  function boxes(root, sel, kind) {
    return Array.from(root.querySelectorAll(sel)).map(function (e) {
      var r = e.getBoundingClientRect();
      return {kind: kind, text: (e.textContent || "").slice(0, 40), l: r.left, t: r.top, r: r.right, b: r.bottom};
    }).filter(function (r) { return r.r - r.l > 0.5 && r.b - r.t > 0.5; });
  }
  function hit(a, b) { var m = 1; return a.l < b.r - m && b.l < a.r - m && a.t < b.b - m && b.t < a.b - m; }
  var figures = [];
  document.querySelectorAll("figure.live div.iplot").forEach(function (gd) {
    var items = [].concat(
      boxes(gd, ".xtick text", "x tick"), boxes(gd, ".ytick text", "y tick"),
      boxes(gd, "g[class^='g-x'][class$='title'] text, g[class^='g-y'][class$='title'] text", "axis title"),
      boxes(gd, ".annotation-text-g", "title or note"),
      boxes(gd, ".legend .bg", "legend"));
    var hits = [];
    for (var i = 0; i < items.length; i++) for (var j = i + 1; j < items.length; j++)
      if (hit(items[i], items[j])) hits.push(items[i].kind + " '" + items[i].text + "' on " + items[j].kind + " '" + items[j].text + "'");
    // Data points (markers) under a legend: hidden from the reader.
    var legends = items.filter(function (r) { return r.kind === "legend"; }), covered = 0, points = 0;
    boxes(gd, ".scatterlayer .points path.point", "point").forEach(function (p) {
      points++;
      if (legends.some(function (l) { return hit(p, l); })) covered++;
    });
    var logs = [];
    Object.keys(gd._fullLayout).forEach(function (k) {
      var a = gd._fullLayout[k];
      if (/^[xy]axis\\d*$/.test(k) && a.type === "log" && a.showticklabels)
        logs.push({axis: k, ticks: Array.from(gd.querySelectorAll("." + a._id + "tick text")).map(function (t) { return t.textContent; })});
    });
    figures.push({id: gd.parentNode.id, items: items.length, hits: hits, logs: logs, covered: covered, points: points});
  });
  return figures;
})())
"""


# Every word of a table's header and of a numeric cell on one line: its boxes (one per line the
# browser laid it on, Range.getClientRects) share one top. "lev el", "decisi on", "0. 27 1" broke.
_BROKEN_WORDS_JS = """
JSON.stringify((function () {
  var out = [];
  document.querySelectorAll("th, td.num").forEach(function (e) {
    if (e.offsetParent === null) return;
    var w = document.createTreeWalker(e, NodeFilter.SHOW_TEXT), re = /\\S+/g, m;
    for (var n = w.nextNode(); n; n = w.nextNode()) {
      re.lastIndex = 0;
      while ((m = re.exec(n.data))) {
        var r = document.createRange(), tops = {};
        r.setStart(n, m.index); r.setEnd(n, m.index + m[0].length);
        Array.from(r.getClientRects()).forEach(function (b) { if (b.width > 0.1) tops[Math.round(b.top)] = 1; });
        if (Object.keys(tops).length > 1) out.push(m[0] + " in '" + e.textContent.slice(0, 50) + "'");
      }
    }
  });
  return out;
})())
"""


def measure_layout(cdp: CDP, session: str) -> dict:
    """On a page open in Chromium: its boxes and its figures' texts on a SCREEN_PX screen, its
    boxes and its words in print at A4's content width (left in print media at that width)."""
    cdp.send("Emulation.setDeviceMetricsOverride", {"width": SCREEN_PX, "height": 1000, "deviceScaleFactor": 1,
                                                    "mobile": False}, session=session)
    specs = _eval(cdp, session, "document.querySelectorAll('script[type=\"application/json\"]').length")
    _wait_for(cdp, session, f"document.querySelectorAll('figure.live').length >= {specs}")
    time.sleep(0.3)  # plotly's responsive relayout after the width change
    out = {"specs": specs, "screen": json.loads(_eval(cdp, session, _OVERFLOW_JS)),
           "figures": json.loads(_eval(cdp, session, _OVERLAP_JS))}
    # Paper: print media at A4's content width (180 mm between the @page margins).
    cdp.send("Emulation.setEmulatedMedia", {"media": "print"}, session=session)
    cdp.send("Emulation.setDeviceMetricsOverride", {"width": CONTENT_WIDTH_PX, "height": 1000, "deviceScaleFactor": 1,
                                                    "mobile": False}, session=session)
    out["print"] = json.loads(_eval(cdp, session, _OVERFLOW_JS))
    out["broken"] = json.loads(_eval(cdp, session, _BROKEN_WORDS_JS))
    return out


def _layout(report: Path, work: Path) -> dict:
    """measure_layout on ``report`` in a Chromium of its own, then its PDF's size."""
    cdp = CDP(_chromium(), work / "chromium-profile")
    try:
        session = open_page(cdp, report)
        out = measure_layout(cdp, session)
        printed = cdp.send("Page.printToPDF", {"paperWidth": A4_IN[0], "paperHeight": A4_IN[1]}, session=session)
        out["pdf_bytes"] = len(base64.b64decode(printed["data"]))
    finally:
        cdp.close()
    return out


# The demo's and the campaign's reports are loaded in Chromium once per run (tests/conftest.py's
# demo_visit and campaign_visit: the page these measurements take, before the mouse moves an axis,
# is the page tests/test_demo.py and tests/test_campaign.py then render, hover and print); the
# README's sweep's here, in a Chromium of its own.
_VISITS = {"demo": "demo_visit", "campaign": "campaign_visit"}


@pytest.fixture(scope="module", params=[*_VISITS, "sweep"])
def layout(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> tuple[str, dict]:
    """One report's layout: the quick demo's (with tests/test_report_browser.METADATA's header,
    the demo tests/test_demo.py reads), the shipped example campaign's (with the pages' metadata)
    or the README's sweep's (a lot: a grid of histogram panels, each with its title under the
    panel above). A module fixture per report, so that pytest builds one report at a time and
    runs both tests on it (the three built in one set-up reached the 300 s timeout on a loaded
    machine)."""
    which = request.param
    if which in _VISITS:
        visit = request.getfixturevalue(_VISITS[which])
        return which, visit["state"]["measured"] | {"pdf_bytes": visit["pdf"].stat().st_size}
    report = request.getfixturevalue("readme_sweep_out") / "report.html"
    return which, _layout(report, tmp_path_factory.mktemp(f"chromium-{which}"))


_SUP = str.maketrans("⁻⁰¹²³⁴⁵⁶⁷⁸⁹", "-0123456789")


def _tick_value(t: str) -> float:
    """A log tick label's number: "20000", "0.005", "10⁵", "5×10⁻⁴" (anything else fails)."""
    t = t.replace("−", "-")
    m = re.fullmatch(r"(-?\d+(?:\.\d+)?)|(?:(\d+)×)?10([⁻⁰¹²³⁴⁵⁶⁷⁸⁹]+)", t)
    assert m, f"log tick label {t!r} is not a whole value"
    if m.group(1):
        return float(m.group(1))
    return float(m.group(2) or 1) * 10.0 ** int(m.group(3).translate(_SUP))


def test_report_fits_its_boxes_on_screen_and_on_a4(layout: tuple[str, dict]) -> None:
    which, got = layout
    screen, paper = got["screen"], got["print"]
    assert screen["width"] == SCREEN_PX and paper["width"] == CONTENT_WIDTH_PX
    assert screen["tables"] >= 3 and screen["figures"] >= 3, "the report this test measures is not the one expected"
    assert screen["over"] == [], f"{which} at {SCREEN_PX} px: content wider than its box: {screen['over'][:5]}"
    assert screen["page"] <= SCREEN_PX, f"{which}: the page scrolls sideways ({screen['page']} px)"
    assert paper["over"] == [], f"{which} on A4: content wider than its box: {paper['over'][:5]}"
    assert paper["page"] <= CONTENT_WIDTH_PX, f"{which} on A4: the page is {paper['page']} px, the paper {CONTENT_WIDTH_PX}"
    assert got["pdf_bytes"] > 10_000


def test_no_word_of_a_header_or_a_number_breaks_on_a4(layout: tuple[str, dict]) -> None:
    which, got = layout
    assert got["broken"] == [], f"{which} on A4: words broken across lines: {got['broken'][:8]}"


def test_figure_texts_do_not_overlap_and_log_axes_say_their_magnitude(layout: tuple[str, dict]) -> None:
    which, got = layout
    figures = got["figures"]
    assert len(figures) == got["specs"] >= 3, "an interactive figure was not drawn"
    for f in figures:
        assert f["items"] >= 4, f"{f['id']}: no tick labels found (the page's structure changed?)"
        assert f["hits"] == [], f"{which} figure {f['id']}: {f['hits'][:4]}"
        assert f["covered"] == 0, f"{which} figure {f['id']}: a legend covers {f['covered']} of {f['points']} data points"
    assert sum(f["points"] for f in figures) > 0, "no data point found (the check above would test nothing)"
    logs = [a for f in figures for a in f["logs"]]
    if which != "sweep":  # the sweep's axes are linear
        assert logs, f"{which}: no log axis drawn (the check below would test nothing)"
    for a in logs:
        # Each label its whole value, rising along the axis: plotly's default minor labels
        # ("100 2 3 4 … 1000") fall back to a bare digit after every decade.
        values = [_tick_value(t) for t in a["ticks"]]
        assert len(values) >= 2, f"a log axis with fewer than two labels: {a}"
        assert all(x < y for x, y in zip(values, values[1:])), f"{which} {a['axis']}: tick labels {a['ticks']}"
