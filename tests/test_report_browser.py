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
from vrelab.results import Conditions, Estimate, FitResult, LevelResult, VreResult

pytestmark = pytest.mark.browser

SCREENSHOT_DIR = Path(os.environ.get("VRELAB_SCREENSHOT_DIR", Path(__file__).resolve().parent.parent / ".pytest_cache" / "report-screenshots"))


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

    def send(self, method: str, params: dict | None = None, session: str | None = None, timeout: float = 20.0) -> dict:
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

    def wait_event(self, method: str, timeout: float = 20.0) -> dict:
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
    fits = (FitResult("clip-censored", {"rail_g": Estimate(2.5, 0.03)}, 6, 1.2, levels_used=tuple(rms)),)
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


def render_in_chromium(report: Path, work: Path, screenshot: Path) -> tuple[dict, list[dict]]:
    """Load ``report`` in headless Chromium; save a full-page screenshot; return the page state
    (image count, decoded count, widths, height, title) and the DevTools events seen."""
    cdp = CDP(_chromium(), work / "chromium-profile")
    try:
        target = cdp.send("Target.createTarget", {"url": "about:blank"})["targetId"]
        session = cdp.send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        for domain in ("Page", "Runtime", "Log", "Network"):
            cdp.send(f"{domain}.enable", session=session)
        cdp.send("Emulation.setDeviceMetricsOverride", {"width": 1280, "height": 1000, "deviceScaleFactor": 1, "mobile": False}, session=session)
        cdp.send("Page.navigate", {"url": report.resolve().as_uri()}, session=session)
        cdp.wait_event("Page.loadEventFired")
        js = (
            "JSON.stringify({n: document.images.length,"
            " ok: Array.from(document.images).filter(i => i.complete && i.naturalWidth > 0).length,"
            " widths: Array.from(document.images).map(i => i.naturalWidth),"
            " h: document.documentElement.scrollHeight, title: document.title})"
        )
        state = json.loads(cdp.send("Runtime.evaluate", {"expression": js, "returnByValue": True}, session=session)["result"]["value"])
        height = min(int(state["h"]), 16000)
        cdp.send("Emulation.setDeviceMetricsOverride", {"width": 1280, "height": height, "deviceScaleFactor": 1, "mobile": False}, session=session)
        shot = cdp.send("Page.captureScreenshot", {"format": "png"}, session=session, timeout=30)
        cdp.send("Runtime.evaluate", {"expression": "1"}, session=session)  # flush pending events
    finally:
        cdp.close()
    import base64

    screenshot.parent.mkdir(parents=True, exist_ok=True)
    screenshot.write_bytes(base64.b64decode(shot["data"]))
    return state, cdp.events


def assert_rendered_cleanly(state: dict, events: list[dict], n_images: int) -> None:
    assert state["n"] == n_images
    assert state["ok"] == state["n"], f"figures that did not decode: widths {state['widths']}"
    assert min(state["widths"]) >= 400
    assert state["title"]
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


def test_report_renders_in_chromium_with_all_figures_and_no_console_errors(tmp_path: Path) -> None:
    _chromium()
    folder = tmp_path / "run"
    folder.mkdir()
    _example_folder(folder)
    report = report_dir(folder)
    n_img_expected = report.read_text().count("<img ")
    assert n_img_expected == 3  # VRE vs rms, record, PSD (no VRC fit: no rms² plot)
    png = SCREENSHOT_DIR / "report.png"
    state, events = render_in_chromium(report, tmp_path, png)
    assert png.stat().st_size > 20_000
    assert state["h"] > 2000  # the whole report laid out, not a blank page
    assert_rendered_cleanly(state, events, n_img_expected)
