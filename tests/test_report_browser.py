"""The HTML report in a real browser: headless Chromium loads it, every figure decodes, no console
error, no network request, and a screenshot is saved for a human to look at.

Talks the Chrome DevTools Protocol over ``--remote-debugging-pipe`` (fd 3 in, fd 4 out,
NUL-separated JSON) with the standard library only: playwright is not available here. Fails,
never skips, when Chromium is missing (``make test`` installs it with tests/setup_browser.py).
"""

from __future__ import annotations

import json
import os
import select
import shutil
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from vrelab.record import Schedule, Segment, write_record_hdf5
from vrelab.report import report_dir
from vrelab.results import ClipModel, Conditions, Estimate, FitResult, LevelResult, VreResult

pytestmark = pytest.mark.browser

SCREENSHOT_DIR = Path(os.environ.get("VRELAB_SCREENSHOT_DIR", Path(__file__).resolve().parent.parent / ".pytest_cache" / "report-screenshots"))
# How long a DevTools answer, the page's load event or a drawn figure is waited for: a hang guard,
# not a speed claim (speed is bench/'s). A report of plotly figures took over 20 s to load on 2
# cores under a load average of 18 (8 suites at once); pytest-timeout still bounds each test.
DEVTOOLS_DEADLINE_S = 120.0


def _chromium() -> str:
    exe = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    if exe is None:
        pytest.fail("chromium not found: run `python tests/setup_browser.py` (make test does) or apt-get install chromium")
    return exe


