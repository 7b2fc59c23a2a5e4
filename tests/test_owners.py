"""One owner per rule (issue 21, "other rules with two owners"): the rules that several modules
used to write each on their own, checked where one can fail."""

from __future__ import annotations

import itertools

from vrelab.report.plots import frequency_groups
from vrelab.results import (
    Conditions,
    Estimate,
    LevelResult,
    VreResult,
    group_by_frequency,
)

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


# --------------------------------------------------------------------------- µg/gⁿ ↔ 1/gⁿ⁻¹
def _unit_literals() -> list[str]:
    """Lines of the package (but vrelab/units.py) writing the µg factor as a number (1e6, 1e-6,
    1e12) on a line about µg, VRC or a per-g coefficient."""
    import ast
    from pathlib import Path

    import vrelab

    src = Path(vrelab.__file__).parent
    hits = []
    for path in sorted(src.rglob("*.py")):
        if path.name == "units.py" and path.parent == src:
            continue
        text = path.read_text(encoding="utf-8")
        lines = text.splitlines()
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.Constant) and isinstance(node.value, float) and node.value in (1e6, 1e-6, 1e12):
                line = lines[node.lineno - 1]
                if any(w in line.lower() for w in ("ug", "µg", "per_g", "vrc", "k2", "k3", "k4")):
                    hits.append(f"{path.relative_to(src)}:{node.lineno}: {line.strip()}")
    return hits


def test_the_ug_factor_has_one_owner() -> None:
    assert _unit_literals() == []


def test_the_ug_owner_converts_a_datasheet_vrc() -> None:
    """A datasheet's 20 µg/g² is k2 = 2e-5 /g (1 µg = 1e-6 g, SI prefix), to the last bit in the
    loader and in the models alike (the models multiplied by 1e-6, the loader divided by 1e6:
    1.9999999999999998e-05 against 2e-05)."""
    from vrelab.models.nonlinearity import per_g_to_ug_per_g2, ug_per_g2_to_per_g
    from vrelab.sensor import load_sensor

    assert load_sensor("ideal", range_g=2, k2_ug_per_g2=20.0).k2_per_g == 2e-5
    assert ug_per_g2_to_per_g(20.0) == 2e-5
    assert per_g_to_ug_per_g2(2e-5) == 20.0


# --------------------------------------------------------------------------- the clipping kind
def _clip_kind_defaults() -> list[str]:
    """Places (but vrelab/models/kinds.py) that write a clipping kind as a default: a function's
    default value, an argparse ``default=``, or a ``.get(key, default)``."""
    import ast
    from pathlib import Path

    import vrelab

    src = Path(vrelab.__file__).parent
    kinds = {"censored", "truncated"}

    def is_kind(node: ast.AST | None) -> bool:
        return isinstance(node, ast.Constant) and node.value in kinds

    hits = []
    for path in sorted(src.rglob("*.py")):
        if path.relative_to(src).as_posix() == "models/kinds.py":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            found = False
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
                found = any(is_kind(d) for d in [*node.args.defaults, *node.args.kw_defaults])
            elif isinstance(node, ast.Call):
                found = any(k.arg == "default" and is_kind(k.value) for k in node.keywords) or (
                    isinstance(node.func, ast.Attribute) and node.func.attr == "get" and len(node.args) == 2
                    and is_kind(node.args[1]))
            if found:
                hits.append(f"{path.relative_to(src)}:{node.lineno}")
    return hits


def test_the_clip_kind_default_has_one_owner() -> None:
    assert _clip_kind_defaults() == []


def test_the_clip_kind_default_is_censored() -> None:
    """SPEC 1.1: physical saturation (a sample beyond a rail reads as the rail) is the default;
    the CLI's --kind and the API agree with it."""
    import inspect

    from vrelab.models.clipping import mean_shift
    from vrelab.models.kinds import DEFAULT_CLIP_KIND
    from vrelab.prediction import predict

    assert DEFAULT_CLIP_KIND == "censored"
    assert inspect.signature(mean_shift).parameters["kind"].default == "censored"
    assert inspect.signature(predict).parameters["kind"].default == "censored"


