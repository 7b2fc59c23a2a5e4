"""Report text is text (issue 23): strings from ``--metadata``, a manifest or a file, whatever they
hold (a form feed that ends a CSS string, ``</script>``, ``<!--``, markup, U+2028), reach the page
as text in its HTML, CSS and JSON contexts; and the page's Content-Security-Policy forbids any
network request even if one got through.

Checked where it matters, in headless Chromium (the DevTools client of test_report_browser):
no request leaves the file, no script of the payload runs, the results tables stay visible, the
payload is on the page as text; and the CSP is shown to be enforced (a fetch and an image added
by hand are blocked)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from test_report_browser import CDP, _chromium, _eval, _example_folder, _wait_for, open_page
from vrelab.folder import ResultsFolder
from vrelab.report import report_dir
from vrelab.report._markup import css_string, esc, script_json
from vrelab.report.campaign import report_campaign_dir
from vrelab.report.html import content_security_policy

pytestmark = pytest.mark.browser

REMOTE = "http://127.0.0.1:9"  # discard port: nothing listens; a request would still be seen
# The probe's payload: a form feed ends a CSS string (CSS Syntax 3: \f is a newline), then
# rules of its own (a remote background, every table hidden); markup and script for the HTML
# contexts; the script element's terminators for the JSON-in-script context.
CSS_BREAK = f"R1\f}}}} table,main{{display:none}} body{{background:url({REMOTE}/c)}} x{{y:\""  # fits the footer's 90
HTML_BREAK = (f"</script><script>window.__pwned = 1</script><img src=\"{REMOTE}/img.png\" onerror=\"window.__pwned = 2\">"
              "<!-- \u2028 \x00 -->")


def _toml(s: str) -> str:
    return json.dumps(s)  # a JSON string is a TOML basic string (\f, \u2028 and \u0000 as escapes)


def test_escapes_cover_each_context() -> None:
    """Each escape against its context's own rule (CSS Syntax 3 4.3.5: a string ends at its quote
    or a newline, \\n \\r \\f; HTML 13.2: < and & start markup; a script element ends at
    ``</script``): what comes out holds none of the characters that would end the context."""
    s = "a\fb\"c'd\\e<f>g&h\ri\nj\x00k\u2028l\x7fm\x85n\u202eo" + "é"
    c = css_string(s)
    assert c[0] == c[-1] == '"' and not set(c[1:-1]) & set("\f\r\n\"'<>&\x00\u2028\x7f\x85\u202e")
    assert re.fullmatch(r'"(?:[^\\"]|\\[0-9a-f]+ )*"', c)  # only hex escapes, each ended by its space
    assert "é" in c and "␌" in c and "␀" in c  # text beyond ASCII kept; controls shown as their pictures
    h = esc(s)
    assert not set(h) & set("<>\"'\f\x00\x7f\x85\u202e") and "␌" in h and "␀" in h
    assert esc("\u202eSSAP") == "\ufffdSSAP"  # a right-to-left override cannot show "PASS"
    j = script_json(json.dumps({"name": "</script><!--\u2028"}, ensure_ascii=False))
    assert "</" not in j and "<!--" not in j and "\u2028" not in j
    assert json.loads(j) == {"name": "</script><!--\u2028"}


def test_csp_allows_only_the_reports_own_scripts() -> None:
    csp = content_security_policy(["a()", "b()"])
    assert csp.startswith("default-src 'none';")
    assert "unsafe-eval" not in csp and "script-src 'sha256-" in csp and "'unsafe-inline'" not in csp.split("script-src")[1].split(";")[0]
    assert "script-src" not in content_security_policy([])  # no script: default-src 'none' holds


_PROBE = """
JSON.stringify((function () {
  var tables = Array.from(document.querySelectorAll("table"));
  return {pwned: window.__pwned === undefined ? null : window.__pwned,
          tables: tables.length,
          hidden: tables.filter(function (t) { return getComputedStyle(t).display === "none" || t.offsetHeight === 0; }).length,
          main: getComputedStyle(document.querySelector("main")).display,
          bg: getComputedStyle(document.body).backgroundImage,
          text: document.body.innerText, title: document.title,
          live: document.querySelectorAll("figure.live").length,
          specs: document.querySelectorAll('script[type="application/json"]').length};
})())
"""

# The CSP itself, enforced: a fetch and an image to a remote address, made by hand, are refused.
_CSP_PROBE = """
new Promise(function (done) {
  var seen = [];
  document.addEventListener("securitypolicyviolation", function (e) { seen.push(e.effectiveDirective); });
  var img = new Image(); img.src = "%s/probe.png"; document.body.appendChild(img);
  fetch("%s/probe").then(function () { seen.push("fetched"); }, function () { seen.push("fetch failed"); })
    .finally(function () { setTimeout(function () { done(JSON.stringify(seen)); }, 200); });
})
""" % (REMOTE, REMOTE)  # noqa: UP031 (the JavaScript's braces stay unescaped with %)


def _load(report: Path, work: Path, figures: bool) -> tuple[dict, list[str], list[str]]:
    cdp = CDP(_chromium(), work / "chromium-profile")
    try:
        session = open_page(cdp, report)
        if figures:
            _wait_for(cdp, session, "document.querySelectorAll('figure.live').length >= 1")
        state = json.loads(_eval(cdp, session, _PROBE))
        sent = [e["params"]["request"]["url"] for e in cdp.events if e.get("method") == "Network.requestWillBeSent"]
        r = cdp.send("Runtime.evaluate", {"expression": _CSP_PROBE, "awaitPromise": True, "returnByValue": True},
                     session=session)
        blocked = json.loads(r["result"]["value"])
    finally:
        cdp.close()
    return state, [u for u in sent if not u.startswith(("file:", "data:", "about:"))], blocked


def _assert_safe(state: dict, remote: list[str], blocked: list[str], payload_text: str) -> None:
    assert remote == [], f"the report requested the network: {remote}"
    assert state["pwned"] is None, "a script of the payload ran"
    assert state["tables"] > 0 and state["hidden"] == 0, f"{state['hidden']} of {state['tables']} tables hidden"
    assert state["main"] != "none" and state["bg"] == "none"
    assert payload_text in state["text"], "the payload is not on the page as text"
    assert "img-src" in blocked and "connect-src" in blocked and "fetched" not in blocked, blocked


def test_metadata_payloads_are_text_in_chromium(tmp_path: Path) -> None:
    folder = tmp_path / "run"
    folder.mkdir()
    _example_folder(folder)
    meta = tmp_path / "meta.toml"
    meta.write_text(f"report_number = {_toml(CSS_BREAK)}\ntitle = {_toml(HTML_BREAK)}\n"
                    f"[item]\nmodel = {_toml(HTML_BREAK)}\nserial = {_toml(CSS_BREAK)}\n")
    report = report_dir(folder, metadata=meta)
    html = report.read_text()
    assert 'http-equiv="Content-Security-Policy"' in html.split("</head>")[0]
    state, remote, blocked = _load(report, tmp_path, figures=True)
    _assert_safe(state, remote, blocked, "window.__pwned = 1")
    assert "R1␌" in state["text"]  # the form feed, shown
    assert state["live"] == state["specs"] >= 1  # plotly draws under the CSP, offline


def test_manifest_name_and_run_payloads_are_text_in_chromium(tmp_path: Path) -> None:
    """A campaign's name (the manifest's ``name``, the report's title and running footer when no
    report number is given) and its runs' labels, files and errors."""
    folder = tmp_path / "camp"
    folder.mkdir()
    run = {"index": 1, "label": HTML_BREAK, "file": CSS_BREAK, "method": "sine", "status": "failed",
           "error": HTML_BREAK}
    doc = {"name": CSS_BREAK, "description": HTML_BREAK, "runs": [run], "channels": [], "n_failed": 1,
           "provenance": {"manifest": CSS_BREAK}}
    report = report_campaign_dir(ResultsFolder(folder, "campaign", doc=doc))
    state, remote, blocked = _load(report, tmp_path, figures=False)
    _assert_safe(state, remote, blocked, "window.__pwned = 1")
    assert state["title"].startswith("Campaign report: R1")
