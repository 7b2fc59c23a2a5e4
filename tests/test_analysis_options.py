"""The reduction's options as dataclasses (issue 21, "the reduction's signatures").

Each option is checked once, when its dataclass is made, with the words ``vrelab analyze`` prints
for it; the former flat keywords still give the same result for one release, with a
DeprecationWarning; an unknown keyword is a TypeError as for any function.
"""

from __future__ import annotations

import dataclasses

import pytest

from test_analysis_helpers import make_record
from vrelab.analysis import (
    BudgetOptions,
    FitOptions,
    ReductionOptions,
    analyze,
    analyze_channels,
    analyze_full,
    reduce,
    reduce_record,
)
from vrelab.gum import TypeB
from vrelab.record import write_record_hdf5

# (CLI option, value, the dataclass that refuses it, the line both print)
REFUSED = [
    ("--settle", "-1", lambda: ReductionOptions(settle_s=-1.0), "settle_s must be >= 0, got -1.0"),
    ("--rail", "-1", lambda: ReductionOptions(rail_g=-1.0), "rail_g must be a finite number > 0, got -1.0"),
    ("--limit", "0", lambda: BudgetOptions(limit_g=0.0), "limit_g must be a finite number > 0, got 0.0"),
]


@pytest.mark.parametrize("flag, value, make, words", REFUSED, ids=[r[0] for r in REFUSED])
def test_a_bad_option_is_refused_with_the_words_the_cli_prints(tmp_path, capsys, flag, value, make, words):
    from vrelab.cli import main

    with pytest.raises(ValueError) as exc:
        make()
    assert str(exc.value) == words
    tr = make_record(3, levels_g=(0.5,), vre_g=(1e-3,), t_off_s=4.0, t_on_s=4.0)
    path = tmp_path / "r.h5"
    write_record_hdf5(path, tr.record.fs_hz, tr.record.blocks(1 << 12, ["reference", "dut"]))
    assert main(["analyze", str(path), "--dut", "dut", "--reference", "reference", flag, value]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0]


def test_each_field_is_checked_when_the_options_are_made():
    bad = [
        (lambda: ReductionOptions(band_hz=(500.0, 100.0)), "band_hz must be F1:F2 with 0 < F1 < F2, got 500:100"),
        (lambda: ReductionOptions(accept=frozenset({"units"})), "accept: unknown check 'units'"),
        (lambda: ReductionOptions(block_size=0), "block_size must be >= 1, got 0"),
        (lambda: ReductionOptions(settle_s=float("nan")), "settle_s must be >= 0, got nan"),
        (lambda: FitOptions(clip_kind="soft"), "clip_kind must be one of censored, truncated; got 'soft'"),  # type: ignore[arg-type]
        (lambda: FitOptions(static_g=float("inf")), "static_g must be finite, got inf"),
        (lambda: TypeB(u_dut_pct=-1.0), "u_dut_pct"),
    ]
    for make, words in bad:
        with pytest.raises(ValueError, match="^" + words.replace("(", r"\(").replace(")", r"\)")):
            make()
    # normalised once: numbers as float, a band as a tuple, a check name as a set of one
    opt = ReductionOptions(band_hz=[20, 400], settle_s=1, rail_g=2, accept="method", block_size=4096.0)  # type: ignore[arg-type]
    assert opt.band_hz == (20.0, 400.0) and opt.settle_s == 1.0 and opt.rail_g == 2.0
    assert opt.accept == frozenset({"method"}) and opt.block_size == 4096
    with pytest.raises(dataclasses.FrozenInstanceError):
        opt.settle_s = 0.0  # type: ignore[misc]
    # replace() checks again
    with pytest.raises(ValueError, match="rail_g"):
        dataclasses.replace(opt, rail_g=0.0)


def _one_warning_at_the_callers_line(record: pytest.WarningsRecorder, where: str, keywords: str) -> None:
    # one warning per call, naming the function and every former keyword it was given (sorted),
    # and pointing at the caller's line (here), not at vrelab's
    assert len(record) == 1, [str(w.message) for w in record]
    message = str(record[0].message)
    assert message.startswith(f"{where}(): the keywords {keywords} are deprecated and will be removed in the next "
                              "release; pass options=ReductionOptions(...)"), message
    assert record[0].filename == __file__


