"""The DUT's noise on the vibration-off stretches (SPEC 4.4, issue 28): the Allan deviation, the
noise density and bias instability as a channel result, and the level u under that noise,
against truths made here with numpy alone.

* Allan deviation against its closed forms for power-law noise (IEEE Std 952-1997, Annex C;
  IEEE Std 1554-2005): white of one-sided PSD h₀ gives σ²(τ) = h₀/(2τ), flicker h₋₁/f gives the
  floor 2·ln 2·h₋₁, i.e. 0.664·B with B = √(π·h₋₁) (IEEE 952 C.3).
* The level contrast's variance (:func:`vrelab.analysis.noise.contrast_var`) against a numpy
  Monte Carlo of the same box means over generated flicker noise.
* analyze over replicated seeds (the level u of vrelab.analysis.levels: batch means and the
  low-frequency term; these hold it to its claims under the issue's lab noise): sine and random levels of a drive through a known memoryless
  nonlinearity (DUT = g0 + x + k2·x²: VRE = k2·E[x²], E[x²] the level's rms², SPEC 1.2) plus
  25 µg/√Hz white noise, 1/f noise of corner 1 Hz, a thermal drift (exponential, τ = 15 s) and a
  linear drift; the coverage of ±2u and ±U held to what the levels claim.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from test_coverage import colored_noise
from vrelab.analysis import ReductionOptions, analyze, reduce_record
from vrelab.analysis.noise import allan_deviation, contrast_var, fit_noise_model, hadamard_rows
from vrelab.gum import coverage_factor
from vrelab.record import ArrayRecord, Schedule, Segment
from vrelab.results import VreResult

H0 = (25e-6) ** 2  # 25 µg/√Hz white, one-sided [g²/Hz]
H1 = H0 * 1.0  # flicker with its corner (where it equals the white level) at 1 Hz [g²]


def test_allan_deviation_matches_the_closed_forms_of_white_and_flicker_noise():
    rng = np.random.default_rng(3)
    fs, tau0 = 1000.0, 0.1
    w = int(fs * tau0)
    # 10 stretches of 60 s: the estimator pools them without a pair across a gap
    stretches = [colored_noise(rng, 60_000, fs, lambda f: H0 + H1 / f).reshape(-1, w).mean(axis=1)
                 for _ in range(10)]
    adev = allan_deviation(stretches, tau0)
    for tau, dev, n in zip(adev.tau_s, adev.adev_g, adev.n_pairs):
        want = math.sqrt(H0 / (2 * tau) + 2 * math.log(2) * H1)
        # an overlapping Allan variance from n pairs of τ-means has at least ~n·τ0/(2τ) degrees of
        # freedom (flicker's, the fewest: IEEE 1554 Table 3's orders); 4 standard errors of the
        # deviation, √(1/(2ν)) relative, plus the 1 % of the generator's lowest bins
        nu = max(n * tau0 / (2 * tau), 1.0)
        assert dev == pytest.approx(want, rel=4 * math.sqrt(1 / (2 * nu)) + 0.01), (tau, dev, want, nu)
    assert adev.tau_s[0] == pytest.approx(tau0)
    assert adev.tau_s[-1] >= 10.0  # octaves while 3 τ-means fit in a stretch


def test_contrast_variance_matches_a_monte_carlo_of_flicker_noise():
    """A level of 9 s between 4 s baselines, its mean against the baselines' interpolation, over
    generated flicker + white noise: the numpy sample variance of 3000 contrasts against the
    integral (relative standard error of a variance from 3000 draws: √(2/3000) = 2.6 %)."""
    rng = np.random.default_rng(5)
    fs = 200.0
    n = int(40 * fs)
    boxes = ((20.0, 9.0, 1.0), (11.0, 4.0, -0.5), (29.0, 4.0, -0.5))
    draws = []
    t = (np.arange(n) + 0.5) / fs
    masks = [(np.abs(t - c) < T / 2, k) for c, T, k in boxes]
    for _ in range(3000):
        x = colored_noise(rng, n, fs, lambda f: H0 + H1 / f)
        draws.append(sum(k * x[m].mean() for m, k in masks))
    got = float(np.var(draws))
    want = float(contrast_var(boxes) @ np.array([H0, H1, 0.0]))
    # the generator's lowest frequency is 1/40 s: flicker below it (absent in the draws) holds
    # about 1 % of the contrast's flicker variance (a second difference removes most of it)
    assert got == pytest.approx(want, rel=4 * math.sqrt(2 / 3000) + 0.02), (got, want)


def test_noise_model_fit_recovers_white_and_flicker():
    rng = np.random.default_rng(11)
    fs, w = 1000.0, 100
    stretches = [colored_noise(rng, 40_000, fs, lambda f: H0 + H1 / f).reshape(-1, w).mean(axis=1)
                 for _ in range(8)]
    m = fit_noise_model(hadamard_rows(stretches, w / fs))
    assert m is not None
    u = np.sqrt(np.diag(np.array(m.cov)))
    # within 4 of the fit's own standard uncertainties, and those honest (not absurdly wide)
    assert abs(m.h[0] - H0) <= 4 * u[0] and u[0] < 0.2 * H0, (m.h, u)
    assert abs(m.h[1] - H1) <= 4 * u[1] and u[1] < 0.5 * H1, (m.h, u)


# --- a record with a known VRE, made here with numpy alone ---------------------------------------


def lab_record(seed: int, kind: str, n_levels: int = 4, seg_s: float = 10.0, base_s: float = 10.0,
               fs: float = 2000.0, flicker: bool = True, thermal_g: float = 200e-6, tau_th_s: float = 15.0,
               drift_g_per_s: float = 2e-6, k2: float = 100e-6, g0: float = 1.0):
    """Baseline, level, ..., baseline; the drive a sine (80, 120, ... Hz) or band-limited Gaussian
    noise (100-300 Hz), scaled to its rms; DUT = g0 + x + k2·x² + noise + a thermal drift
    thermal·(1 - e^(-t/τ)) + a linear drift. Truth per level: k2·rms² (a sine's E[x²] = A²/2
    over whole periods; the noise's, its level's mean square by construction)."""
    rng = np.random.default_rng(seed)
    mb, ml = int(base_s * fs), int(seg_s * fs)
    parts, segs, truths, t0 = [], [], [], 0.0
    for j, a in enumerate(np.linspace(0.5, 2.0, n_levels)):
        parts.append(np.zeros(mb))
        segs.append(Segment(t0, t0 + base_s, 0.0))
        t0 += base_s
        if kind == "sine":
            f = 80.0 + 40 * j
            x = math.sqrt(2) * a * np.sin(2 * np.pi * f * np.arange(ml) / fs + rng.uniform(0, 2 * np.pi))
            segs.append(Segment(t0, t0 + seg_s, float(a), freq_hz=f))
        else:
            x = colored_noise(rng, ml, fs, lambda f: ((f >= 100) & (f <= 300)) * 1.0)
            x = x / math.sqrt(np.mean(x**2)) * a
            segs.append(Segment(t0, t0 + seg_s, float(a)))
        truths.append(k2 * a * a)
        parts.append(x)
        t0 += seg_s
    parts.append(np.zeros(mb))
    segs.append(Segment(t0, t0 + base_s, 0.0))
    ref = np.concatenate(parts)
    t = np.arange(len(ref)) / fs
    h1 = H1 if flicker else 0.0
    noise = colored_noise(rng, len(ref), fs, lambda f: H0 + h1 / f)
    dut = g0 + ref + k2 * ref**2 + noise + thermal_g * (1 - np.exp(-t / tau_th_s)) + drift_g_per_s * t
    return ArrayRecord({"reference": ref, "dut": dut}, fs), Schedule(tuple(segs)), truths


def _z(kind: str, seeds: int, **kw) -> tuple[np.ndarray, np.ndarray]:
    z, dof = [], []
    for seed in range(seeds):
        rec, sched, truth = lab_record(seed, kind, **kw)
        levels, _ = reduce_record(rec, schedule=sched, method=kind, options=ReductionOptions(band_hz=(20.0, 900.0)))
        assert len(levels) == len(truth)
        for lv, v in zip(levels, truth):
            z.append((lv.vre.value - v) / lv.vre.u)
            dof.append(lv.dof if lv.dof is not None else math.inf)
    return np.array(z), np.array(dof)


def _claim(dof: np.ndarray, k: float) -> float:
    nu = np.where(np.isfinite(dof), np.maximum(dof, 1.0), 1e9)
    return float(np.mean(2 * stats.t.cdf(k, nu) - 1))


@pytest.mark.parametrize("kind", ["sine", "random"])
def test_analyze_u_covers_flicker_thermal_and_linear_drift(kind):
    """25 records × 4 levels (issue 28 asked for ≥ 100): ±U (k from each level's degrees of
    freedom) covers 0.9545 and ±2u what its t claims, within the 99 % binomial limits of 25
    independent records (a record's levels share its noise model, so they are not independent)."""
    seeds = 25
    z, dof = _z(kind, seeds)
    a = np.abs(z)
    k = np.array([coverage_factor(d) for d in dof])
    cov2, covU = float(np.mean(a <= 2)), float(np.mean(a <= k))
    print(f"{kind}: n={len(z)} ±1u {np.mean(a <= 1):.3f} ±2u {cov2:.3f} ±U {covU:.3f} worst |z| {a.max():.2f} "
          f"median dof {np.median(dof):.1f}")
    lo_u = stats.binom.ppf(0.005, seeds, 0.9545) / seeds
    assert covU >= lo_u, (covU, lo_u)
    assert cov2 >= stats.binom.ppf(0.005, seeds, _claim(dof, 2.0)) / seeds, (cov2, _claim(dof, 2.0))


@pytest.mark.parametrize("kind", ["sine", "random"])
def test_analyze_u_with_short_baselines_covers_flicker(kind):
    """Issue 28's open case: the same lab noise with 2 s baselines (1 s after the trims) between
    10 s levels, which cannot show the flicker at the level's time scale; the level u takes it
    from the levels' own second differences (levels.short_baseline_u). Before: ±2u 0.87 sine,
    0.90 random (|z| up to 5.5). 25 records × 4 levels; ±2u against 0.95 within the 99 %
    binomial limit of 100 levels (the levels of a record share its low-frequency term, so
    this limit is the tighter, optimistic one), ±U against the 25 records' limit."""
    seeds = 25
    z, dof = _z(kind, seeds, base_s=2.0)
    a = np.abs(z)
    k = np.array([coverage_factor(d) for d in dof])
    cov2, covU = float(np.mean(a <= 2)), float(np.mean(a <= k))
    print(f"{kind} short baselines: n={len(z)} ±1u {np.mean(a <= 1):.3f} ±2u {cov2:.3f} ±U {covU:.3f} "
          f"worst |z| {a.max():.2f}")
    assert cov2 >= stats.binom.ppf(0.005, len(z), 0.95) / len(z), cov2
    assert covU >= stats.binom.ppf(0.005, seeds, 0.9545) / seeds, covU


def test_short_baselines_are_named_in_a_notice():
    """What the reduction can say of the open case: its levels' baselines (2 s, 1 s after the
    trims) are shorter than a third of the levels (9 s), named in a notice; the 10 s baselines
    of the covered case are not."""
    opt = ReductionOptions(band_hz=(20.0, 900.0))
    rec, sched, _ = lab_record(0, "sine", base_s=2.0)
    _, warnings = reduce_record(rec, schedule=sched, method="sine", options=opt)
    assert any(getattr(w, "code", None) == "short-baselines" and "4 level(s)" in str(w) for w in warnings), warnings
    rec, sched, _ = lab_record(0, "sine")
    _, warnings = reduce_record(rec, schedule=sched, method="sine", options=opt)
    assert not any(getattr(w, "code", None) == "short-baselines" for w in warnings)


def test_analyze_u_on_white_noise_is_not_absurdly_conservative():
    """White noise alone (no flicker, no drift): ±1u covers near its claim (0.68 for large dof;
    measured 0.83: the low-frequency term's unthresholded excess), not the 0.95 of a u twice too
    large."""
    z, dof = _z("sine", 25, flicker=False, thermal_g=0.0, drift_g_per_s=0.0)
    a = np.abs(z)
    print(f"white: n={len(z)} ±1u {np.mean(a <= 1):.3f} ±2u {np.mean(a <= 2):.3f}")
    assert np.mean(a <= 1) <= stats.binom.ppf(0.995, 25, _claim(dof, 1.0)) / 25 + 0.1
    assert np.mean(a <= 2) >= stats.binom.ppf(0.005, 25, _claim(dof, 2.0)) / 25


# --- the channel's noise as a result ---------------------------------------------------------------


def test_analyze_reports_the_channels_noise_density_and_bias_instability():
    """Long baselines (30 s each) of white 25 µg/√Hz and flicker of corner 1 Hz: the result's
    density and bias instability against the generator's √h₀ and √(π·h₋₁) (IEEE 952 C.3), within
    4 of their own u; the JSON document carries them and reads back."""
    rec, sched, _ = lab_record(1, "sine", n_levels=3, base_s=30.0, thermal_g=0.0, drift_g_per_s=0.0)
    res = analyze(rec, "sine", sched, options=ReductionOptions(band_hz=(20.0, 900.0)))
    nz = res.noise
    assert nz is not None
    dens, bi = nz.density_ug_rthz, nz.bias_instability_ug
    assert abs(dens.value - 25.0) <= 4 * dens.u and dens.u < 5.0, dens
    want_bi = 1e6 * math.sqrt(math.pi * H1)
    assert abs(bi.value - want_bi) <= 4 * bi.u and bi.u < 0.5 * want_bi, (bi, want_bi)
    assert nz.n_stretches == 4 and nz.off_s == pytest.approx(4 * 29.0, rel=0.01)
    # the Allan deviation's first point: white and flicker at τ = 0.1 s (IEEE 952 Annex C)
    want0 = 1e6 * math.sqrt(H0 / (2 * nz.tau_s[0]) + 2 * math.log(2) * H1)
    assert nz.adev_ug[0] == pytest.approx(want0, rel=0.15)
    doc = res.to_dict()
    assert doc["noise"]["density_ug_rthz"]["unit"] == "µg/√Hz"
    back = VreResult.from_dict(doc).noise
    assert back is not None and back.adev_ug == pytest.approx(nz.adev_ug)


def test_campaign_reports_each_channels_noise_by_run(tmp_path):
    """A simulated campaign of two parts with 25 µg/√Hz white noise (vrelab.example_campaign's
    example truth, its sensor file's noise_ug_per_rthz): each channel's summary lists its noise
    per run, the density within 4 of its u of 25 µg/√Hz, and the run's document carries the curve."""
    import dataclasses

    from vrelab.campaigns import campaign_doc, combine, read_manifest, run_campaign
    from vrelab.example_campaign import ExampleRun, example_truth, write_campaign

    truth = dataclasses.replace(example_truth(), runs=(ExampleRun("csv", 1.0, 80.0, (0.2, 0.4, 0.6), label="Z up"),))
    man = read_manifest(write_campaign(tmp_path / "c", truth, seconds=2.0, seed=1))
    results = run_campaign(man)
    summaries = combine(results, man.channels)
    for s in summaries:
        (n,) = s.noise_by_run
        d = n["density_ug_rthz"]
        assert abs(d["value"] - 25.0) <= 4 * d["u"], (s.channel, d)
    doc = campaign_doc(man, results, summaries)
    assert all("noise" in c for c in doc["runs"][0]["channels"])
    assert doc["channels"][0]["noise_by_run"][0]["allan"]["adev_ug"]
