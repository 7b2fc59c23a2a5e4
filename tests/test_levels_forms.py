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


def test_second_difference_var_cached_by_exact_inputs():
    """The low-frequency term's geometry variances are cached by the exact bits of their inputs
    (the within-baseline geometry repeats at every level): a repeat is a cache hit with the same
    bits as the computation itself, a caller's copy can be changed without touching the cache,
    and inputs differing in one bit (-0.0 and 0.0 included) are computed, not looked up."""
    from vrelab.analysis import levels as L

    boxes = ((0.0, 4.0, 1.0), (-4.0, 4.0, -0.5), (4.0, 4.0, -0.5))
    direct = L._second_difference_var(boxes, L.ALPHAS)
    before = L._second_difference_var_cached.cache_info()
    first = L.second_difference_var(boxes, L.ALPHAS)
    first[:] = -1.0  # a caller's array: the cache must not see this
    again = L.second_difference_var(boxes, L.ALPHAS)
    after = L._second_difference_var_cached.cache_info()
    assert after.hits >= before.hits + 1
    assert again.tobytes() == direct.tobytes()
    shifted = ((-0.0, 4.0, 1.0), (-4.0, 4.0, -0.5), (4.0, 4.0, -0.5))
    misses = L._second_difference_var_cached.cache_info().misses
    assert L.second_difference_var(shifted, L.ALPHAS).tobytes() == L._second_difference_var(shifted, L.ALPHAS).tobytes()
    assert L._second_difference_var_cached.cache_info().misses == misses + 1


def test_second_difference_var_shared_by_the_same_geometry_at_other_times():
    """A regular schedule repeats a level's geometry (level and baselines) at every level: the
    variances depend on the boxes' times about their mean, not on the record's clock, so the
    same geometry later in the record is a cache hit, with the bits of a fresh computation.
    (Times and lengths here are exact in binary: both geometries' offsets and spans are the
    same bits.)"""
    early = ((100.0, 4.0, 1.0), (96.0, 4.0, -0.5), (104.0, 4.0, -0.5))
    late = ((1000.0, 4.0, 1.0), (996.0, 4.0, -0.5), (1004.0, 4.0, -0.5))
    first = L.second_difference_var(early, L.ALPHAS)
    hits = L._second_difference_var_cached.cache_info().hits
    again = L.second_difference_var(late, L.ALPHAS)
    assert L._second_difference_var_cached.cache_info().hits == hits + 1
    assert again.tobytes() == first.tobytes() == L._second_difference_var(late, L.ALPHAS).tobytes()
