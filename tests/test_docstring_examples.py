"""Every public function and class has an Examples section, and every Examples section runs.

The public API is what a user is shown: every callable name of ``dir(vrelab)`` and every
function and class the API pages document (``docs/api.rst`` and ``docs/api/*.rst``: each
``automodule`` with ``:members:`` — its listed members, else the module's ``__all__``, else
what autodoc takes, the public functions and classes defined in the module — and each
``autofunction``). The directives are parsed here from the same files sphinx reads, so a module
added to the docs is checked without touching this test. Deprecated aliases (a docstring whose
first line says so) are left out: their replacement carries the example.

Each Examples section is run by :mod:`doctest` in a fresh namespace, in a temporary working
directory holding a link to the repository's ``examples/`` folder (the committed example data
and the example campaign that ``tests/conftest.py`` generates), so an example reads
``examples/...`` as a user in the repository's root would, and writes only into the temporary
folder.

Printed numbers: an example prints values rounded to what its computation justifies
(``print(f"{x:.3f}")``), so its output is the same on any CPU. Where a rounded value sits on a
rounding boundary an ulp can still move its last digit, so the checker accepts a number that
differs from the expected one by at most one unit of its last printed digit (the role of
pytest-doctestplus's FLOAT_CMP, which the project does not depend on); everything else is
compared as doctest does, with NORMALIZE_WHITESPACE and ELLIPSIS.
"""

from __future__ import annotations

import doctest
import importlib
import inspect
import re
from pathlib import Path

import pytest

import vrelab

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"

_DIRECTIVE = re.compile(r"^\.\. (automodule|autofunction|autoclass):: (\S+)[ \t]*\n((?:[ \t]+:.*\n(?:[ \t]{4,}\S.*\n)*)*)",
                        re.M)
_SECTION = re.compile(r"^[ \t]*Examples\n[ \t]*-{8,}\n", re.M)
_NEXT_SECTION = re.compile(r"^[ \t]*\S[^\n]*\n[ \t]*-{3,}[ \t]*$", re.M)


def _module_members(module_name: str, options: str) -> list[str]:
    """The names ``.. automodule:: module_name`` with ``options`` documents (autodoc's rule)."""
    module = importlib.import_module(module_name)
    listed = re.search(r":members:(.*(?:\n[ \t]{4,}\S.*)*)", options)
    if listed and listed.group(1).strip():
        return [n.strip() for n in listed.group(1).replace("\n", " ").split(",") if n.strip()]
    if hasattr(module, "__all__"):
        return list(module.__all__)
    return [n for n, obj in vars(module).items()
            if (inspect.isfunction(obj) or inspect.isclass(obj)) and getattr(obj, "__module__", None) == module_name]


def _documented() -> dict[str, object]:
    """Dotted name -> object of every function and class the API pages document."""
    found: dict[str, object] = {}
    for page in [DOCS / "api.rst", *sorted((DOCS / "api").glob("*.rst"))]:
        for kind, target, options in _DIRECTIVE.findall(page.read_text(encoding="utf-8")):
            if kind == "automodule":
                if ":members:" not in options:
                    continue
                module = importlib.import_module(target)
                for name in _module_members(target, options):
                    found[f"{target}.{name}"] = getattr(module, name)
            else:
                module_name, _, name = target.rpartition(".")
                found[target] = getattr(importlib.import_module(module_name), name)
    return found


def public_api() -> dict[str, object]:
    """Dotted name -> object, one name per object (the front door's where it has one)."""
    named = {f"vrelab.{n}": getattr(vrelab, n) for n in dir(vrelab) if not n.startswith("_")}
    named.update({k: v for k, v in _documented().items() if not k.rpartition(".")[2].startswith("_")})
    out: dict[str, object] = {}
    seen: set[int] = set()
    for name, obj in named.items():
        if not (inspect.isfunction(obj) or inspect.isclass(obj)) or id(obj) in seen:
            continue
        seen.add(id(obj))
        first_line = (inspect.getdoc(obj) or "").strip().splitlines()[:1]
        if first_line and "deprecated" in first_line[0].lower():
            continue
        out[name] = obj
    return out


PUBLIC = public_api()


def examples_section(obj: object) -> str | None:
    """The text of the object's numpydoc Examples section, or None (its own docstring only:
    a class does not borrow its base's)."""
    doc = obj.__doc__ if inspect.isclass(obj) else inspect.getdoc(obj)
    doc = inspect.cleandoc(doc or "")
    start = _SECTION.search(doc)
    if start is None:
        return None
    rest = doc[start.end():]
    end = _NEXT_SECTION.search(rest)
    return rest[: end.start()] if end else rest


class _Checker(doctest.OutputChecker):
    """doctest's checker, then the same with each expected number accepted within one unit of
    its last printed digit (an ulp that moves a rounded value across a rounding boundary)."""

    _NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")

    def check_output(self, want: str, got: str, optionflags: int) -> bool:
        if super().check_output(want, got, optionflags):
            return True
        wanted, gotten = self._NUMBER.findall(want), self._NUMBER.findall(got)
        if not wanted or len(wanted) != len(gotten):
            return False
        for w, g in zip(wanted, gotten):
            if abs(float(w) - float(g)) > self._last_digit(w) * (1 + 1e-9):
                return False
        numbers = iter(wanted)
        return super().check_output(want, self._NUMBER.sub(lambda m: next(numbers), got), optionflags)

    @staticmethod
    def _last_digit(text: str) -> float:
        mantissa, _, exponent = text.lower().partition("e")
        decimals = len(mantissa.partition(".")[2])
        return 10.0 ** (int(exponent or 0) - decimals)


def test_checker_accepts_one_last_digit_only():
    """The tolerance is one unit of the last printed digit, no more (the checker's own test)."""
    flags = doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS
    checker = _Checker()
    assert checker.check_output("-0.083 g\n", "-0.082 g\n", flags)
    assert checker.check_output("1.25e-03\n", "1.26e-03\n", flags)
    assert not checker.check_output("-0.083 g\n", "-0.081 g\n", flags)
    assert not checker.check_output("-0.083 g\n", "-0.083 mg\n", flags)
    assert not checker.check_output("2\n", "4\n", flags)


def test_public_api_is_found():
    """The collection sees the front door and the API pages (a broken parse would empty it)."""
    for name in ("vrelab.predict", "vrelab.simulate", "vrelab.load_sensor", "vrelab.models.clipping.censored_mean_shift",
                 "vrelab.gum.coverage_factor", "vrelab.sensor.configs.Mechanics"):
        assert name in PUBLIC, name
    assert "vrelab.predict_triaxial" not in PUBLIC  # deprecated alias
    assert len(PUBLIC) > 200


def test_every_public_name_has_examples():
    missing = sorted(name for name, obj in PUBLIC.items() if examples_section(obj) is None)
    assert not missing, "no Examples section in the docstring of: " + ", ".join(missing)


@pytest.fixture
def in_tmp(tmp_path, monkeypatch):
    (tmp_path / "examples").symlink_to(ROOT / "examples", target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    return tmp_path


@pytest.mark.parametrize("name", sorted(n for n, o in PUBLIC.items() if examples_section(o) is not None))
def test_examples_run(name, in_tmp):
    section = examples_section(PUBLIC[name])
    assert section is not None
    test = doctest.DocTestParser().get_doctest(section, {}, name, None, 0)
    assert test.examples, f"{name}: its Examples section has no >>> line"
    flags = doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS
    runner = doctest.DocTestRunner(checker=_Checker(), optionflags=flags)
    report: list[str] = []
    runner.run(test, out=report.append)
    assert runner.failures == 0, "".join(report)
