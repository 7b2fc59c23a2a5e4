"""The line-residual form of a segment's DUT mean is built once per (n, ρ), not once per segment.

:func:`vrelab.analysis.levels._line_residual_form` builds n×n matrices and their products
(O(n³)) that depend on the segment's number of interior windows n and the kernel correlation ρ
only, not on the data. A record's levels and baselines share a handful of lengths, so issue
29's 2 h record (120 levels of 40 s) rebuilt 400×400 products 240 times: 80 % of its analysis.
The cached ν must be the fresh computation's, bit for bit (same machine, same inputs).
"""

from __future__ import annotations

from test_analysis_helpers import make_record
from vrelab.analysis import levels as L
from vrelab.analysis.pipeline import reduce
from vrelab.analysis.segmentation import kernel_correlation


def test_line_residual_form_is_built_once_per_length(monkeypatch):
    built: list[int] = []
    fresh = L._line_residual_form

    def counted(n, rho):
        built.append(n)
        return fresh(n, rho)

    monkeypatch.setattr(L, "_line_residual_form", counted)
    L._line_residual_dof.cache_clear()  # another test may have built these lengths already
    # six levels and seven baselines of the same lengths; AR(1) noise (φ = 0.98, τ ≈ 2 windows)
    # caps the batches below 10·τ, the branch that needs ν
    tr = make_record(4, levels_g=(0.3, 0.6, 0.9, 1.2, 1.5, 1.8), vre_g=(0.0,) * 6, t_on_s=8.0, t_off_s=6.0)
    red = reduce(tr.record, tr.schedule, "random")
    assert len(red.levels) == 6
    assert built, "no segment took the capped-batches branch: the test no longer exercises the form"
    assert len(built) == len(set(built)), f"a form rebuilt for the same length: {sorted(built)}"
    rho = kernel_correlation(red.stats.window)
    for n in set(built):
        assert L._line_residual_dof(n, rho) == fresh(n, rho)[3]
