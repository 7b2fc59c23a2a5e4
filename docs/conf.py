"""Sphinx configuration of vrelab's documentation (``make docs``; tests/test_docs.py builds it
with warnings as errors)."""

import os
import re
import shutil
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
if (HERE.parent / "src" / "vrelab").is_dir():  # the source tree beside these docs, not an installed copy
    sys.path.insert(0, str(HERE.parent / "src"))
sys.path.insert(0, str(HERE))  # _cli: the parser as the CLI reference reads it
os.environ.setdefault("MPLBACKEND", "Agg")

import vrelab  # noqa: E402

project = "vrelab"
author = "the vrelab developers"
copyright = "the vrelab developers, BSD-3-Clause"
release = vrelab.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "numpydoc",  # numpy-style sections; renames each docstring's [1] references so pages do not clash
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "myst_parser",
    "sphinxarg.ext",
    "sphinx_gallery.gen_gallery",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
myst_enable_extensions = ["dollarmath", "amsmath", "deflist"]
myst_heading_anchors = 3
exclude_patterns = ["_build", "examples/README.txt"]
templates_path: list[str] = []

autodoc_member_order = "bysource"
autodoc_typehints = "signature"
autodoc_default_options = {"members": True, "show-inheritance": False}
numpydoc_show_class_members = False  # autodoc's :members: lists them once
numpydoc_class_members_toctree = False
numpydoc_validation_checks: set[str] = set()  # the build checks the reST, not the docstring style

sphinx_gallery_conf = {
    "examples_dirs": "examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/plot_",
    "download_all_examples": False,
    "remove_config_comments": True,
    "abort_on_example_error": True,
    "within_subsection_order": "FileNameSortKey",
    # its execution-times pages load jQuery and DataTables from CDNs; the docs fetch nothing
    # from another host (tests/test_docs.py)
    "write_computation_times": False,
}

# pydata-sphinx-theme (pvlib's and xarray's): a wide content column and an API sidebar; its
# assets (Bootstrap, Font Awesome) ship in the package, so a page reads offline.
html_theme = "pydata_sphinx_theme"
html_title = f"vrelab {release}"
html_static_path: list[str] = []
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "footer_start": ["copyright"],
    "footer_end": [],
}

# Maths offline: MathJax 3 from a PyPI package (django-static-mathjax, MathJax's own es5 build,
# no Python dependency) instead of sphinx's default CDN URL. tex-svg.js is one self-contained
# file (its fonts are paths inside it), copied into _static/mathjax when the build finishes.
mathjax_path = "mathjax/tex-svg.js"

# the section sidebar only where a section has pages (the API reference, the gallery); the
# single pages give its width to the text
html_sidebars = {"index": [], "physics": [], "tutorial-*": [], "cli": []}


def _mathjax_file() -> Path:
    import mathjax  # django-static-mathjax

    return Path(mathjax.__file__).resolve().parent / "static" / "mathjax" / "es5" / "tex-svg.js"


def _copy_mathjax(app, exception):
    if exception is None and app.builder.format == "html":
        target = Path(app.outdir) / "_static" / "mathjax"
        target.mkdir(parents=True, exist_ok=True)
        shutil.copy2(_mathjax_file(), target / "tex-svg.js")

# A docstring's References list is a bibliography: an entry its text does not cite is not an
# error (numpydoc turns each ``.. [1]`` into a citation unique to its docstring).
suppress_warnings = ["ref.citation"]

# The docstrings write absolute values as |x| (|VRE|, |H(f)|²), which reST reads as a
# substitution reference. Rather than asking every docstring to escape them, escape each |x|
# outside inline literals, roles and ``.. math::`` blocks (where | is math) before parsing.
_SPANS = re.compile(r"(``.+?``|:[\w:.-]+:`[^`]*`|`[^`]*`_{0,2})")
_BARS = re.compile(r"(?<!\\)\|([^\s|`](?:[^|`\n]*?[^\s|`\\])?)\|")


def _escape_absolute_bars(app, what, name, obj, options, lines):
    math_indent = None
    for i, line in enumerate(lines):
        stripped = line.lstrip()
        indent = len(line) - len(stripped)
        if math_indent is not None:
            if not stripped or indent > math_indent:
                continue
            math_indent = None
        if stripped.startswith(".. math::"):
            math_indent = indent
            continue
        if re.match(r"\|(\s|$)|\+[-=]", stripped):  # a table row or a line block
            continue
        parts = _SPANS.split(line)
        lines[i] = "".join(p if k % 2 else _BARS.sub(r"\\|\1\\|", p) for k, p in enumerate(parts))


def _numpydoc_template_once() -> None:
    """numpydoc 1.11's ``get_doc_object`` makes a new jinja2 environment for each docstring it
    renders, so its one template (numpydoc_docstring.rst) was compiled again for each of ~1400
    docstrings: ~15 s of CPU, a quarter of the build. The environment holds no state a render
    changes, so one per kind of loader numpydoc passes (the builder's; a plain file loader when it
    reads a signature) compiles the template once. Made in ``setup``, so each build starts afresh."""
    from jinja2.sandbox import SandboxedEnvironment
    from numpydoc import docscrape_sphinx

    made: dict[type, SandboxedEnvironment] = {}

    def environment(*, loader):
        if type(loader) not in made:
            made[type(loader)] = SandboxedEnvironment(loader=loader)
        return made[type(loader)]

    docscrape_sphinx.SandboxedEnvironment = environment


def setup(app):
    _mathjax_file().stat()  # a missing package fails the build here, not a reader's page later
    _numpydoc_template_once()
    app.connect("build-finished", _copy_mathjax)
    app.connect("autodoc-process-docstring", _escape_absolute_bars, priority=600)  # after numpydoc
