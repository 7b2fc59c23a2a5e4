"""The documentation builds with warnings as errors (issue 21): the physics, the tutorials, the
gallery (its examples run), the CLI reference from the parser and the API reference from the
docstrings. A docstring that is not valid reST in a public module fails here."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_the_documentation_builds_without_a_warning(tmp_path):
    # a copy: sphinx-gallery writes its generated pages beside the sources
    docs = tmp_path / "docs"
    shutil.copytree(ROOT / "docs", docs, ignore=shutil.ignore_patterns("_build", "auto_examples", "sg_execution_times.rst"))
    env = {**os.environ, "MPLBACKEND": "Agg",
           "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run(
        [sys.executable, "-m", "sphinx", "-b", "html", "-W", "--keep-going", "-q", str(docs), str(tmp_path / "html")],
        capture_output=True, text=True, env=env, timeout=300,
    )
    assert done.returncode == 0, done.stderr[-4000:]
    html = tmp_path / "html"
    cli = (html / "cli.html").read_text()
    for command in ("predict", "simulate", "analyze", "campaign", "identify", "report"):  # from the parser
        assert f'id="{command}"' in cli or f"vrelab {command}" in cli, command
    assert "vrelab.prediction.front.predict" in (html / "api" / "predict.html").read_text()
    gallery = (html / "auto_examples" / "plot_clipping_models.html").read_text()
    assert "-82.9 mg" in gallery  # printed by the example at build: SPEC 1.1's -83 mg
    assert (html / "physics.html").is_file() and (html / "tutorial-designer.html").is_file()
