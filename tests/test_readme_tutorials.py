"""The designer's path's and the two tutorials' commands and Python blocks (docs/designer-path.md,
tutorial-test-engineer.md, tutorial-designer.md) run as written, in page order, by the rules of
tests/test_readme.py. A file of their own (test_readme.PAGE_FILES) so that pytest-xdist's
--dist loadfile runs them beside the other pages, on the other worker."""

from __future__ import annotations

import pytest

from test_readme import PAGE_FILES, local_scheduler, page_step_params, run_page_step, workspaces  # noqa: F401  (fixtures)

pytestmark = [pytest.mark.slow, pytest.mark.timeout(300)]


@pytest.mark.parametrize(("page", "k", "kind", "what"), page_step_params(PAGE_FILES["test_readme_tutorials"]))
def test_page_step_runs(page: str, k: int, kind: str, what: object, workspaces, tmp_path_factory,  # noqa: F811
                        request, monkeypatch) -> None:
    run_page_step(page, k, kind, what, workspaces, tmp_path_factory, request, monkeypatch)
