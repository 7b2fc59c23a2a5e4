"""One owner per rule (issue 21, "other rules with two owners"): the rules that several modules
used to write each on their own, checked where one can fail."""

from __future__ import annotations

import itertools

from vrelab.report.plots import frequency_groups
from vrelab.results import Conditions, Estimate, LevelResult, VreResult, group_by_frequency

# Three drive frequencies 0.9 % apart: 100 and 100.9 Hz are one sine point (within 1 %,
# results.FREQ_RTOL), 100.9 and 101.8 Hz too, but 100 and 101.8 Hz (1.8 %) are not. Grouping
# against the first item seen, as the report's plots did, gave one group or two depending on
# which level came first; against the lowest after sorting, always [100, 100.9] and [101.8].
FREQS = (100.0, 100.9, 101.8)


def test_group_by_frequency_does_not_depend_on_input_order() -> None:
    for order in itertools.permutations(FREQS):
        assert group_by_frequency(order, float) == [[100.0, 100.9], [101.8]]


def test_group_by_frequency_separates_distinct_points_and_keeps_ties_in_order() -> None:
    items = [("b", 200.0), ("a", 100.0), ("c", 200.0), ("d", 400.0)]
    assert group_by_frequency(items, lambda x: x[1]) == [[("a", 100.0)], [("b", 200.0), ("c", 200.0)], [("d", 400.0)]]
    assert group_by_frequency([], float) == []


def _result(freqs: tuple[float | None, ...]) -> VreResult:
    levels = tuple(LevelResult(rms_g=1.0 + i, vre=Estimate(-0.001 * (i + 1), 1e-4, "g"), freq_hz=f)
                   for i, f in enumerate(freqs))
    return VreResult(method="sine", conditions=Conditions(), levels=levels)


def test_report_frequency_groups_do_not_depend_on_level_order() -> None:
    for order in itertools.permutations(FREQS):
        groups = frequency_groups(_result(order))
        assert [sorted(x.freq_hz for x in pts) for _, pts, _ in groups] == [[100.0, 100.9], [101.8]]


def test_report_frequency_groups_put_random_levels_first_in_one_group() -> None:
    groups = frequency_groups(_result((200.0, None, None)))
    assert [(fq, len(pts)) for fq, pts, _ in groups] == [(None, 2), (200.0, 1)]
