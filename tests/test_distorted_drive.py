"""A shaker drive that is not a pure sine (issue 28, SPEC 4.4): the campaign's VRC, k2 and k3
against a truth made with numpy alone.

The generator below is this file's own (no vrelab code): a drive x(t) = A1·cos θ +
d·A1·cos(2θ + φ) (a second harmonic of d = 5-10 %, random phase φ per level), a DUT that
reads a + k2·a² + k3·a³ + white noise with a = g0 + x (SPEC 1.2's polynomial, memoryless: its
response is flat at every harmonic), and a reference that reads x + white noise. A sine level's
VRE is then k2·E[x²] + k3·(3·g0·E[x²] + E[x³]) with E[x²] = A1²·(1 + d²)/2 and
E[x³] = (3/4)·d·A1³·cos φ (the only product of three of the drive's lines whose frequencies
sum to zero is f + f - 2f): a VRC fitted against the fundamental's rms² is off by
(k2 + 3·k3·g0)·d² and by k3·(3/2)·d·A1·cos φ (the audit's ±40-46 µg/g² with u 7-10).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

FS = 2000.0
F0 = 80.0
K2 = 50e-6  # g/g² (50 µg/g²)
K3 = 100e-6  # g/g³ (100 µg/g³)
RMS = (0.8, 1.4, 2.0)  # the fundamental's rms per level [g]
SEG_S = 2.0


def drive(rng: np.random.Generator, n: int, rms: float, distortion: tuple[float, float]
          ) -> tuple[np.ndarray, float, float]:
    """A1·cos θ + d·A1·cos(2θ + φ) over n samples, random start phase, d uniform in
    ``distortion``, φ uniform: (x, E[x²], E[x³]) with the moments in closed form (module doc)."""
    a1 = math.sqrt(2.0) * rms
    d = rng.uniform(*distortion)
    phi = rng.uniform(0.0, 2 * math.pi)
    th = 2 * math.pi * F0 * np.arange(n) / FS + rng.uniform(0.0, 2 * math.pi)
    x = a1 * np.cos(th) + d * a1 * np.cos(2 * th + phi)
    return x, a1 * a1 * (1 + d * d) / 2, 0.75 * d * a1**3 * math.cos(phi)


def distorted_run(seed: int, g0: float, distortion: tuple[float, float] = (0.05, 0.10),
                  noise_g: float = 2e-3, cos_phi: float = 1.0
                  ) -> tuple[dict[str, np.ndarray], list[tuple[float, float, float, float]]]:
    """Baseline, level, baseline, ... (``SEG_S`` each) at static field g0 along the DUT's input
    axis: channels and the schedule rows (start_s, end_s, nominal rms, freq). ``cos_phi``: the
    DUT's input axis at φ to the vibration (IEEE 1293's mount angle) senses cos φ of the drive
    (no cross-axis terms in this DUT)."""
    rng = np.random.default_rng(seed)
    m = int(SEG_S * FS)
    nseg = 2 * len(RMS) + 1
    x = np.zeros(m * nseg)
    rows = []
    for j in range(nseg):
        on = j % 2 == 1
        rows.append((j * SEG_S, (j + 1) * SEG_S, RMS[j // 2] if on else 0.0, F0 if on else math.nan))
        if on:
            x[j * m:(j + 1) * m] = drive(rng, m, RMS[j // 2], distortion)[0]
    a = g0 + cos_phi * x
    dut = a + K2 * a * a + K3 * a**3 + noise_g * rng.standard_normal(x.size)
    ref = x + 1e-4 * rng.standard_normal(x.size)
    return {"dut": dut, "reference": ref}, rows


def write_campaign(folder: Path, seed: int, fields: tuple[float, ...] = (1.0, -1.0), mount_deg: float | None = None,
                   **kw) -> Path:
    """A run per static field (+1 g and -1 g), as HDF5 records with their schedule, and the
    manifest; ``mount_deg``: one more run, the DUT mounted at that angle in the IP plane on a
    vertical shaker (+1 g along the vibration: [cos φ, sin φ, 0] in the part's triad)."""
    from vrelab.record import Schedule, Segment, write_record_hdf5

    folder.mkdir(parents=True, exist_ok=True)
    runs = []
    extra = [] if mount_deg is None else [math.radians(mount_deg)]
    for i, g0 in enumerate(list(fields) + extra):
        mounted = i >= len(fields)
        c = math.cos(g0) if mounted else 1.0
        data, rows = distorted_run(1000 * seed + i, c if mounted else g0, cos_phi=c, **kw)
        sched = Schedule(tuple(Segment(a, b, r, None if math.isnan(f) else f) for a, b, r, f in rows))
        name = f"run{i}.h5"
        write_record_hdf5(folder / name, FS, [data], schedule=sched)
        static = f"[{c!r}, {math.sin(g0)!r}, 0]\nmount_deg = {mount_deg}\nmount_plane = \"ip\"" if mounted else g0
        runs.append(f'[[run]]\nfile = "{name}"\nreference = "reference"\ndut = {{part = "dut"}}\n'
                    f'static_g = {static}\nmethod = "sine"\nsettle_s = 0.2\n')
    man = folder / "campaign.toml"
    man.write_text('name = "distorted drive"\n' + "".join(runs), encoding="utf-8")
    return man


def campaign_z(tmp: Path, seeds: range, **kw) -> dict[str, np.ndarray]:
    """z = (estimate - truth)/u of the campaign's VRC per orientation (truth k2 + 3·k3·g0) and of
    its k2 and k3 at the drive frequency, over ``seeds``."""
    from vrelab.campaigns import combine, read_manifest, run_campaign

    z: dict[str, list[float]] = {"vrc": [], "k2": [], "k3": []}
    for seed in seeds:
        man = read_manifest(write_campaign(tmp / f"c{seed}", seed, **kw))
        results = run_campaign(man)
        assert all(r.ok for r in results), [r.error for r in results]
        (ch,) = combine(results, man.channels)
        for v in ch.vrc_by_freq:
            e = v["vrc_ug_per_g2"]
            z["vrc"].append((e["value"] - (K2 + 3 * K3 * v["static_g"]) * 1e6) / e["u"])
        (fit,) = ch.k2_k3_by_freq
        for key, true in (("k2", K2 * 1e6), ("k3", K3 * 1e6)):
            e = fit.params[f"{key}_ug_per_g{key[1]}"]
            z[key].append((e.value - true) / e.u)
    return {k: np.array(v) for k, v in z.items()}


def test_generator_moments_match_their_closed_form():
    """The generator's own check: E[x²] and E[x³] of a drawn drive over whole periods equal the
    closed forms of the module docstring (trigonometric sums over whole periods are exact)."""
    rng = np.random.default_rng(3)
    n = int(FS / F0) * 200  # 200 whole periods (25 samples each)
    x, m2, m3 = drive(rng, n, 1.5, (0.08, 0.08))
    assert np.mean(x * x) == pytest.approx(m2, rel=1e-12)
    assert np.mean(x**3) == pytest.approx(m3, rel=1e-9, abs=1e-12)
    assert abs(m3) > 0.01  # the case is not trivial: 3/4·0.08·3.2·cos φ


REPS = 24


def _covered(z: np.ndarray) -> float:
    return float(np.mean(np.abs(z) <= 2))


@pytest.mark.slow
def test_campaign_vrc_k2_k3_cover_the_truth_under_a_distorted_drive(tmp_path: Path):
    """Issue 28: with 5-10 % of second harmonic the VRC per orientation covered ±2u 0.71 of
    the time (z up to 4.4). Over 24 seeds (48 VRCs, 24 k2 and k3; ~10 s) the VRCs must cover
    ±2u at least 0.95 of the time (the issue's bar), and k2 and k3 at least the lower end of
    the 99 % binomial interval around 0.9545 for 24 independent campaigns (0.83)."""
    z = campaign_z(tmp_path, range(REPS))
    for key, zz in z.items():
        print(f"{key}: n={zz.size} ±2u coverage {_covered(zz):.3f}, max |z| {np.max(np.abs(zz)):.2f}")
    lo = stats.binom.ppf(0.005, REPS, 0.9545) / REPS
    assert _covered(z["vrc"]) >= 0.95, z["vrc"]
    assert _covered(z["k2"]) >= lo and _covered(z["k3"]) >= lo, (z["k2"], z["k3"])


@pytest.mark.slow
def test_the_fundamental_rms_alone_does_not_cover_a_distorted_drive(tmp_path: Path, monkeypatch):
    """The failure the measured moments fix, on the first 12 of the same campaigns: with each
    level's drive waveform dropped (VRC against the fundamental's rms², as before issue 28) the
    VRCs cover ±2u far less often."""
    import vrelab.analysis.levels as L

    real = L.sine_level
    monkeypatch.setattr(L, "sine_level", lambda *a, **k: dataclasses.replace(real(*a, **k), drive=None))
    z = campaign_z(tmp_path, range(12))
    assert _covered(z["vrc"]) < 0.8, z["vrc"]


def test_a_pure_sine_level_reads_e_x2_as_its_rms_squared_and_no_shift():
    """A pure drive (no harmonic): E[x²] is the level's rms² to the harmonics' noise power
    (2·σ²/L each, about 1e-10 g² here), E[x³] is 0 within its u, the THD is the noise floor, and
    the VRC is the one fitted against rms² (to 1e-6 of it: the fit's weights are the same)."""
    from vrelab.analysis import analyze
    from vrelab.fits import fit_vrc
    from vrelab.record import ArrayRecord, Schedule, Segment

    data, rows = distorted_run(7, 1.0, distortion=(0.0, 0.0))
    sched = Schedule(tuple(Segment(a, b, r, None if math.isnan(f) else f) for a, b, r, f in rows))
    res = analyze(ArrayRecord(data, FS), "sine", sched)
    for lv in res.levels:
        d = lv.drive
        assert d is not None
        assert d.mean_square_g2.value == pytest.approx(lv.rms_g**2, rel=1e-8)
        assert abs(d.mean_cube_g3.value) <= 4 * d.mean_cube_g3.u
        assert d.thd.value < 1e-4
    (fit,) = res.fits
    plain = fit_vrc([dataclasses.replace(lv, drive=None) for lv in res.levels])
    assert fit.params["vrc_ug_per_g2"].value == pytest.approx(plain.params["vrc_ug_per_g2"].value, rel=1e-6)
    assert abs(fit.static_shift_g) < 1e-4


def test_a_distorted_level_reports_its_harmonics_thd_and_moments():
    """8 % of second harmonic at 2 g rms: the level's h2 is 8 % of the fundamental, the THD 0.08,
    E[x²] and E[x³] the closed forms of the module docstring (the generator's own phases, drawn
    again from the same seed), each within 4 of its u plus the reference noise's share."""
    from vrelab.analysis import analyze
    from vrelab.record import ArrayRecord, Schedule, Segment

    data, rows = distorted_run(11, -1.0, distortion=(0.08, 0.08))
    sched = Schedule(tuple(Segment(a, b, r, None if math.isnan(f) else f) for a, b, r, f in rows))
    res = analyze(ArrayRecord(data, FS), "sine", sched)
    # the same draws as distorted_run: per level, drive() draws d, φ, the start phase
    rng = np.random.default_rng(11)
    m = int(SEG_S * FS)
    for lv, rms in zip(res.levels, RMS):
        _, m2, m3 = drive(rng, m, rms, (0.08, 0.08))
        d = lv.drive
        assert d is not None
        assert d.harmonics_rms_g[1].value / d.harmonics_rms_g[0].value == pytest.approx(0.08, rel=1e-3)
        assert d.thd.value == pytest.approx(0.08, rel=1e-3)
        # the reference's 1e-4 g noise moves E[x²] by about 1e-4·rms relative (the fit's u holds it)
        assert abs(d.mean_square_g2.value - m2) <= 4 * d.mean_square_g2.u + 1e-6 * m2
        assert abs(d.mean_cube_g3.value - m3) <= 4 * d.mean_cube_g3.u + 1e-6 * abs(m2)
    out = res.to_dict()["levels"][0]["drive"]
    assert [h["h"] for h in out["harmonics"]][:2] == [1, 2] and out["thd"]["value"] == pytest.approx(0.08, rel=1e-3)


@pytest.mark.parametrize("gain_2f", [1.0, 1.3])
def test_a_dut_that_responds_otherwise_at_2f_is_named(gain_2f: float):
    """The moments are the reference's: a DUT whose output shows the second harmonic 1.3x as
    strong as the reference does (relative to the fundamental) is named in a 'drive' notice; one
    that follows the reference (1.0) is not."""
    from vrelab.analysis import analyze
    from vrelab.record import ArrayRecord, Schedule, Segment

    rng = np.random.default_rng(5)
    m = int(SEG_S * FS)
    th = 2 * math.pi * F0 * np.arange(m) / FS
    x = 1.4 * np.cos(th) + 0.1 * np.cos(2 * th + 0.7)
    seen = 1.4 * np.cos(th) + gain_2f * 0.1 * np.cos(2 * th + 0.7)
    z = np.zeros(m)
    ref = np.concatenate([z, x, z]) + 1e-4 * rng.standard_normal(3 * m)
    dut = 1.0 + np.concatenate([z, seen, z]) + 1e-3 * rng.standard_normal(3 * m)
    sched = Schedule((Segment(0, SEG_S, 0.0), Segment(SEG_S, 2 * SEG_S, 1.0, F0), Segment(2 * SEG_S, 3 * SEG_S, 0.0)))
    res = analyze(ArrayRecord({"dut": dut, "reference": ref}, FS), "sine", sched)
    named = [w for w in res.warnings if getattr(w, "code", "") == "drive"]
    assert bool(named) == (gain_2f != 1.0), res.warnings
    if named:
        assert "1.3x" in named[0]


def test_the_reference_sensitivity_moves_the_vrc_by_minus_2r_through_the_measured_moments():
    """SPEC 4.3: a reference-sensitivity error r scales E[x²] by (1+r)² (and E[x³] by (1+r)³),
    so a VRC fitted against E[x²] moves by -2r (to first order): the budget's term for 1 % is
    2 % of the VRC. (Had the perturbation scaled the rms alone, the VRC fitted against the
    measured E[x²] would not move at all and the term would read 0.)"""
    from vrelab.analysis import analyze
    from vrelab.analysis.options import BudgetOptions
    from vrelab.gum import TypeB
    from vrelab.record import ArrayRecord, Schedule, Segment

    data, rows = distorted_run(4, 1.0)
    sched = Schedule(tuple(Segment(a, b, r, None if math.isnan(f) else f) for a, b, r, f in rows))
    (fit,) = analyze(ArrayRecord(data, FS), "sine", sched, budget=BudgetOptions(TypeB(u_reference_pct=1.0))).fits
    (term,) = [n for n in fit.notes if n.startswith("budget: reference")]
    vrc = fit.params["vrc_ug_per_g2"].value
    moved = float(term.rsplit(" ", 1)[1])
    # -2r to first order; (1+r)^-2 - 1 = -1.99 % exactly for r = 1 %
    assert moved == pytest.approx(((1.01) ** -2 - 1) * vrc, rel=2e-3)


def test_analyze_json_and_report_show_the_drive_harmonics(tmp_path: Path, capsys):
    """The user's view: ``vrelab analyze --json`` holds each sine level's drive (harmonics, THD,
    E[x²], E[x³]) and the fit's static_shift_g; the text table a THD column; the report a
    drive-waveform table with the harmonics in % of the fundamental."""
    import json

    from vrelab.cli import main
    from vrelab.record import Schedule, Segment, write_record_hdf5

    data, rows = distorted_run(2, 1.0, distortion=(0.06, 0.06))
    sched = Schedule(tuple(Segment(a, b, r, None if math.isnan(f) else f) for a, b, r, f in rows))
    rec = tmp_path / "run.h5"
    write_record_hdf5(rec, FS, [data], schedule=sched)
    args = ["analyze", str(rec), "--dut", "dut", "--reference", "reference", "--method", "sine"]
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "THD (%)" in text and "a distorted drive" in text
    assert main([*args, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    drive = doc["levels"][0]["drive"]
    assert drive["thd"]["value"] == pytest.approx(0.06, rel=1e-3)
    assert {"mean_square_g2", "mean_cube_g3", "harmonics"} <= set(drive)
    assert doc["fits"][0]["static_shift_g"] is not None
    assert main([*args, "--out", str(tmp_path / "out")]) == 0
    assert main(["report", str(tmp_path / "out")]) == 0
    html = (tmp_path / "out" / "report.html").read_text()
    # h2 = 6 % of the fundamental, shown at the table's 0.001 % resolution
    assert "Drive waveform (reference)" in html and "h2 (% of h1)" in html and ">6.000<" in html


def test_one_orientation_names_the_bias_it_cannot_remove(tmp_path: Path):
    """With one orientation k3 is unknown, so the drive's 3·k3·shift stays in the VRC: the
    campaign says so (and leaves the VRC as measured, with its shift beside it)."""
    from vrelab.campaigns import combine, read_manifest, run_campaign

    man = read_manifest(write_campaign(tmp_path / "c", 0, fields=(1.0,)))
    (ch,) = combine(run_campaign(man), man.channels)
    assert ch.k3 is None
    assert any(n.startswith("a distorted drive") and "unknown bias" in n for n in ch.notes), ch.notes
    (v,) = ch.vrc_by_freq
    assert abs(v["static_shift_g"]) > 1e-3 and "vrc_measured_ug_per_g2" not in v



IDENT_REPS = 20


def identify_z(tmp: Path, seeds: range) -> dict[str, np.ndarray]:
    """z = (estimate - truth)/u of ``vrelab identify``'s k2 and k3 on the campaign document
    (results.json as written) of each seed's two-orientation campaign (``k2``, ``k3``), and on
    the same document with each level's measured ``drive`` stripped (``k2 pure``, ``k3 pure``:
    identify then models a pure sine of the fundamental's rms, as before issue 28)."""
    import json

    from vrelab.campaigns import campaign_doc, combine, read_manifest, run_campaign
    from vrelab.identification import identify

    z: dict[str, list[float]] = {"k2": [], "k3": [], "k2 pure": [], "k3 pure": []}
    for seed in seeds:
        man = read_manifest(write_campaign(tmp / f"i{seed}", seed))
        results = run_campaign(man)
        doc = json.loads(json.dumps(campaign_doc(man, results, combine(results, man.channels))))
        pure = json.loads(json.dumps(doc))
        for run in pure["runs"]:
            for ch in run["channels"]:
                for lv in ch["levels"]:
                    assert lv.pop("drive")["thd"]["value"] > 0.04  # the levels carried their distortion
        for tag, d in (("", doc), (" pure", pure)):
            # the ideal base's rails (±range) clear the levels' peaks: 2·√2·1.1 + 1 = 4.1 g < 8 g
            (ch,) = identify(d, "ideal", range_g=8.0).channels
            for key, true in (("k2", K2 * 1e6), ("k3", K3 * 1e6)):
                e = ch.parameters[f"{key}_ug_per_g{key[1]}"]
                assert e is not None, ch.reasons
                z[key + tag].append((e.value - true) / e.u)
    return {k: np.array(v) for k, v in z.items()}


@pytest.mark.slow
def test_identify_k2_k3_cover_the_truth_under_a_distorted_drive(tmp_path: Path):
    """Issue 28 row 5 for ``vrelab identify``: its sine model uses each level's measured E[x²]
    and E[x³] (the campaign document's ``drive``). Over 20 two-orientation campaigns (5-10 %
    second harmonic, random phase, k2 = 50 µg/g², k3 = 100 µg/g³; ~25 s) k2 and k3 must cover
    ±2u at least the lower end of the 99 % binomial interval around 0.9545 for 20 trials
    (0.80). With the drive stripped from the same documents (a pure sine, as before) they fall
    below it (0.75 and 0.55 when written): the cubic term's k3·E[x³] and the harmonics' power
    in E[x²] are read as k2 and k3."""
    lo = stats.binom.ppf(0.005, IDENT_REPS, 0.9545) / IDENT_REPS
    z = identify_z(tmp_path, range(IDENT_REPS))
    for key, zz in z.items():
        print(f"{key}: n={zz.size} ±2u coverage {_covered(zz):.3f}, max |z| {np.max(np.abs(zz)):.2f}")
    assert _covered(z["k2"]) >= lo and _covered(z["k3"]) >= lo, (z["k2"], z["k3"])
    assert min(_covered(z["k2 pure"]), _covered(z["k3 pure"])) < lo, (z["k2 pure"], z["k3 pure"])


MOUNT_DEG = 45.0
MOUNT_REPS = 12


@pytest.mark.slow
def test_mount_angle_vrc_is_carried_to_a_pure_drive(tmp_path: Path):
    """A mount-angle run (IEEE 1293, SPEC 1.6) under a distorted drive: the input axis senses
    cos φ of the vibration, so its VRE/E[x²] is cos²φ·(k2 + 3·k3·cos φ·(1 + s)) with s the drive's
    E[x³]/(3·E[x²]) (module doc); ``vrc_by_mount`` subtracts 3·k3·cos³φ·s with k3 of the axial
    runs' fit at the same frequency. Over 12 campaigns (+1 g, -1 g, and 45° in the IP plane, 5-10 %
    second harmonic, a 0.3 mg DUT noise; ~10 s) the corrected VRC covers its truth cos²φ·(k2 + 3·k3·cos φ) at ±2u at
    least the lower end of the 99 % binomial interval around 0.9545 for 12 trials (0.75); the
    measured one did not (the 3·k3·cos³φ·s left in)."""
    from vrelab.campaigns import combine, read_manifest, run_campaign

    c = math.cos(math.radians(MOUNT_DEG))
    truth = c * c * (K2 + 3 * K3 * c) * 1e6
    z: dict[str, list[float]] = {"corrected": [], "measured": []}
    for seed in range(MOUNT_REPS):
        # a quieter DUT (0.3 mg) than the other tests': the bias 3·k3·cos³φ·s (about 1-8 µg/g²
        # here) stands out of the VRC's u (2-4 µg/g²), which at 2 mg of noise hides it (u 9-13)
        man = read_manifest(write_campaign(tmp_path / f"m{seed}", seed, mount_deg=MOUNT_DEG, noise_g=3e-4))
        results = run_campaign(man)
        assert all(r.ok for r in results), [r.error for r in results]
        (ch,) = combine(results, man.channels)
        (v,) = ch.vrc_by_mount
        assert v["static_shift_g"] != 0.0
        for key, name in (("corrected", "vrc_ug_per_g2"), ("measured", "vrc_measured_ug_per_g2")):
            z[key].append((v[name]["value"] - truth) / v[name]["u"])
    lo = stats.binom.ppf(0.005, MOUNT_REPS, 0.9545) / MOUNT_REPS
    zz = {k: np.array(x) for k, x in z.items()}
    for k, x in zz.items():
        print(f"vrc_by_mount {k}: n={x.size} ±2u coverage {_covered(x):.3f}, max |z| {np.max(np.abs(x)):.2f}")
    assert _covered(zz["corrected"]) >= lo, zz["corrected"]
    assert _covered(zz["measured"]) < lo, zz["measured"]


def test_campaign_levels_csv_has_each_sine_levels_thd(tmp_path: Path):
    """``vrelab campaign --out``'s levels.csv carries each sine level's THD and its u (the
    ``thd``, ``u_thd`` columns), the generator's 6 % second harmonic (THD = A2/A1, module doc) to
    the reference's noise (1e-4 g against A2 of 0.07-0.17 g: 1e-3 relative, as above), and the
    same numbers as results.json."""
    import csv
    import json

    from vrelab.cli import main

    man = write_campaign(tmp_path / "c", 5, distortion=(0.06, 0.06))
    out = tmp_path / "out"
    assert main(["campaign", str(man), "--out", str(out)]) == 0
    with open(out / "levels.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 2 * len(RMS)
    doc = json.loads((out / "results.json").read_text())
    thd = [lv["drive"]["thd"] for run in doc["runs"] for ch in run["channels"] for lv in ch["levels"]]
    for row, t in zip(rows, thd):
        assert float(row["thd"]) == pytest.approx(0.06, rel=1e-3)
        assert 0 < float(row["u_thd"]) < 1e-3
        assert (float(row["thd"]), float(row["u_thd"])) == (t["value"], t["u"])  # repr: read back bit for bit
