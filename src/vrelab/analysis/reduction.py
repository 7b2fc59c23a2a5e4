"""The reduction's former single module, kept importable: its names now live in

* :mod:`vrelab.analysis.options`: :class:`~vrelab.analysis.options.ReductionOptions`,
  :class:`~vrelab.analysis.options.FitOptions`, :class:`~vrelab.analysis.options.BudgetOptions`;
* :mod:`vrelab.analysis.sine`: a sine level's second pass (drive frequency, whole-period
  batches, IEEE Std 1057 fits);
* :mod:`vrelab.analysis.levels`: baselines, bracketing, the low-frequency term, one level's VRE;
* :mod:`vrelab.analysis.pipeline`: record -> :class:`~vrelab.analysis.pipeline.Reduction` ->
  fits and budget -> :class:`~vrelab.results.VreResult` (``reduce``, ``analyze``, ...).

New code imports from those modules (or from :mod:`vrelab.analysis`); this one only re-exports.
"""

from __future__ import annotations

from vrelab.analysis.levels import (
    ALPHAS,
    MIN_SEGMENT_WINDOWS,
    Baseline,
    LowFrequency,
    bracket,
    dut_mean_estimate,
    low_frequency,
    second_difference_var,
)
from vrelab.analysis.options import (
    ACCEPTABLE,
    DEFAULT_BAND_HZ,
    DEFAULT_BLOCK,
    BudgetOptions,
    FitOptions,
    ReductionOptions,
    default_band,
)
from vrelab.analysis.pipeline import (
    Reduction,
    analyze,
    analyze_channels,
    analyze_full,
    reduce,
    reduce_record,
    with_budget,
)
from vrelab.analysis.sine import estimate_frequency, whole_period_batch
from vrelab.record import DEFAULT_SETTLE_S

__all__ = [
    "ACCEPTABLE",
    "ALPHAS",
    "DEFAULT_BAND_HZ",
    "DEFAULT_BLOCK",
    "DEFAULT_SETTLE_S",
    "MIN_SEGMENT_WINDOWS",
    "Baseline",
    "BudgetOptions",
    "FitOptions",
    "LowFrequency",
    "Reduction",
    "ReductionOptions",
    "analyze",
    "analyze_channels",
    "analyze_full",
    "bracket",
    "default_band",
    "dut_mean_estimate",
    "estimate_frequency",
    "low_frequency",
    "reduce",
    "reduce_record",
    "second_difference_var",
    "whole_period_batch",
    "with_budget",
]
