"""The suite's scheduling hint (tests/conftest.py HEAVY_FIRST, `make test`'s --dist loadfile
--no-loadscope-reorder): it names files that exist, and reorders without losing or splitting any."""

from __future__ import annotations

from pathlib import Path

from conftest import HEAVY_FIRST, _file_order

TESTS = Path(__file__).resolve().parent


def test_heavy_first_names_test_files():
    """A renamed or split file left in HEAVY_FIRST would silently lose its place at the front."""
    missing = [name for name in HEAVY_FIRST if not (TESTS / f"{name}.py").is_file()]
    assert not missing, f"HEAVY_FIRST names no test file: {missing}"
    assert len(set(HEAVY_FIRST)) == len(HEAVY_FIRST)


class _Item:
    def __init__(self, nodeid: str) -> None:
        self.nodeid = nodeid


def test_file_order_puts_heavy_files_first_and_keeps_every_test_once_in_its_order():
    ids = ["tests/test_a.py::t1", "tests/test_lint.py::t1", "tests/test_b.py::t1", "tests/test_a.py::t2",
           f"tests/{HEAVY_FIRST[0]}.py::t1", "tests/test_b.py::t2", "tests/test_b.py::t3", "tests/test_lint.py::t2"]
    got = [i.nodeid for i in _file_order([_Item(n) for n in ids])]
    assert sorted(got) == sorted(ids)
    assert got == [f"tests/{HEAVY_FIRST[0]}.py::t1", "tests/test_lint.py::t1", "tests/test_lint.py::t2",
                   "tests/test_b.py::t1", "tests/test_b.py::t2", "tests/test_b.py::t3",
                   "tests/test_a.py::t1", "tests/test_a.py::t2"]