# --------------------------------------------------------------------------- the weighted mean, Type B
def test_gum_weighted_mean_scales_by_the_birge_ratio_only_upward() -> None:
    """By hand: 1 ± 1 and 3 ± 1 average to 2 with internal u 1/√2 and χ² = 2 (one dof), Birge
    ratio √2, so u = 1; 1 ± 1 and 1.5 ± 1 scatter less than their u (χ² = 0.125): u stays 1/√2."""
    import math

    from vrelab.gum import weighted_mean, weighted_mean_chi2
    from vrelab.results import Estimate

    assert weighted_mean_chi2([1.0, 3.0], [1.0, 1.0]) == (2.0, math.sqrt(0.5), 2.0)
    e = weighted_mean([Estimate(1.0, 1.0, "g"), Estimate(3.0, 1.0, "g")])
    assert (e.value, e.unit) == (2.0, "g") and math.isclose(e.u, 1.0, rel_tol=1e-15)
    e = weighted_mean([Estimate(1.0, 1.0, "g"), Estimate(1.5, 1.0, "g")])
    assert e.value == 1.25 and math.isclose(e.u, math.sqrt(0.5), rel_tol=1e-15)
    # weights 1/u²: 0 ± 1 and 10 ± 3 -> (0·1 + 10/9) / (1 + 1/9) = 1
    assert math.isclose(weighted_mean([Estimate(0.0, 1.0, "g"), Estimate(10.0, 3.0, "g")]).value, 1.0, rel_tol=1e-15)


def test_common_sensitivity_terms_in_closed_form() -> None:
    """A VRC = VRE/rms² scales by -2·r (reference) and p (DUT): u² = u_A² + ((2r)² + p²)·k²;
    with r = 1 %, p = 0.5 % and k2 = 100 ± 3: u = √(9 + (0.0004 + 0.000025)·10⁴) = √13.25."""
    import math

    from vrelab.gum import common_sensitivity_terms
    from vrelab.results import Estimate

    (k2, k3), note = common_sensitivity_terms(
        (Estimate(100.0, 3.0, "ug/g^2"), None), [{"u_reference_pct": 1.0}, {"u_dut_pct": 0.5}])
    assert k3 is None and note and math.isclose(k2.u, math.sqrt(13.25), rel_tol=1e-12)
    assert common_sensitivity_terms((k2,), [{}]) == ([k2], None)


def _sine_observation(vre_g: list[float]) -> object:
    import numpy as np

    from vrelab.identification import Observation

    return Observation(run=1, label="s", method="sine", static_g=1.0, freq_hz=80.0, profile=None,
                       rms_g=np.array([1.0, 2.0]), vre_g=np.array(vre_g), u_g=np.array([1e-6, 4e-6]))


def test_identify_apparent_vrc_is_the_birge_scaled_weighted_mean() -> None:
    """Levels at 1 and 2 g rms, u 1 and 4 µg: per level VRC = VRE/rms² with u/rms² = 1 µg/g²
    each. VREs of 100 and 400 µg lie on VRC = 100 µg/g² exactly: 100 ± 1/√2 (χ² = 0, not scaled
    down). VREs of 100 and 440 µg give 100 and 110 µg/g²: mean 105, χ² = 50 on one dof, so
    u = √50/√2 = 5 (Birge); the unscaled fit said 1/√2."""
    import math

    from vrelab.identification import apparent_vrc

    v, u = apparent_vrc(_sine_observation([100e-6, 400e-6]))  # type: ignore[arg-type]
    assert math.isclose(v, 100.0, rel_tol=1e-12) and math.isclose(u, math.sqrt(0.5), rel_tol=1e-12)
    v, u = apparent_vrc(_sine_observation([100e-6, 440e-6]))  # type: ignore[arg-type]
    assert math.isclose(v, 105.0, rel_tol=1e-12) and math.isclose(u, 5.0, rel_tol=1e-12)


# --------------------------------------------------------------------------- a test's durations
_DURATION_NAMES = {"seconds", "baseline_s", "sine_seconds", "--seconds", "--baseline"}


