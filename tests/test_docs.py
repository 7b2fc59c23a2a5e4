"""The documentation builds with warnings as errors (issue 21): the physics, the tutorials, the
gallery (its examples run), the CLI reference from the parser and the API reference from the
docstrings. A docstring that is not valid reST in a public module fails here."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> Path:
    """The HTML documentation, built once for the tests of this file."""
    tmp_path = tmp_path_factory.mktemp("docs")
    # a copy: sphinx-gallery writes its generated pages beside the sources
    docs = tmp_path / "docs"
    shutil.copytree(ROOT / "docs", docs, ignore=shutil.ignore_patterns("_build", "auto_examples", "sg_execution_times.rst"))
    env = {**os.environ, "MPLBACKEND": "Agg",
           "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    # the timeout is a hang guard, not a speed claim: the build (~50 s of one core) ran out of
    # 300 s at a load average of 20 on 2 cores; 540 s stays under pytest-timeout's 600 s, as in
    # tests/test_lint.py, so a hang still ends here with sphinx's output
    done = subprocess.run(
        [sys.executable, "-m", "sphinx", "-b", "html", "-W", "--keep-going", "-q", str(docs), str(tmp_path / "html")],
        capture_output=True, text=True, env=env, timeout=540,
    )
    assert done.returncode == 0, done.stderr[-4000:]
    return tmp_path / "html"


@pytest.mark.slow
def test_the_documentation_builds_without_a_warning(built):
    html = built
    cli = (html / "cli.html").read_text()
    for command in ("predict", "simulate", "analyze", "campaign", "identify", "report"):  # from the parser
        assert f'id="{command}"' in cli or f"vrelab {command}" in cli, command
    assert "highlight-text" in cli and "highlight-default" not in cli and "highlight-python" not in cli
    assert "vrelab.prediction.front.predict" in (html / "api" / "predict.html").read_text()
    gallery = (html / "auto_examples" / "plot_clipping_models.html").read_text()
    assert "-82.9 mg" in gallery  # printed by the example at build: SPEC 1.1's -83 mg
    assert (html / "physics.html").is_file() and (html / "tutorial-designer.html").is_file()


# What a page loads (as opposed to what it links to): <script src>, <link href> (stylesheets,
# icons, preloads), <img>/<iframe>/<source>/<video>/<audio> src, and url(...) or @import in CSS.
_LOADS = re.compile(r"<(?:script|img|iframe|source|video|audio|embed)\b[^>]*?\bsrc\s*=\s*[\"']?([^\"'\s>]+)"
                    r"|<link\b[^>]*?\bhref\s*=\s*[\"']?([^\"'\s>]+)", re.IGNORECASE)
_CSS_LOADS = re.compile(r"(?:url\(\s*[\"']?|@import\s+[\"'])([^\"')\s]+)", re.IGNORECASE)
_REMOTE = re.compile(r"^(?:[a-z][a-z0-9+.-]*:)?//", re.IGNORECASE)  # http://, https://, //host


def _remote_loads(html: Path) -> list[str]:
    found = []
    for page in html.rglob("*.html"):
        for m in _LOADS.finditer(page.read_text(errors="replace")):
            url = m.group(1) or m.group(2)
            if _REMOTE.match(url):
                found.append(f"{page.relative_to(html)}: {url}")
    for sheet in html.rglob("*.css"):
        for url in _CSS_LOADS.findall(sheet.read_text(errors="replace")):
            if _REMOTE.match(url):
                found.append(f"{sheet.relative_to(html)}: {url}")
    return found


def test_the_remote_load_finder_finds_what_a_page_would_fetch(tmp_path):
    """The check below can fail: each way a page fetches from another host is found."""
    (tmp_path / "a.html").write_text(
        '<script src="https://cdn.example.org/x.js"></script>'
        "<link rel=stylesheet href='//cdn.example.org/y.css'>"
        '<img alt=x src=http://example.org/z.png>'
        '<a href="https://example.org/">a link is not a fetch</a>'
        '<script src="_static/local.js"></script>')
    (tmp_path / "b.css").write_text("@import 'https://fonts.example.org/f.css'; p{background:url(data:image/png;base64,AA)}")
    assert sorted(_remote_loads(tmp_path)) == [
        "a.html: //cdn.example.org/y.css", "a.html: http://example.org/z.png",
        "a.html: https://cdn.example.org/x.js", "b.css: https://fonts.example.org/f.css"]


@pytest.mark.slow
def test_the_built_documentation_fetches_nothing_from_another_host(built):
    """Read offline: maths (MathJax from a package), theme, gallery load only their own files."""
    assert _remote_loads(built) == []
    physics = (built / "physics.html").read_text()
    assert '_static/mathjax/tex-svg.js' in physics  # maths rendered, from the build itself
    assert (built / "_static" / "mathjax" / "tex-svg.js").stat().st_size > 1_000_000