class CDP:
    """A minimal DevTools client over the pipe transport."""

    def __init__(self, exe: str, profile_dir: Path) -> None:
        to_chrome_r, self._w = os.pipe()
        self._r, from_chrome_w = os.pipe()
        # Chromium reads commands on fd 3 and writes replies on fd 4.
        os.set_inheritable(to_chrome_r, True)
        os.set_inheritable(from_chrome_w, True)

        def remap() -> None:
            os.dup2(to_chrome_r, 3)
            os.dup2(from_chrome_w, 4)

        self.proc = subprocess.Popen(
            [
                exe,
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--disable-extensions",
                "--no-first-run",
                "--no-default-browser-check",
                "--hide-scrollbars",
                "--remote-debugging-pipe",
                f"--user-data-dir={profile_dir}",
                "about:blank",
            ],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            preexec_fn=remap,
            close_fds=False,
        )
        os.close(to_chrome_r)
        os.close(from_chrome_w)
        self._buf = b""
        self._id = 0
        self.events: list[dict] = []

    def _read_message(self, deadline: float) -> dict:
        while b"\0" not in self._buf:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError("no DevTools message from chromium")
            ready, _, _ = select.select([self._r], [], [], left)
            if ready:
                chunk = os.read(self._r, 1 << 20)
                if not chunk:
                    raise RuntimeError(f"chromium closed the DevTools pipe (exit {self.proc.poll()})")
                self._buf += chunk
        msg, self._buf = self._buf.split(b"\0", 1)
        return json.loads(msg)

    def send(self, method: str, params: dict | None = None, session: str | None = None, timeout: float = DEVTOOLS_DEADLINE_S) -> dict:
        self._id += 1
        msg: dict = {"id": self._id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        os.write(self._w, json.dumps(msg).encode() + b"\0")
        deadline = time.monotonic() + timeout
        while True:
            m = self._read_message(deadline)
            if m.get("id") == self._id:
                if "error" in m:
                    raise RuntimeError(f"{method}: {m['error']}")
                return m.get("result", {})
            self.events.append(m)

    def wait_event(self, method: str, timeout: float = DEVTOOLS_DEADLINE_S) -> dict:
        deadline = time.monotonic() + timeout
        for i, m in enumerate(self.events):
            if m.get("method") == method:
                return self.events.pop(i)
        while True:
            m = self._read_message(deadline)
            if m.get("method") == method:
                return m
            self.events.append(m)

    def close(self) -> None:
        try:
            os.write(self._w, json.dumps({"id": 0, "method": "Browser.close"}).encode() + b"\0")
            self.proc.wait(timeout=5)
        except Exception:
            self.proc.kill()
            self.proc.wait()
        finally:
            os.close(self._w)
            os.close(self._r)


def _example_folder(folder: Path) -> None:
    """An output folder with every optional file: results, record, PSD table, prediction."""
    rng = np.random.default_rng(7)
    rms = np.array([0.25, 0.5, 1.0, 1.5, 2.0, 2.5])
    levels = tuple(
        LevelResult(float(r), Estimate(-0.09 * max(0.0, r - 0.5) ** 2 + float(rng.normal(0, 0.002)), 0.002), n_samples=20000, n_saturated=int(400 * max(0.0, r - 0.8)))
        for r in rms
    )
    fits = (FitResult(ClipModel({"rail_g": Estimate(2.5, 0.03)}), 6, 1.2, levels_used=tuple(rms)),)
    res = VreResult(
        "random",
        Conditions(sensor="adxl355", static_g=1.0, range_g=2.048, axis="z", bandwidth_hz=1000.0, profile="random flat 50-2000 Hz"),
        levels,
        fits,
        kind="simulation",
    )
    (folder / "results.json").write_text(json.dumps(res.to_dict()))
    fs = 2000.0
    sched = Schedule((Segment(0, 1, 0), Segment(1, 2, 0.3), Segment(2, 3, 0), Segment(3, 4, 1.0), Segment(4, 5, 0)))
    x = np.concatenate([rng.normal(0, s.nominal_rms_g, int(fs)) if s.nominal_rms_g else np.zeros(int(fs)) for s in sched.segments])
    write_record_hdf5(folder / "record.h5", fs, [{"reference": 1 + x, "dut": np.clip(1 + x, -2.048, 2.048)}], sched)
    f = np.geomspace(50, 2000, 120)
    with open(folder / "psd.csv", "w") as fh:
        fh.write("freq_hz,psd_measured_g2_per_hz,psd_profile_g2_per_hz\n")
        for a, b in zip(f, 0.003 * 10 ** (rng.normal(0, 1, f.size) / 10)):
            fh.write(f"{a},{b},0.003\n")
    (folder / "prediction.json").write_text(
        json.dumps({"levels": [{"rms_g": 1.0, "vre_g": -0.083, "tilt_error_deg": 4.8, "shares": {"clipping": -0.082, "nonlinearity": -0.001}}], "notes": []})
    )


# Finds, in interactive figure k, a point the user can hover (inside its axes, on a trace that
# shows hover values) and the plot area to drag a zoom box across; scrolls the figure into view.
_PROBE_JS = """
(function (k) {
  var gd = document.querySelectorAll("figure.live div.iplot")[k];
  gd.scrollIntoView({block: "center"});
  var fl = gd._fullLayout, rect = gd.getBoundingClientRect();
  var drawn = gd.querySelectorAll(".scatterlayer .trace, .barlayer .trace").length;
  for (var i = 0; i < gd._fullData.length; i++) {
    var t = gd._fullData[i];
    if (t.hoverinfo === "skip" || t.visible !== true || !t.x) continue;
    var xa = fl[(t.xaxis || "x").replace("x", "xaxis")], ya = fl[(t.yaxis || "y").replace("y", "yaxis")];
    for (var j = 0; j < t.x.length; j++) {
      var x = t.x[j], y = t.type === "bar" ? t.y[j] / 2 : t.y[j];
      if (x === null || y === null || !isFinite(x) || !isFinite(y)) continue;
      var px = xa._offset + xa.l2p(xa.d2l(x)), py = ya._offset + ya.l2p(ya.d2l(y));
      if (px < xa._offset + 3 || px > xa._offset + xa._length - 3 || py < ya._offset + 3 || py > ya._offset + ya._length - 3) continue;
      gd.__hovered = 0;
      gd.on("plotly_hover", function (d) { gd.__hovered = d.points.length; });
      return JSON.stringify({ok: true, id: gd.parentNode.id, x: rect.left + px, y: rect.top + py, axis: xa._name,
        range: xa.range.slice(), traces: gd._fullData.length, drawn: drawn,
        box: [rect.left + xa._offset, rect.top + ya._offset, xa._length, ya._length]});
    }
  }
  return JSON.stringify({ok: false, id: gd.parentNode.id, traces: gd._fullData.length, drawn: drawn});
})
"""

_HOVER_JS = """
(function (k) {
  var gd = document.querySelectorAll("figure.live div.iplot")[k];
  var labels = gd.querySelectorAll(".hoverlayer .hovertext");
  return JSON.stringify({events: gd.__hovered || 0, labels: labels.length,
                         text: Array.from(labels).map(function (l) { return l.textContent; }).join(" | ")});
})
"""

_RANGE_JS = """
(function (k, axis) {
  var gd = document.querySelectorAll("figure.live div.iplot")[k];
  return JSON.stringify(gd._fullLayout[axis].range);
})
"""

# Under print emulation at the page's content width: every table inside its container and the
# page, the static images shown and inside the page, the interactive twins hidden.
_PRINT_JS = """
JSON.stringify((function () {
  var W = document.documentElement.clientWidth, over = [];
  document.querySelectorAll("table").forEach(function (t, i) {
    var r = t.getBoundingClientRect(), box = t.parentElement;
    if (r.right > W + 0.5 || r.left < -0.5 || t.scrollWidth > box.clientWidth + 0.5)
      over.push({i: i, right: r.right, scroll: t.scrollWidth, box: box.clientWidth,
                 text: t.textContent.slice(0, 80)});
  });
  var imgs = Array.from(document.querySelectorAll("img.static"));
  var iplots = Array.from(document.querySelectorAll("div.iplot"));
  return {width: W, page: document.documentElement.scrollWidth, tables: document.querySelectorAll("table").length,
          over: over,
          images_shown: imgs.filter(function (m) { return getComputedStyle(m).display !== "none"; }).length,
          images: imgs.length,
          images_over: imgs.filter(function (m) { return m.getBoundingClientRect().right > W + 0.5; }).length,
          iplots_shown: iplots.filter(function (d) { return getComputedStyle(d).display !== "none"; }).length};
})())
"""

# A4 at 96 CSS px per inch, less the @page margins (15 mm each side): 180 mm. Letter paper is
# wider (186 mm of content), so what fits A4 fits both.
A4_IN = (8.27, 11.69)
CONTENT_WIDTH_PX = round(180 / 25.4 * 96)
FOOTER_PT = 16 / 25.4 * 72  # the bottom @page margin, 16 mm: the running footer lives there


def _eval(cdp: CDP, session: str, expression: str, timeout: float = DEVTOOLS_DEADLINE_S):
    r = cdp.send("Runtime.evaluate", {"expression": expression, "returnByValue": True}, session=session, timeout=timeout)
    if "exceptionDetails" in r:
        raise AssertionError(f"page script failed: {r['exceptionDetails']}")
    return r["result"].get("value")


def _wait_for(cdp: CDP, session: str, expression: str, timeout: float = DEVTOOLS_DEADLINE_S):
    deadline = time.monotonic() + timeout
    while True:
        value = _eval(cdp, session, expression)
        if value or time.monotonic() > deadline:
            return value
        time.sleep(0.05)


def _mouse(cdp: CDP, session: str, kind: str, x: float, y: float, pressed: bool = False) -> None:
    cdp.send("Input.dispatchMouseEvent", {"type": kind, "x": x, "y": y, "button": "left" if kind != "mouseMoved" or pressed else "none",
                                          "buttons": 1 if pressed else 0, "clickCount": 1 if kind != "mouseMoved" else 0},
             session=session)


def _exercise_figures(cdp: CDP, session: str, n: int) -> list[dict]:
    """Hover a data point of every interactive figure with the mouse, then drag a zoom box across
    it: what the page shows after each (the hover label, the axis range)."""
    out = []
    for k in range(n):
        probe = json.loads(_eval(cdp, session, f"{_PROBE_JS}({k})"))
        if probe["ok"]:
            _mouse(cdp, session, "mouseMoved", probe["x"], probe["y"])
            deadline = time.monotonic() + 2.0
            while True:
                hover = json.loads(_eval(cdp, session, f"{_HOVER_JS}({k})"))
                if (hover["labels"] and hover["events"]) or time.monotonic() > deadline:
                    break
                time.sleep(0.03)
            probe["hover"] = hover
            x0, y0, w, h = probe["box"]
            _mouse(cdp, session, "mousePressed", x0 + 0.30 * w, y0 + 0.25 * h, pressed=True)
            _mouse(cdp, session, "mouseMoved", x0 + 0.6 * w, y0 + 0.7 * h, pressed=True)
            _mouse(cdp, session, "mouseReleased", x0 + 0.6 * w, y0 + 0.7 * h)
            deadline = time.monotonic() + 2.0
            while True:
                after = json.loads(_eval(cdp, session, f"{_RANGE_JS}({k}, {json.dumps(probe['axis'])})"))
                if after != probe["range"] or time.monotonic() > deadline:
                    break
                time.sleep(0.03)
            probe["zoomed"] = after
            _mouse(cdp, session, "mouseMoved", 1, 1)  # leave: the next figure starts without a hover label
        out.append(probe)
    return out


def _print_checks(cdp: CDP, session: str, pdf: Path) -> dict:
    cdp.send("Emulation.setEmulatedMedia", {"media": "print"}, session=session)
    cdp.send("Emulation.setDeviceMetricsOverride", {"width": CONTENT_WIDTH_PX, "height": 1000, "deviceScaleFactor": 1,
                                                    "mobile": False}, session=session)
    layout = json.loads(_eval(cdp, session, _PRINT_JS))
    cdp.send("Emulation.setEmulatedMedia", {"media": ""}, session=session)
    printed = cdp.send("Page.printToPDF", {"paperWidth": A4_IN[0], "paperHeight": A4_IN[1]}, session=session)
    import base64

    pdf.parent.mkdir(parents=True, exist_ok=True)
    pdf.write_bytes(base64.b64decode(printed["data"]))
    return layout


def pdf_pages(pdf: Path) -> list[dict]:
    """Each page of a printed report: its whole text, the text of its body (above the bottom
    margin, where the running footer is), the "Page i of n" footer, its width, its images."""
    import re

    from pypdf import PdfReader

    pages = []
    for page in PdfReader(pdf).pages:
        body: list[str] = []
        bottom = float(page.mediabox.bottom) + FOOTER_PT

        def keep(text, cm, tm, font, size, body=body, bottom=bottom):
            y = tm[5] * cm[3] + tm[4] * cm[1] + cm[5]  # the text's baseline in page coordinates
            if y > bottom:
                body.append(text)

        text = page.extract_text(visitor_text=keep) or ""
        m = re.search(r"Page (\d+) of (\d+)", text)
        own = "".join(body)
        pages.append({"text": text, "body": own, "footer": (int(m.group(1)), int(m.group(2))) if m else None,
                      # images are slow to list: only where the text would not show the page holds anything
                      "images": len(page.images) if len(own.strip()) < 20 else None,
                      "width_pt": float(page.mediabox.width)})
    return pages


def open_page(cdp: CDP, report: Path) -> str:
    """Open ``report`` in a new tab, 1280 px wide, with the page, console, log and network events
    on; return the tab's DevTools session once the page has loaded."""
    target = cdp.send("Target.createTarget", {"url": "about:blank"})["targetId"]
    session = cdp.send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
    for domain in ("Page", "Runtime", "Log", "Network"):
        cdp.send(f"{domain}.enable", session=session)
    cdp.send("Emulation.setDeviceMetricsOverride", {"width": 1280, "height": 1000, "deviceScaleFactor": 1, "mobile": False}, session=session)
    cdp.send("Page.navigate", {"url": report.resolve().as_uri()}, session=session)
    cdp.wait_event("Page.loadEventFired")
    return session


def render_in_chromium(report: Path, work: Path, screenshot: Path, pdf: Path | None = None,
                       exercise: bool = True, measure=None) -> tuple[dict, list[dict]]:
    """Load ``report`` in headless Chromium; wait until its script has drawn the interactive
    figures; with ``measure`` (``measure(cdp, session) -> dict``: tests/test_report_layout.py's
    measurements, on the page as loaded, before the mouse moves its axes), its answer as the
    state's "measured", the page then back on screen at 1280 px; hover and zoom each figure with
    the mouse (unless not ``exercise``: a test of the printed page only, where each figure's two
    waits for the page to answer cost seconds); save a full-page screenshot; with ``pdf``, check
    the print layout and print to that PDF (A4). Return the page state (images, decoded, widths,
    height, title, the interactive figures and what they did, the print layout) and the DevTools
    events seen."""
    cdp = CDP(_chromium(), work / "chromium-profile")
    try:
        session = open_page(cdp, report)
        specs = _eval(cdp, session, "document.querySelectorAll('script[type=\"application/json\"]').length")
        # Drawn (class "live") or given up (its box removed, an error on the console).
        _wait_for(cdp, session, "document.querySelectorAll('figure.live').length + "
                                f"({specs} - document.querySelectorAll('div.iplot').length) >= {specs}")
        measured = None
        if measure is not None:
            measured = measure(cdp, session)
            cdp.send("Emulation.setEmulatedMedia", {"media": ""}, session=session)
            cdp.send("Emulation.setDeviceMetricsOverride", {"width": 1280, "height": 1000, "deviceScaleFactor": 1,
                                                            "mobile": False}, session=session)
            time.sleep(0.3)  # plotly's responsive relayout after the width change
        js = (
            "JSON.stringify({n: document.images.length,"
            " ok: Array.from(document.images).filter(i => i.complete && i.naturalWidth > 0).length,"
            " widths: Array.from(document.images).map(i => i.naturalWidth),"
            " h: document.documentElement.scrollHeight, title: document.title,"
            " live: document.querySelectorAll('figure.live').length,"
            " static_shown: Array.from(document.images).filter(i => getComputedStyle(i).display !== 'none').length})"
        )
        state = json.loads(_eval(cdp, session, js))
        state["specs"] = specs
        if measure is not None:
            state["measured"] = measured
        state["figures"] = _exercise_figures(cdp, session, state["live"]) if exercise else []
        _eval(cdp, session, "window.scrollTo(0, 0), 1")
        height = min(int(state["h"]), 16000)
        cdp.send("Emulation.setDeviceMetricsOverride", {"width": 1280, "height": height, "deviceScaleFactor": 1, "mobile": False}, session=session)
        # JPEG for a long page: PNG-encoding 16000 rows costs a second of the test.
        fmt = "jpeg" if screenshot.suffix.lower() in (".jpg", ".jpeg") else "png"
        shot = cdp.send("Page.captureScreenshot", {"format": fmt, **({"quality": 70} if fmt == "jpeg" else {})},
                        session=session)
        if pdf is not None:
            state["print"] = _print_checks(cdp, session, pdf)
        cdp.send("Runtime.evaluate", {"expression": "1"}, session=session)  # flush pending events
    finally:
        cdp.close()
    import base64

    screenshot.parent.mkdir(parents=True, exist_ok=True)
    screenshot.write_bytes(base64.b64decode(shot["data"]))
    return state, cdp.events


def assert_rendered_cleanly(state: dict, events: list[dict], n_images: int) -> None:
    """Every PNG decodes; every figure has its interactive twin, drawn with all its traces, and
    answers the mouse (a hover label, a narrower axis after a zoom drag); no console error, no
    network request."""
    assert state["n"] == n_images
    assert state["ok"] == state["n"], f"figures that did not decode: widths {state['widths']}"
    assert min(state["widths"]) >= 400
    assert state["title"]
    assert state["specs"] == n_images, "a figure without its interactive twin"
    assert state["live"] == n_images, f"{state['live']} of {n_images} interactive figures drawn"
    assert state["static_shown"] == 0, "a PNG shown on screen beside its drawn twin"
    for f in state["figures"]:
        assert f["ok"], f"figure {f['id']}: no point to hover inside its axes"
        assert f["drawn"] >= 1, f"figure {f['id']}: no trace drawn"
        assert f["hover"]["events"] >= 1 and f["hover"]["labels"] >= 1, f"figure {f['id']}: no hover label ({f['hover']})"
        lo, hi = sorted(f["range"])
        zlo, zhi = sorted(f["zoomed"])
        assert lo < zlo < zhi < hi, f"figure {f['id']}: the zoom drag did not narrow {f['axis']} ({f['range']} -> {f['zoomed']})"
    errors = [
        e
        for e in events
        if e.get("method") == "Runtime.exceptionThrown"
        or (e.get("method") == "Runtime.consoleAPICalled" and e["params"].get("type") in ("error", "assert"))
        or (e.get("method") == "Log.entryAdded" and e["params"]["entry"].get("level") == "error")
    ]
    assert not errors, f"console errors: {errors}"
    urls = [e["params"]["request"]["url"] for e in events if e.get("method") == "Network.requestWillBeSent"]
    remote = [u for u in urls if not u.startswith(("file:", "data:", "about:"))]
    assert not remote, f"the report requested the network: {remote}"


def assert_prints_cleanly(state: dict, pdf: Path, min_pages: int) -> list[dict]:
    """Print layout (A4 content width): no table wider than its box or the page, every figure's
    PNG shown and inside the page, no interactive twin; the PDF: at least ``min_pages`` pages,
    each numbered "Page i of n" and none without content of its own."""
    lay = state["print"]
    assert lay["width"] == CONTENT_WIDTH_PX and lay["tables"] > 0
    assert not lay["over"], f"tables cut at the right edge in print: {lay['over']}"
    assert lay["page"] <= lay["width"], f"the printed page is {lay['page']} px wide for {lay['width']} px of paper"
    assert lay["images_shown"] == lay["images"] > 0 and lay["images_over"] == 0
    assert lay["iplots_shown"] == 0
    pages = pdf_pages(pdf)
    assert len(pages) >= min_pages
    n = len(pages)
    assert [p["footer"] for p in pages] == [(i, n) for i in range(1, n + 1)]
    blank = [i for i, p in enumerate(pages, 1) if len(p["body"].strip()) < 20 and not p["images"]]
    assert not blank, f"pages with nothing but the footer: {blank}"
    assert all(abs(p["width_pt"] - A4_IN[0] * 72) < 1 for p in pages)
    return pages


def markup_only(text: str) -> str:
    """The report's HTML without its scripts (plotly.js's source names URLs it never loads)."""
    import re

    return re.sub(r"<script[^>]*>.*?</script>", "", text, flags=re.S)


METADATA = """
report_number = "VRE-2025-014"
[laboratory]
name = "Vibration Lab"
[item]
manufacturer = "Analog Devices"
model = "ADXL355"
serial = "SN 0001"
[equipment]
reference = "PCB 352C33"
reference_calibration = "cert. 2024-118, 2024-11-02, due 2025-11-02"
[approval]
prepared_by = "A. Tester"
date = 2025-03-14
"""


def test_report_renders_in_chromium_answers_the_mouse_and_prints(tmp_path: Path) -> None:
    _chromium()
    folder = tmp_path / "run"
    folder.mkdir()
    _example_folder(folder)
    (tmp_path / "meta.toml").write_text(METADATA)
    report = report_dir(folder, metadata=tmp_path / "meta.toml")
    n_img_expected = markup_only(report.read_text()).count("<img ")
    assert n_img_expected == 3  # VRE vs rms, record, PSD (no VRC fit: no rms² plot)
    png = SCREENSHOT_DIR / "report.png"
    pdf = SCREENSHOT_DIR / "report.pdf"
    state, events = render_in_chromium(report, tmp_path, png, pdf=pdf)
    assert png.stat().st_size > 20_000
    assert state["h"] > 2000  # the whole report laid out, not a blank page
    assert_rendered_cleanly(state, events, n_img_expected)
    pages = assert_prints_cleanly(state, pdf, min_pages=4)
    text = "\n".join(p["text"] for p in pages)
    # The test report's parts, in order, each on paper; the metadata where given, "not given" elsewhere.
    heads = [text.index(h) for h in ("1 Test item", "2 Equipment", "3 Conditions", "4 Procedure", "5 Results",
                                       "6 Decisions", "7 Approval")]
    assert heads == sorted(heads)
    assert "Report VRE-2025-014" in pages[-1]["text"] and "PCB 352C33" in text and "not given" in text
