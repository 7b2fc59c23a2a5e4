"""Every public result shows itself briefly (issue 33's API row): a repr of a line or two with
its type, its headline value ± u and its count of levels (never ``np.float64(...)``), a notebook
table (``_repr_html_``), and, with levels, ``to_dataframe()`` whose columns are the result's
fields with units in their names. The results are built by hand (their numbers are arbitrary:
what is checked is that the display shows the very numbers the object holds), so this file runs
in a second."""

from __future__ import annotations

import math
import sys
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from vrelab import gum
from vrelab.campaigns.summary import ChannelSummary
from vrelab.identification.api import Identification
from vrelab.identification.observation import ChannelModel
from vrelab.prediction.results import LevelPrediction, Prediction
from vrelab.results import (
    ClipModel,
    Conditions,
    DriveWaveform,
    Estimate,
    FitResult,
    K2K3Model,
    K2Model,
    LevelResult,
    NoiseResult,
    VrcK4Model,
    VrcModel,
    VreResult,
)
from vrelab.sweep import SweepResult
from vrelab.triaxial.analyze import TriaxialLevel
from vrelab.triaxial.profile import TriaxialSine
from vrelab.triaxial.result import TriaxialPart

# "a line or two": a terminal's two lines of 120 columns, and a little more for the type's name
MAX_REPR = 300

f64 = np.float64  # numpy scalars, as the analysis returns them: the repr must not show their type


def _level(rms: float, vre: float, u: float, freq: float | None = None) -> LevelResult:
    return LevelResult(rms_g=f64(rms), vre=Estimate(f64(vre), f64(u)), freq_hz=freq, u_rms_g=f64(0.002 * rms),
                       duration_s=4.0, n_samples=16000, flags=("over-range",) if rms > 2 else (), dof=f64(40.0))


VRC = Estimate(f64(-12.34), f64(0.56), "ug/g^2")
FIT = FitResult(VrcModel({"vrc_ug_per_g2": VRC}), n_points=3, chi2_reduced=f64(0.8),
                levels_used=(1.0, 2.0, 3.0), notes=("a note",))
LEVELS = tuple(_level(r, -12.34e-6 * r * r, 1.1e-6) for r in (1.0, 2.0, 3.0))
RESULT = VreResult("random", Conditions(sensor="adxl355", profile="random 50-2000 Hz", static_g=1.0, axis="z"),
                   LEVELS, (FIT,), ("one warning",))
PRED_LEVELS = tuple(
    LevelPrediction(rms_g=r, vre_g=f64(-0.0241 * r), tilt_error_deg=f64(1.4), shares={"clip_g": f64(-0.024 * r),
                    "nonlinearity_g": f64(3e-5)}, sigma_proof_mass_g=1.2 * r, sigma_output_g=0.7 * r,
                    sigma_at_clip_g=0.7 * r, overrange_rate_hz=0.0, valid=r < 2, notes=("held",) if r > 2 else (),
                    u_vre_g=f64(0.0063 * r) if r < 2 else None)
    for r in (1.0, 2.5))
PREDICTION = Prediction(Conditions(sensor="adxl355", model="prediction-censored"), PRED_LEVELS, ("a note",))
AXES = {"x": RESULT, "z": VreResult("random", Conditions(axis="z"), LEVELS[:2], (), ())}
TRI_TEST = VreResult.of_axes(AXES, kind="simulation", triaxial=TriaxialPart(
    excitation=TriaxialSine(100.0, (1.0, 0.0, 1.0)), levels_g=(1.0, 2.0), static_g=(0.0, 0.0, 1.0)))
TRI_LEVEL = TriaxialLevel(1.0, 5.0, f64(1.414), (f64(1.0), f64(0.0), f64(1.0)), None, u_rms_g=f64(0.003))
TRI_ANALYSIS = VreResult.of_axes(AXES, triaxial=TriaxialPart((TRI_LEVEL,), {"x": "rx", "y": "ry", "z": "rz"}, "x",
                                                             {"x": "x", "z": "z"}))
CHANNEL = ChannelModel("101:+Z", {"rail_g": Estimate(f64(2.31), f64(0.04)), "fn_hz": None}, {"fn_hz": "not seen"},
                       {"rail_g": 2.31}, None, f64(3.2), 4, (), ("n",))
NOISE = NoiseResult(Estimate(f64(25.1), f64(0.4), "ug/rtHz"), Estimate(f64(3.1), f64(0.9), "ug"), (0.1, 1.0),
                    (f64(80.0), f64(30.0)), (100, 10), 40.0, 2, 10.0)
DRIVE = DriveWaveform((Estimate(1.0, 0.001), Estimate(0.02, 0.001)), Estimate(f64(0.02), f64(0.001), "1"),
                      Estimate(1.0004, 0.002, "g^2"), Estimate(0.03, 0.001, "g^3"), 0.001)