def test_the_former_keywords_give_the_same_result_with_a_deprecation_warning():
    """Kept for one release (issue 21): each function of the reduction that took the flat keywords
    still takes them, maps them onto the dataclasses field by field (``fit_k4`` is
    ``FitOptions.k4``) and gives the options' result identically, with one DeprecationWarning.
    The options change the result (so the comparison can fail). Everywhere else the suite turns
    this warning into an error (``filterwarnings`` in pyproject.toml): vrelab does not call them."""
    lv = (0.5, 1.0, 1.5, 2.0)
    tr = make_record(12, levels_g=lv, vre_g=tuple(500e-6 * r * r for r in lv), noise_g=2e-4)
    options = ReductionOptions(settle_s=1.5, band_hz=(60.0, 240.0))
    fit, budget = FitOptions(static_g=0.9, k4=True), BudgetOptions(TypeB(u_reference_pct=1.0), 0.01)
    flat = dict(settle_s=1.5, band_hz=(60.0, 240.0), static_g=0.9, fit_k4=True, typeb=TypeB(u_reference_pct=1.0),
                limit_g=0.01)
    all_keywords = "band_hz, fit_k4, limit_g, settle_s, static_g, typeb"
    new = analyze(tr.record, "random", tr.schedule, options=options, fit=fit, budget=budget)
    with pytest.warns(DeprecationWarning) as caught:
        old = analyze(tr.record, "random", tr.schedule, **flat)
    _one_warning_at_the_callers_line(caught, "analyze", all_keywords)
    plain = analyze(tr.record, "random", tr.schedule)
    d_new, d_old, d_plain = new.to_dict(), old.to_dict(), plain.to_dict()
    assert d_new == d_old
    assert d_new["levels"] != d_plain["levels"] and d_new["conditions"] != d_plain["conditions"]
    assert new.fits != plain.fits
    assert all("decision" in lv for lv in d_new["levels"])

    with pytest.warns(DeprecationWarning) as caught:
        old_full, _ = analyze_full(tr.record, "random", tr.schedule, **flat)
    _one_warning_at_the_callers_line(caught, "analyze_full", all_keywords)
    assert old_full.to_dict() == d_new
    with pytest.warns(DeprecationWarning) as caught:
        [(_, old_channel, _)] = analyze_channels(tr.record, None, "random", tr.schedule, **flat)
    # static_g is analyze_channels' own parameter (a number or one per DUT), not a former keyword
    _one_warning_at_the_callers_line(caught, "analyze_channels", "band_hz, fit_k4, limit_g, settle_s, typeb")
    assert old_channel.to_dict() == d_new

    values = [lv.vre.value for lv in reduce(tr.record, tr.schedule, "random", options=options).levels]
    assert values == [lv.vre.value for lv in new.levels]
    with pytest.warns(DeprecationWarning) as caught:
        red = reduce(tr.record, tr.schedule, "random", settle_s=1.5, band_hz=(60.0, 240.0))
    _one_warning_at_the_callers_line(caught, "reduce", "band_hz, settle_s")
    assert [lv.vre.value for lv in red.levels] == values
    with pytest.warns(DeprecationWarning) as caught:
        levels, _ = reduce_record(tr.record, tr.schedule, "random", settle_s=1.5, band_hz=(60.0, 240.0))
    _one_warning_at_the_callers_line(caught, "reduce_record", "band_hz, settle_s")
    assert [lv.vre.value for lv in levels] == values


def test_an_unknown_keyword_is_a_type_error():
    tr = make_record(3, levels_g=(0.5,), vre_g=(1e-3,), t_off_s=4.0, t_on_s=4.0)
    with pytest.raises(TypeError, match="unexpected keyword argument 'settle'"):
        analyze(tr.record, settle=1.0)


def test_the_reduction_takes_its_options_as_three_objects():
    """Issue 21's row: analyze_full took 20 parameters, reduce 12, _level 10, _with_budget 10.
    Now the options are three keyword-only objects, and no function of the reduction takes more
    than ten parameters (the former flat keywords only through ``**keywords``, for one release)."""
    import inspect

    from vrelab.analysis import levels, pipeline

    for fn in (pipeline.analyze_full, pipeline.analyze, pipeline.analyze_channels, pipeline.reduce,
               pipeline.reduce_record, pipeline.with_budget, levels.reduce_level):
        params = [p for p in inspect.signature(fn).parameters.values() if p.kind is not p.VAR_KEYWORD]
        assert len(params) <= 10, (fn.__name__, len(params))
        for name in ("options", "fit", "budget"):
            if name in inspect.signature(fn).parameters and fn is not pipeline.with_budget:
                assert inspect.signature(fn).parameters[name].kind is inspect.Parameter.KEYWORD_ONLY
