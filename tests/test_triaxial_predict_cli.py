"""``vrelab predict`` with a triaxial vibration (issue 22, SPEC 1.6): options, JSON keys, text
columns, one-line refusals; and the report's prediction table showing the cross terms."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from vrelab.cli import main
from vrelab.prediction import predict
from vrelab.profiles import parse_profile
from vrelab.report.html import ReportSection, render_section
from vrelab.sensor import load_sensor
from vrelab.triaxial.profile import TriaxialProfile, TriaxialSine, direction

PART = str(Path(__file__).resolve().parents[1] / "examples" / "triaxial-part.toml")


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    rc = main(list(argv))
    out, err = capsys.readouterr()
    return rc, out, err


def test_mount_angle_json_is_the_api_prediction(capsys: pytest.CaptureFixture[str]) -> None:
    rc, out, err = _run(capsys, "predict", "--sensor", PART, "--profile", "flat:20-500", "--levels", "0.5,1",
                        "--mount-deg", "45", "--static-vector", "0,0.5,0.866", "--json")
    assert rc == 0, err
    d = json.loads(out)
    api = predict(load_sensor(PART), TriaxialProfile.along(parse_profile("flat:20-500"), direction("z", "x", 45)),
                           [0.5, 1.0], static_g=(0, 0.5, 0.866))
    assert d["kind"] == "triaxial-prediction"
    ex = d["conditions"]["extra"]
    assert ex["static_vector_g"] == [0.0, 0.5, 0.866] and ex["triad"]["pendulous"] == "x"
    for lv, ref in zip(d["levels"], api.levels):
        assert lv["vre_g"] == pytest.approx(ref.vre_g, rel=1e-12)
        for key in ("cross_kip_g", "cross_kio_g", "cross_kpp_g", "cross_koo_g", "cross_kpo_g", "cross_g", "clip_g",
                    "nonlinearity_g", "overrange_g"):
            assert lv["shares"][key] == pytest.approx(ref.shares[key], rel=1e-12, abs=1e-18)
        assert lv["axis_rms_g"] == pytest.approx([lv["rms_g"] / math.sqrt(2), 0.0, lv["rms_g"] / math.sqrt(2)])
        assert {"model_error_g", "valid", "notes", "sensed_rms_g", "cross_pass"} <= set(lv)
    # the IEEE 1293 io plane: toward the output axis y
    rc, out, _ = _run(capsys, "predict", "--sensor", PART, "--profile", "flat:20-500", "--levels", "0.5",
                      "--mount-deg", "30", "--mount-plane", "io", "--json")
    assert rc == 0
    assert json.loads(out)["levels"][0]["axis_rms_g"] == pytest.approx([0.0, 0.25, 0.5 * math.cos(math.radians(30))])


def test_direction_and_sine(capsys: pytest.CaptureFixture[str]) -> None:
    rc, out, err = _run(capsys, "predict", "--sensor", PART, "--freq", "200", "--levels", "0.7",
                        "--direction", "1,0,1", "--json")
    assert rc == 0, err
    lv = json.loads(out)["levels"][0]
    ref = predict(load_sensor(PART), TriaxialSine(200.0, (1, 0, 1)), [0.7], static_g=(0, 0, 1)).levels[0]
    assert lv["freq_hz"] == 200.0 and lv["vre_g"] == pytest.approx(ref.vre_g, rel=1e-12)
    assert lv["shares"]["cross_kip_g"] > 0


def test_text_shows_the_cross_terms_beside_the_mechanisms(capsys: pytest.CaptureFixture[str]) -> None:
    rc, out, err = _run(capsys, "predict", "--sensor", PART, "--profile", "flat:20-500", "--levels", "0.5,1",
                        "--mount-deg", "45")
    assert rc == 0, err
    head = next(line for line in out.splitlines() if "rms_g" in line)
    for col in ("clip mg", "nonlin mg", "overrange mg", "Kip mg", "Kpp mg", "cross mg", "valid"):
        assert col in head
    assert "triad i=z p=x o=y" in out and "static vector (0, 0, 1) g" in out


def test_single_axis_output_is_unchanged_without_the_options(capsys: pytest.CaptureFixture[str]) -> None:
    rc, out, _ = _run(capsys, "predict", "--sensor", "ideal", "--range", "2", "--profile", "flat:50-2000",
                      "--levels", "1", "--json")
    assert rc == 0
    d = json.loads(out)
    assert d["kind"] == "prediction" and "cross_g" not in d["levels"][0]["shares"]
    assert d["levels"][0]["vre_g"] == pytest.approx(-0.0833, abs=0.0005)  # SPEC 1.1, censored, +1 g default


@pytest.mark.parametrize("extra,words", [
    (["--direction", "1,0"], "--direction must be three finite numbers"),
    (["--direction", "0,0,0"], "direction must not be the zero vector"),
    (["--direction", "1,nan,0"], "--direction must be three finite numbers"),
    (["--mount-plane", "io"], "--mount-plane needs --mount-deg"),
    (["--mount-deg", "45", "--direction", "1,0,0"], "--direction or --mount-deg, not both"),
    (["--static", "1", "--static-vector", "0,0,1"], "--static (along the axis) or --static-vector"),
    (["--static-vector", "0,1"], "--static-vector must be three finite numbers"),
    (["--mount-deg", "inf"], "--mount-deg"),
])
def test_bad_triaxial_input_is_one_line_exit_2(capsys: pytest.CaptureFixture[str], extra: list[str], words: str) -> None:
    rc, out, err = _run(capsys, "predict", "--sensor", PART, "--profile", "flat:20-500", "--levels", "1", *extra)
    assert rc == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and words in err and "Traceback" not in err


def test_tones_are_refused_along_a_direction(capsys: pytest.CaptureFixture[str]) -> None:
    rc, _, err = _run(capsys, "predict", "--sensor", PART, "--profile", "flat:20-500+sine:100:0.5", "--levels", "1",
                      "--mount-deg", "45")
    assert rc == 2 and "random profile (no +sine tones)" in err and len(err.strip().splitlines()) == 1


def test_report_table_shows_the_cross_terms() -> None:
    pred = predict(load_sensor(PART), TriaxialProfile.along(parse_profile("flat:20-500"), direction("z", "x", 45)),
                            [0.5, 1.0], static_g=(0, 0, 1))
    html = render_section(ReportSection("triaxial", "a 45° mount", prediction=pred.to_dict()), "t")
    for col in ("clip (mg)", "nonlinearity (mg)", "cross kip (mg)", "cross kpp (mg)", "cross (mg)"):
        assert col in html


def test_a_triaxial_profile_string_goes_through_vrelab_triaxial_files(capsys: pytest.CaptureFixture[str],
                                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    # `vrelab simulate`'s triaxial profile strings (PROFILE@dir=X,Y,Z, @z45x, triaxial TOML files)
    # belong to vrelab.triaxial.files; predict hands them over. A stand-in module here so that the
    # wiring is held whatever that module's own forms are.
    import sys
    import types

    seen: list[str] = []
    stub = types.ModuleType("vrelab.triaxial.files")

    def parse_triaxial(spec: str) -> TriaxialProfile:
        seen.append(spec)
        return TriaxialProfile.along(parse_profile(spec.partition("@")[0]), direction("z", "x", 45.0))

    stub.is_triaxial_spec = lambda spec: "@" in spec  # type: ignore[attr-defined]
    stub.parse_triaxial = parse_triaxial  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "vrelab.triaxial.files", stub)
    rc, out, err = _run(capsys, "predict", "--sensor", PART, "--profile", "flat:20-500@z45x", "--levels", "0.5", "--json")
    assert rc == 0, err
    assert seen == ["flat:20-500@z45x"]
    rc2, out2, _ = _run(capsys, "predict", "--sensor", PART, "--profile", "flat:20-500", "--levels", "0.5",
                        "--mount-deg", "45", "--json")
    assert json.loads(out)["levels"][0]["vre_g"] == json.loads(out2)["levels"][0]["vre_g"]
    rc, _, err = _run(capsys, "predict", "--sensor", PART, "--profile", "flat:20-500@z45x", "--levels", "0.5",
                      "--direction", "1,0,0")
    assert rc == 2 and "apply to a single-axis --profile" in err