SUMMARY = ChannelSummary("101:+Z", ({"freq_hz": 300.0, "static_g": 1.0, "vrc_ug_per_g2": 3304.0, "u": 45.0},),
                         (), Estimate(f64(3200.0), f64(40.0), "ug/g^2"), None, None, Estimate(f64(2.3), f64(0.05)),
                         (), ())


def _identification() -> Identification:
    from vrelab.sensor import load_sensor

    return Identification("demo", "ideal", load_sensor("ideal", range_g=2.048), (CHANNEL,), "censored")


def _models() -> list[object]:
    return [VrcModel({"vrc_ug_per_g2": VRC}),
            VrcK4Model({"vrc_ug_per_g2": VRC, "c4_ug_per_g4": Estimate(f64(0.5), f64(0.1), "ug/g^4")}),
            ClipModel({"rail_g": Estimate(f64(2.31), f64(0.04))}, "censored", 1.0),
            K2K3Model({"k2_ug_per_g2": VRC, "k3_ug_per_g3": Estimate(f64(4.0), f64(0.3), "ug/g^3")}),
            K2Model({"k2_ug_per_g2": VRC})]


# (result, the texts its repr must hold: its headline value ± u, its count of levels)
CASES = [
    (Estimate(f64(-0.0831234), f64(0.00041)), ["-0.0831234", "0.00041"]),
    (LEVELS[0], [str(LEVELS[0].vre), "rms_g=1"]),
    (FIT, [str(VRC), "n_points=3"]),
    (RESULT, [str(VRC), "levels=3", "adxl355"]),
    (NOISE, [str(NOISE.density_ug_rthz)]),
    (DRIVE, [str(DRIVE.thd)]),
    (PRED_LEVELS[0], [str(PRED_LEVELS[0].vre), "valid=True"]),
    (PREDICTION, ["levels=2", "valid=False"]),
    (TRI_TEST, [str(VRC), "levels_g=(1, 2)", "static_g=(0, 0, 1)"]),
    (TRI_LEVEL, ["rms_g=1.414", "axis_rms_g=(1, 0, 1)"]),
    (TRI_ANALYSIS, [str(VRC), "reference_levels=1"]),
    (CHANNEL, ["rail_g = " + str(CHANNEL.parameters["rail_g"])]),
    (SUMMARY, [str(SUMMARY.k2), str(SUMMARY.rail), "vrc_by_freq=1"]),
    (SweepResult(None, None, {}, {"points": 4}, {"csv": Path("result.csv")}),  # type: ignore[arg-type]
     ["points=0", "points = 4", "csv"]),
] + [(m, [str(next(iter(m.params.values())))]) for m in _models()]  # type: ignore[attr-defined]


@pytest.mark.parametrize("result, holds", CASES, ids=lambda x: type(x).__name__ if not isinstance(x, list) else "")
def test_repr_is_short_and_shows_the_value_and_u(result, holds):
    text = repr(result)
    assert len(text) <= MAX_REPR, text
    assert type(result).__name__ in text
    assert "np.float64" not in text and "numpy" not in text, text
    for h in holds:
        assert h in text, (h, text)


def test_the_identification_shows_each_channels_parameters():
    text = repr(_identification())
    assert len(text) <= MAX_REPR and "np.float64" not in text
    assert "101:+Z=rail_g = " + str(CHANNEL.parameters["rail_g"]) in text, text


def test_an_estimate_repr_evaluates_back():
    e = Estimate(f64(-0.0831234), f64(0.00041), "g")
    assert eval(repr(e), {"Estimate": Estimate}) == e


