"""Campaigns (SPEC 4.1, 5.1): manifests, several DUTs per file, lab formats, recovery of the truth.

The campaign is simulated (vrelab.example_campaign) with a known truth: k2, k3 per part, rails
±2.048 g at the output, a proof-mass resonance fn = 1200 Hz, Q = 4. The expected apparent VRC at
a sine f and static field g0 is (k2 + 3·k3·g0)·|H(f)|² with H(f) = 1/(1 - r² + j·r/Q) (SPEC 1.2,
1.3), computed here independently of the reduction.
"""

from __future__ import annotations

import json
import math
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate

from vrelab.campaigns import combine, read_manifest, run_campaign
from vrelab.cli import main
from vrelab.example_campaign import example_truth, write_campaign


@pytest.fixture(scope="module")
def example(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_campaign(tmp_path_factory.mktemp("campaign"))


@pytest.fixture(scope="module")
def reduced(example: Path, tmp_path_factory: pytest.TempPathFactory) -> dict:
    out = tmp_path_factory.mktemp("cout") / "out"
    assert main(["campaign", str(example), "--out", str(out), "--json"]) == 0
    return json.loads((out / "results.json").read_text())


def _h2(f: float, fn: float, q: float) -> float:
    r = f / fn
    return 1.0 / ((1 - r * r) ** 2 + (r / q) ** 2)


def test_vrc_by_frequency_recovers_the_truth_within_3u(reduced: dict) -> None:
    truth = example_truth()
    parts = {p.name: p for p in truth.parts}
    seen = 0
    for ch in reduced["channels"]:
        p = parts[ch["channel"]]
        for v in ch["vrc_by_freq"]:
            expected = (p.k2_ug_per_g2 + 3 * p.k3_ug_per_g3 * v["static_g"]) * _h2(v["freq_hz"], truth.fn_hz, truth.q)
            e = v["vrc_ug_per_g2"]
            assert abs(e["value"] - expected) < 3 * e["u"], (ch["channel"], v, expected)
            seen += 1
    # every sine run of both parts gave a VRC, the resonance's rise included (1 kHz: |H|² = 7.3)
    assert seen == 2 * sum(1 for r in truth.runs if r.freq_hz)
    top = min(reduced["channels"][0]["vrc_by_freq"], key=lambda v: abs(v["freq_hz"] - 1000.0))  # near fn
    low = min(reduced["channels"][0]["vrc_by_freq"], key=lambda v: (v["freq_hz"], -v["static_g"]))
    assert top["vrc_ug_per_g2"]["value"] > 5 * low["vrc_ug_per_g2"]["value"]


def test_k2_k3_per_frequency_and_combined(reduced: dict) -> None:
    truth = example_truth()
    parts = {p.name: p for p in truth.parts}
    for ch in reduced["channels"]:
        p = parts[ch["channel"]]
        assert len(ch["k2_k3_by_freq"]) == 2  # 80 Hz and 300 Hz were run at +1 g and -1 g
        for f in ch["k2_k3_by_freq"]:
            h2 = _h2(f["freq_hz"], truth.fn_hz, truth.q)
            for key, true in (("k2_ug_per_g2", p.k2_ug_per_g2 * h2), ("k3_ug_per_g3", p.k3_ug_per_g3 * h2)):
                e = f["parameters"][key]
                assert abs(e["value"] - true) < 3 * e["u"], (ch["channel"], f["freq_hz"], key)
        # combined over frequencies whose |H|² differ by 13 %: the Birge scaling widens u to cover it
        for key, true in (("k2_ug_per_g2", p.k2_ug_per_g2), ("k3_ug_per_g3", p.k3_ug_per_g3)):
            e = ch[key]
            assert abs(e["value"] - true) < 3 * e["u"], (ch["channel"], key, e, true)


def test_effective_rail_from_the_random_run(reduced: dict) -> None:
    # The clip sits at the output, after the resonance: it sees the reference's vibration times
    # |H|, so the effective rail (in reference rms terms) is the physical rail over the rms gain
    # of |H|² averaged over the flat 50-500 Hz band (an independent quadrature).
    truth = example_truth()
    gain2 = integrate.quad(lambda f: _h2(f, truth.fn_hz, truth.q), 50, 500)[0] / 450
    expected = truth.rail_g / math.sqrt(gain2)
    for ch in reduced["channels"]:
        e = ch["rail_g"]
        assert e is not None
        assert abs(e["value"] - expected) < 3 * e["u"], (ch["channel"], e, expected)


def test_runs_keep_their_conditions_and_files(reduced: dict) -> None:
    assert reduced["n_failed"] == 0
    fmts = {Path(r["file"]).suffix for r in reduced["runs"]}
    assert fmts == {".tdms", ".csv", ".uff", ".h5"}
    for r in reduced["runs"]:
        assert {c["channel"] for c in r["channels"]} == {"sn1", "sn2"}
        for c in r["channels"]:
            assert c["static_g"] in (1.0, -1.0)
            assert all("u_vre_g" in lv for lv in c["levels"])


def test_workers_give_the_same_campaign(example: Path) -> None:
    m = read_manifest(example)
    one = combine(run_campaign(m, 1), m.channels)
    two = combine(run_campaign(m, 2), m.channels)
    assert [c.to_dict() for c in one] == [c.to_dict() for c in two]


@pytest.fixture(scope="module")
def campaign_report(example_campaign_report: Path) -> tuple[Path, str]:
    """``vrelab campaign`` of the shipped example (what ``example`` writes: tests/test_examples.py
    holds the generation bit-identical) then ``vrelab report --metadata`` on it (the pages' lines:
    tests/conftest.py CAMPAIGN_LINE, CAMPAIGN_REPORT_LINE): the folder and the CLI's stdout. Built
    once per run by tests/conftest.py, shared with tests/test_report_layout.py and the pages'
    steps: read only."""
    return example_campaign_report / "camp", (example_campaign_report / "cli-stdout.txt").read_text()


def _quoted_metadata(value: object) -> list[str]:
    """Every text of a --metadata file (a table's, a list's, at any depth)."""
    if isinstance(value, dict):
        return [t for v in value.values() for t in _quoted_metadata(v)]
    if isinstance(value, list):
        return [t for v in value for t in _quoted_metadata(v)]
    return [value] if isinstance(value, str) else []


def test_report_of_a_campaign(campaign_report: tuple[Path, str]) -> None:
    import tomllib

    from test_format import gum_violations, visible_text

    out, cli = campaign_report
    html = (out / "report.html").read_text()
    text = visible_text(html)
    # One formatter: every "value ± u" in the report and the CLI table by GUM 7.2.6, with units.
    # The --metadata file's texts (examples/report-metadata.toml, the pages' report: "23 ± 2 °C")
    # are its author's words, quoted as written: the rule holds the numbers the report computes.
    meta = tomllib.loads((Path(__file__).resolve().parent.parent / "examples" / "report-metadata.toml").read_text())
    computed = text
    for quoted in (t for t in _quoted_metadata(meta) if "±" in t):
        computed = computed.replace(quoted, "")
    assert "23 ± 2 °C" in text and gum_violations(computed) == [] and gum_violations(cli) == []
    assert re.search(r"VRC at +1000 Hz, \+1 g: -?\d+0 ± \d\d0 µg/g²", cli)  # u of ~540 shown as two digits
    # The random run stated as its shape and the levels it reached, never the unit shape's grms
    # (21.21 g rms for flat 50-500 Hz at 1 g²/Hz): the example steps 0.3, 0.5, 0.7, 0.9 g rms
    # (vrelab.example_campaign.example_truth, its random run).
    assert "21.21" not in text and "g rms (flat" not in text
    head = re.search(r"5\.14 Run 6 \(Z up, random 50-500 Hz\), channel sn1: \+1 g field, "
                     r"random 50–500 Hz \(flat-50-500\), ([\d.]+)–([\d.]+) g rms", text)
    assert head and 0.27 < float(head[1]) < 0.33 and 0.85 < float(head[2]) < 0.95, head
    assert re.search(r"levels reached\s+0\.\d+–0\.9\d* g rms", text)
    # The raw JSON is an attachment: each run channel's provenance links its results file.
    links = re.findall(r'<a href="(runs/[^"]+/results\.json)">', html)
    assert len(links) == 2 * 7 and all((out / ln).is_file() for ln in links)
    # Human names and units, no raw JSON values.
    assert "null" not in text and "\\u00" not in text and "rails g" not in text
    # The combined k2 is called apparent, with the per-frequency consistency check (80 and 300 Hz
    # disagree by ~3 sigma in this example: the 300 Hz point carries the resonance's gain).
    assert "k2 (apparent: combined over frequencies" in text
    assert re.search(r"k2 per frequency DISAGREE \(80 Hz [-\d]+ ± \d+ µg/g², 300 Hz [-\d]+ ± \d+ µg/g²; "
                     r"χ²/dof = [\d.]+, Birge ratio [\d.]+, p = [\d.]+\): the combined k2 is apparent", text)
    assert "Channel sn1" in html and "Channel sn2" in html
    assert "VRC by frequency and orientation" in html
    assert html.count('<section class="result"') == 1 + 2 + 2 * 7  # summary, channels, each run's channels
    # the runs table links each run to its first section (run 1's channels follow the 3 first sections)
    # The runs table's link names the sections it points to as their headings number them.
    assert '<a href="#s4">5.4–5.5 (run 1)</a>' in html and '<section class="result" id="s4"><h3>5.4 Run 1' in html


@pytest.mark.browser
def test_campaign_report_prints_on_a4_without_raw_values(campaign_visit: dict) -> None:
    """The campaign report in headless Chromium and printed to A4: every table inside the page
    (the provenance's file paths and hashes break to fit), and the paper reads no JSON escapes,
    no null and no unit-shape level. The page is tests/conftest.py's campaign_visit (loaded once
    per run, with tests/test_report_layout.py's measurements): the paper only, its 30 figures not
    hovered nor zoomed (the demo's test and the browser test do, on the same page code)."""
    from test_report_browser import assert_prints_cleanly

    state, pdf = campaign_visit["state"], campaign_visit["pdf"]
    printed = "".join(p["text"] for p in assert_prints_cleanly(state, pdf, min_pages=10))
    assert "\\u00" not in printed and "null" not in printed and "21.21" not in printed
    assert "20910 ± 540 µg/g²" in printed or re.search(r"VRC -?\d+0 ± \d\d0 µg/g²", printed)


# ----------------------------------------------------------------------------- honest nulls


def test_one_orientation_gives_null_k2_k3_with_the_reason(example: Path, tmp_path: Path) -> None:
    text = example.read_text()
    runs = text.split("[[run]]")
    keep = [r for r in runs[1:] if "static_g = 1" in r and "random" not in r]
    (tmp_path / "runs").symlink_to(example.parent / "runs")
    m = tmp_path / "up_only.toml"
    m.write_text(runs[0] + "".join("[[run]]" + r for r in keep))
    man = read_manifest(m)
    ch = combine(run_campaign(man), man.channels)[0]
    assert ch.k2 is None and ch.k3 is None and ch.rail is None
    assert any("one orientation only" in n for n in ch.notes)
    assert any("no random run" in n for n in ch.notes)


# ----------------------------------------------------------------------------- bad manifests


def _manifest(tmp: Path, example: Path, body: str, defaults: str = "") -> Path:
    runs = tmp / "runs"
    if not runs.exists():
        runs.symlink_to(example.parent / "runs")
    m = tmp / "m.toml"
    m.write_text('name = "t"\n[defaults]\nreference_units = "mv"\nreference_sensitivity = 10\n'
                 'dut_units = "lsb"\ndut_sensitivity = 256000\n' + defaults + body)
    return m


GOOD = '[[run]]\nfile = "runs/01_z_up_80hz.tdms"\nreference = "shaker/ref"\ndut = {a = "shaker/sn1_z"}\nstatic_g = 1\n'


@pytest.mark.parametrize(
    "body, defaults, words",
    [
        (GOOD.replace("static_g", "statc_g"), "", ["run 1", "unknown key 'statc_g'"]),
        (GOOD, "colour = 1\n", ["[defaults]", "unknown key 'colour'"]),
        (GOOD.replace("01_z_up_80hz.tdms", "nope.tdms"), "", ["run 1", "file", "nope.tdms", "not found"]),
        (GOOD.replace("shaker/sn1_z", "shaker/sn9_z"), "", ["run 1", "dut", "sn9_z", "not found"]),
        (GOOD.replace('reference = "shaker/ref"', 'reference = "shaker/rf"'), "", ["run 1", "reference", "rf"]),
        (GOOD.replace("static_g = 1\n", ""), "", ["run 1", "static_g", "missing"]),
        (GOOD.replace('{a = "shaker/sn1_z"}', '{a = "shaker/sn1_z", b = "shaker/sn2_z"}')
         .replace("static_g = 1", "static_g = {a = 1}"), "", ["run 1", "static_g", "'b'"]),
        (GOOD.replace('{a = "shaker/sn1_z"}', '{a = "shaker/sn1_z", b = "shaker/sn1_z"}'), "",
         ["run 1", "dut", "given twice"]),
        (GOOD + 'label = "x"\nmethod = "sweep"\n', "", ["run 1 ('x')", "method"]),
        ("", "", ["no [[run]]"]),
        (GOOD + "[[run]\n", "", ["not valid TOML"]),
    ],
)
def test_bad_manifest_is_one_line_exit_2(example: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                         body: str, defaults: str, words: list[str]) -> None:
    m = _manifest(tmp_path, example, body, defaults)
    assert main(["campaign", str(m), "--json"]) == 2
    cap = capsys.readouterr()
    assert cap.out == ""
    err = cap.err.strip()
    assert "\n" not in err and "Traceback" not in err
    for w in words:
        assert w in err, (w, err)
    with pytest.raises(ValueError):
        read_manifest(m)


def test_a_failing_run_does_not_lose_the_rest(example: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    runs = tmp_path / "runs"
    shutil.copytree(example.parent / "runs", runs)
    csv = runs / "02_z_down_80hz.csv"
    lines = csv.read_text().splitlines()
    parts = lines[5000].split(",")
    parts[1] = "nan"  # a NaN in the reference, found while streaming
    lines[5000] = ",".join(parts)
    csv.write_text("\n".join(lines) + "\n")
    m = tmp_path / "campaign.toml"
    m.write_text(example.read_text())
    out = tmp_path / "out"
    assert main(["campaign", str(m), "--out", str(out), "--json"]) == 1
    cap = capsys.readouterr()
    doc = json.loads(cap.out)
    failed = [r for r in doc["runs"] if r["status"] != "ok"]
    assert [r["index"] for r in failed] == [2]
    assert "non-finite" in failed[0]["error"]
    assert "run 2" in cap.err and "failed" in cap.err
    assert doc["n_failed"] == 1 and len(doc["runs"]) == 7
    assert all(r["channels"] for r in doc["runs"] if r["status"] == "ok")
    # the -1 g at 80 Hz is gone, so 80 Hz gives no k2/k3; 300 Hz still does
    assert [f["freq_hz"] for f in doc["channels"][0]["k2_k3_by_freq"]] == pytest.approx([300.0], rel=1e-3)
    assert (out / "results.json").is_file() and (out / "levels.csv").is_file()


# ----------------------------------------------------------------------------- several DUTs in analyze


def test_several_duts_equal_each_reduced_alone(example: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    f = str(example.parent / "runs" / "01_z_up_80hz.tdms")
    common = ["--reference", "shaker/ref", "--reference-units", "mv", "--reference-sensitivity", "10",
              "--dut-units", "lsb", "--dut-sensitivity", "256000", "--json"]
    assert main(["analyze", f, "--dut", "shaker/sn1_z,shaker/sn2_z", *common, "--out", str(tmp_path / "o")]) == 0
    both = json.loads(capsys.readouterr().out)
    assert [c["channel"] for c in both["channels"]] == ["shaker/sn1_z", "shaker/sn2_z"]
    for c in both["channels"]:
        assert main(["analyze", f, "--dut", c["channel"], *common]) == 0
        alone = json.loads(capsys.readouterr().out)
        assert [lv["vre_g"] for lv in c["levels"]] == [lv["vre_g"] for lv in alone["levels"]]
        assert [lv["u_vre_g"] for lv in c["levels"]] == [lv["u_vre_g"] for lv in alone["levels"]]
        assert c["fit"]["vrc_ug_per_g2"] == alone["fit"]["vrc_ug_per_g2"]
    # one segmentation: the same levels for both channels
    assert [lv["rms_g"] for lv in both["channels"][0]["levels"]] == [lv["rms_g"] for lv in both["channels"][1]["levels"]]
    assert main(["report", str(tmp_path / "o")]) == 0
    assert (tmp_path / "o" / "report.html").read_text().count('<section class="result"') == 2


def test_several_duts_need_a_reference(example: Path, capsys: pytest.CaptureFixture[str]) -> None:
    f = str(example.parent / "runs" / "01_z_up_80hz.tdms")
    assert main(["analyze", f, "--dut", "shaker/sn1_z,shaker/sn2_z"]) == 2
    assert "need --reference" in capsys.readouterr().err


def test_the_same_record_in_every_format_gives_the_same_levels(tmp_path: Path) -> None:
    from vrelab import example_campaign as C
    from vrelab.analysis.readers import Scale, open_record
    from vrelab.analysis.reduction import analyze_channels

    truth = example_truth()
    run = C.ExampleRun("tdms", 1.0, 80.0, (0.2, 0.4, 0.6))
    sensor = tmp_path / "sensor.toml"
    sensor.write_text(truth.sensor)
    got = {}
    for fmt, writer in C._WRITERS.items():
        fs, n, blocks = C.simulate_run(truth, run, 7, 2.0, sensor)
        path = tmp_path / f"r.{ {'uffb': 'uff'}.get(fmt, fmt) }"
        path = path.with_name(f"r-{fmt}{path.suffix}")
        names = writer(path, fs, n, blocks, ["sn1", "sn2"])
        duts = {p: names[p] for p in ("sn1", "sn2")}
        with open_record(path, duts, names["reference"], None, Scale("lsb", 256000), Scale("mv", 10)) as rec:
            got[fmt] = {name: res for name, res, _ in analyze_channels(rec, static_g=1.0)}
    assert set(got) == {"tdms", "csv", "h5", "uff", "uffb", "mf4", "lvm", "ide"}
    ref = got["h5"]
    for fmt, res in got.items():
        for name in ("sn1", "sn2"):
            a, b = ref[name].levels, res[name].levels
            assert len(a) == len(b) == 3, fmt
            for la, lb in zip(a, b):
                # CSV keeps 7 digits of the reference, UFF and IDE single precision: far below u
                assert abs(la.vre.value - lb.vre.value) < 0.02 * la.vre.u, (fmt, name)
                assert lb.rms_g == pytest.approx(la.rms_g, rel=1e-6), (fmt, name)


# ----------------------------------------------------------------------------- UFF58


def test_uff_names_rates_and_bad_files(example: Path, tmp_path: Path) -> None:
    from vrelab.analysis.readers import Scale, open_record
    from vrelab.analysis.readers.uff import UffSource

    path = example.parent / "runs" / "03_z_up_300hz.uff"
    src = UffSource.open(path)
    assert {"reference mV", "sn1 LSB", "sn2 LSB", "1:+Z", "101:+Z", "201:+Z"} <= set(src.channels)
    assert np.array_equal(src.read("101:+Z", 0, 100), src.read("sn1 LSB", 0, 100))
    src.close()
    counts, mv = Scale("lsb", 256000.0), Scale("mv", 10.0)  # the records state LSB and mV: scales needed
    with open_record(path, "sn1 LSB", "1:+Z", dut_scale=counts, reference_scale=mv) as rec:
        assert rec.fs_hz == pytest.approx(6000.0)
    cut = tmp_path / "cut.uff"
    cut.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    with pytest.raises(ValueError, match="cut.uff"):
        with open_record(cut, "sn2 LSB", "1:+Z", dut_scale=counts, reference_scale=mv) as rec:
            next(rec.blocks(1 << 20, ["dut"]))


def _uff58_ascii(id1: str, node: int, direction: int, dt: float, values: list[float], double: bool) -> str:
    """One UFF58 ASCII record written by hand (the layout of the I-DEAS universal file format:
    11 header records, then the ordinates 4E20.12 (double) or 6E13.5 (single))."""
    lines = ["    -1", "    58", f"{id1:<80}", "NONE", "NONE", "NONE", "NONE",
             f"{1:5d}{0:10d}{0:5d}{0:10d} {'NONE':<10}{node:10d}{direction:4d} {'NONE':<10}{0:10d}{0:4d}",
             f"{4 if double else 2:10d}{len(values):10d}{1:10d}{0.0:13.5E}{dt:13.5E}{0.0:13.5E}",
             f"{17:10d}{0:5d}{0:5d}{0:5d} {'Time':<20} {'s':<20}",
             f"{12:10d}{0:5d}{0:5d}{0:5d} {'Acceleration':<20} {'g':<20}",
             f"{0:10d}{0:5d}{0:5d}{0:5d} {'NONE':<20} {'NONE':<20}",
             f"{0:10d}{0:5d}{0:5d}{0:5d} {'NONE':<20} {'NONE':<20}"]
    per, fmt = (4, "{:20.12E}") if double else (6, "{:13.5E}")
    for i in range(0, len(values), per):
        lines.append("".join(fmt.format(v) for v in values[i : i + per]))
    lines.append("    -1")
    return "\n".join(lines) + "\n"


def test_uff_by_hand_trailing_spaces_and_mixed_precision(tmp_path: Path) -> None:
    from vrelab.analysis.readers.uff import UffSource

    rng = np.random.default_rng(3)
    a = list(np.round(rng.standard_normal(50), 6))
    b = list(np.round(rng.standard_normal(50), 4))
    p = tmp_path / "hand.uff"
    p.write_text(_uff58_ascii("ref   ", 1, 3, 1e-3, a, True) + _uff58_ascii("dut z    ", 101, -3, 1e-3, b, False))
    src = UffSource.open(p)
    assert set(src.channels) >= {"ref", "dut z", "1:+Z", "101:-Z"}
    assert src.fs_hz == pytest.approx(1000.0)
    np.testing.assert_allclose(src.read("ref", 0, 50), a, rtol=1e-11)
    np.testing.assert_allclose(src.read("101:-Z", 0, 50), b, rtol=1e-5)
    q = tmp_path / "rates.uff"
    q.write_text(_uff58_ascii("ref", 1, 3, 1e-3, a, True) + _uff58_ascii("dut", 101, 3, 5e-4, b, True))
    # records at two rates share the file; a record's channels must share one (issue 19)
    from vrelab.analysis.readers import open_record

    with pytest.raises(ValueError, match=r"rates.uff: channels 'ref' \(1000 Hz\) and 'dut' \(2000 Hz\) have different"):
        open_record(q, "dut", "ref")


def test_manifest_budget_keys_reach_levels_and_k2(example: Path, tmp_path: Path) -> None:
    (tmp_path / "runs").symlink_to(example.parent / "runs")
    m = tmp_path / "b.toml"
    m.write_text(example.read_text().replace("[defaults]\n", "[defaults]\nu_reference_pct = 1.0\nu_dut_pct = 0.5\n"))
    man = read_manifest(m)
    assert man.runs[0].budget == {"u_reference_pct": 1.0, "u_dut_pct": 0.5}
    plain = read_manifest(example)
    with_b = run_campaign(man, 1, limit_g=0.001)
    without = run_campaign(plain, 1)
    lv_b, lv = with_b[0].results[0][1].levels[0], without[0].results[0][1].levels[0]
    assert lv_b.vre.value == lv.vre.value and lv_b.vre.u > lv.vre.u and lv_b.decision in ("pass", "fail", "indeterminate")
    a, b = combine(without, plain.channels)[0], combine(with_b, man.channels)[0]
    assert a.k2 is not None and b.k2 is not None
    assert b.k2.value == pytest.approx(a.k2.value)
    # the common sensitivity terms (2r ⊕ p = 2.06 %) added once to the combined k2
    assert b.k2.u == pytest.approx(math.hypot(a.k2.u, math.hypot(0.02, 0.005) * abs(a.k2.value)), rel=1e-9)
    assert any("common to every run" in n for n in b.notes)


def test_uff_magic_does_not_claim_a_column_of_numbers() -> None:
    from vrelab.analysis.readers.uff import UffSource

    assert UffSource.can_open(b"    -1\n    58\nid1\n")
    assert UffSource.can_open(b"    -1\r\n    58b     1     2\r\n")
    assert not UffSource.can_open(b"-1\n58\n3\n")  # a headerless CSV of counts
    assert not UffSource.can_open(b"-1,58\n")