def _duration_defaults() -> list[str]:
    """Places (but vrelab/simulation/durations.py) that write a level's or a baseline's length as
    a number where a default goes: a parameter's or a field's default, an argparse ``default=``
    of ``--seconds``/``--baseline``, a ``.setdefault("seconds", 2.0)``, ``seconds=4.0 if ... else``."""
    import ast
    from pathlib import Path

    import vrelab

    src = Path(vrelab.__file__).parent

    def number(node: ast.AST | None) -> bool:
        return isinstance(node, ast.Constant) and type(node.value) in (int, float)

    hits = []
    for path in sorted(src.rglob("*.py")):
        rel = path.relative_to(src).as_posix()
        if rel == "simulation/durations.py":
            continue
        text = path.read_text(encoding="utf-8")
        lines = text.splitlines()
        for node in ast.walk(ast.parse(text)):
            found = False
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                a = node.args
                pos = [*a.posonlyargs, *a.args]
                pairs = [*zip(pos[len(pos) - len(a.defaults):], a.defaults), *zip(a.kwonlyargs, a.kw_defaults)]
                found = any(p.arg in _DURATION_NAMES and number(d) for p, d in pairs)
            elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
                found = node.target.id in _DURATION_NAMES and number(node.value)
            elif isinstance(node, ast.Call):
                first = node.args[0] if node.args else None
                named = isinstance(first, ast.Constant) and first.value in _DURATION_NAMES
                found = (named and any(k.arg == "default" and number(k.value) for k in node.keywords)) or (
                    named and isinstance(node.func, ast.Attribute) and node.func.attr == "setdefault"
                    and len(node.args) == 2 and number(node.args[1])) or any(
                    k.arg in _DURATION_NAMES and isinstance(k.value, ast.IfExp)
                    and (number(k.value.body) or number(k.value.orelse)) for k in node.keywords)
            if found:
                hits.append(f"{path.stem}: {lines[node.lineno - 1].strip()}")
    return hits


def test_a_tests_durations_have_one_owner() -> None:
    """Issue 31: a sine level lasted 2 s from ``run_sine_test`` and 4 s from ``vrelab simulate
    --freq``; the 2 s baseline was written in four places."""
    assert _duration_defaults() == [
        "demo: seconds: float = 16.0  # per vibration level",  # the demo's random level, its own choice
        # the example campaign's short files (2 s segments), its own choice
        "example_campaign: def write_campaign(folder: str | Path, truth: CampaignTruth | None = None, seconds: float = 2.0,",
        "example_campaign: def ensure_campaign(folder: str | Path, truth: CampaignTruth | None = None, seconds: float = 2.0,",
        "example_campaign: def campaign_document(sensor: Any, runs: Sequence[ExampleRun], seed: int = 0, seconds: float = 2.0,",
    ]


def test_the_command_line_and_the_api_run_the_same_sine_test() -> None:
    """``vrelab simulate --freq`` and ``plan_sine_test`` (``run_sine_test``) with no duration
    given make the same schedule: each level ``DEFAULT_LEVEL_S`` (rounded to whole periods),
    each baseline ``DEFAULT_BASELINE_S``."""
    from vrelab.cli import build_parser
    from vrelab.sensor import load_sensor
    from vrelab.shaker import plan_sine_test
    from vrelab.simulation.durations import DEFAULT_BASELINE_S, DEFAULT_LEVEL_S
    from vrelab.simulation.plan import TestPlan

    args = build_parser().parse_args(["simulate", "--sensor", "ideal", "--freq", "100", "--levels", "1"])
    assert (args.seconds, args.baseline) == (DEFAULT_LEVEL_S, DEFAULT_BASELINE_S)
    sensor = load_sensor("ideal", range_g=2.0)
    cli = TestPlan.sine(sensor, [100.0], [1.0], seconds=args.seconds, baseline_s=args.baseline).record(False)
    api = plan_sine_test(sensor, [100.0], [1.0])
    assert api.schedule == cli.schedule
    level = [s for s in api.schedule.segments if not s.is_baseline]
    assert len(level) == 1 and abs((level[0].end_s - level[0].start_s) - DEFAULT_LEVEL_S) < 0.01  # 1 period = 0.01 s