class _Tags(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.open: list[str] = []
        self.seen: list[str] = []
        self.text: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.open.append(tag)
        self.seen.append(tag)

    def handle_endtag(self, tag):
        assert self.open and self.open[-1] == tag, (tag, self.open)
        self.open.pop()

    def handle_data(self, data):
        self.text.append(data)


@pytest.mark.parametrize("result, holds", CASES, ids=lambda x: type(x).__name__ if not isinstance(x, list) else "")
def test_repr_html_is_a_table_that_holds_the_value(result, holds):
    parser = _Tags()
    parser.feed(result._repr_html_())
    parser.close()
    assert parser.open == []  # every tag closed, in order
    assert "table" in parser.seen and "th" in parser.seen
    text = " ".join(parser.text)
    for h in holds:
        if "=" not in h:  # "levels=3" is the repr's wording; the table has "levels | 3"
            assert h in text, (h, text)


def test_a_result_with_levels_has_them_as_a_table_in_html():
    parser = _Tags()
    parser.feed(RESULT._repr_html_())
    assert parser.seen.count("table") == 2 and parser.seen.count("tr") == 1 + len(RESULT._shown_fields()) + 3


def test_to_dataframe_columns_are_the_levels_fields():
    df = RESULT.to_dataframe()
    assert len(df) == len(RESULT.levels)
    for col in ("rms_g", "vre_g", "u_vre_g", "vrc_ug_per_g2", "u_vrc_ug_per_g2", "u_rms_g", "n_saturated", "note"):
        assert col in df.columns, col
    for (_, row), lv in zip(df.iterrows(), RESULT.levels):
        assert row["rms_g"] == lv.rms_g and row["vre_g"] == lv.vre.value and row["u_vre_g"] == lv.vre.u
        assert row["vrc_ug_per_g2"] == lv.vrc.value and row["u_vrc_ug_per_g2"] == lv.vrc.u
        assert row["note"] == "; ".join(lv.flags)


def test_to_dataframe_carries_U_and_k_and_U_is_k_times_u():
    """A level with its GUM budget (vrelab.gum.level_budget, what the CLI's analyze makes): U and
    k are columns, and U = k·u (GUM 6.2.1) in the object as in the table."""
    levels = tuple(gum.level_budget(lv, gum.TypeB(u_dut_pct=1.0), None) for lv in LEVELS)
    result = VreResult("random", Conditions(), levels)
    df = result.to_dataframe()
    for (_, row), lv in zip(df.iterrows(), levels):
        assert lv.U_vre_g is not None and lv.k is not None and lv.k > 1.96  # 40 dof: t(0.975, 40) = 2.02
        assert lv.U_vre_g == lv.k * lv.vre.u == lv.vre.expanded(lv.k)
        assert row["U_vre_g"] == lv.U_vre_g and row["k"] == lv.k
        assert "U_vre_g=" in repr(lv) and "k=" in repr(lv)


def test_a_prediction_has_the_measured_levels_shape_and_a_table():
    """LevelPrediction.vre is an Estimate as LevelResult.vre is (its vre_g and u_vre_g kept); no
    u (no covariance): NaN, unknown, never 0."""
    a, b = PRED_LEVELS
    assert a.vre == Estimate(a.vre_g, a.u_vre_g, "g")  # type: ignore[arg-type]
    assert math.isnan(b.vre.u) and b.vre.value == b.vre_g
    assert a.vrc.value == a.vrc_ug_per_g2 and a.vrc.u == a.u_vrc_ug_per_g2
    df = PREDICTION.to_dataframe()
    assert list(df["vre_g"]) == [lv.vre_g for lv in PRED_LEVELS]
    assert df["u_vre_g"][0] == a.u_vre_g and math.isnan(df["u_vre_g"][1])
    assert list(df["valid"]) == [True, False] and list(df["clip_g"]) == [lv.shares["clip_g"] for lv in PRED_LEVELS]
    assert list(df["note"]) == ["", "held"]


def test_per_axis_results_give_one_row_per_axis_and_level():
    for result in (TRI_TEST, TRI_ANALYSIS):
        df = result.to_dataframe()
        assert list(df["axis"]) == ["x", "x", "x", "z", "z"]
        assert list(df["vre_g"]) == [lv.vre.value for lv in LEVELS] + [lv.vre.value for lv in LEVELS[:2]]
    assert TRI_ANALYSIS.axes == {"x": RESULT, "z": AXES["z"]}


def test_simulate_and_analyze_results_read_alike_by_axis():
    """Issue 31's one shape, read side: a single-axis result, a triaxial test and a triaxial
    analysis each give ``axes`` (axis -> VreResult) and a DataFrame with the same level columns."""
    assert RESULT.axes == {"z": RESULT} and AXES["z"].axes == {"z": AXES["z"]}
    assert VreResult("random", Conditions(), LEVELS).axes["dut"].levels == LEVELS
    for result in (RESULT, TRI_TEST, TRI_ANALYSIS):
        assert all(isinstance(r, VreResult) for r in result.axes.values())
    single = set(RESULT.to_dataframe().columns)
    assert set(TRI_TEST.to_dataframe().columns) == set(TRI_ANALYSIS.to_dataframe().columns) == single | {"axis"}


def test_campaign_summary_table_is_its_vrc_by_frequency():
    df = SUMMARY.to_dataframe()
    assert list(df.columns) == ["freq_hz", "static_g", "vrc_ug_per_g2", "u"] and df["vrc_ug_per_g2"][0] == 3304.0


def test_to_dataframe_without_levels_or_pandas_says_so(monkeypatch):
    with pytest.raises(TypeError, match="FitResult has no levels"):
        FIT.to_dataframe()
    monkeypatch.setitem(sys.modules, "pandas", None)  # import pandas now raises ImportError
    with pytest.raises(ImportError, match=r"to_dataframe\(\) needs pandas: pip install 'vrelab\[dataframe\]'"):
        RESULT.to_dataframe()
