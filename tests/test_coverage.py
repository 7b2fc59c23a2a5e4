"""Coverage of vrelab's uncertainties over replicated seeds against an independent truth (issue 18).

For each command the test runs many seeded replicates, counts how often the truth lies within
±1u, ±2u and ±U (U = k·u, k from the result's own degrees of freedom, Welch-Satterthwaite), and
holds the counts to the coverage the result claims: a value with ν degrees of freedom claims
P(|t_ν| <= 1) for ±1u and 95.45 % for ±U. The limits are the 99 % two-sided binomial interval
around the claimed coverage, for n = the number of independent replicates (the levels of one
record share its baselines and low-frequency estimate, so they are not independent draws; the
interval for n records is the honest, wider one).

Truths:

* analyze: recordings generated here with numpy alone (no vrelab code): DUT = 1 g + the
  reference's vibration + a known VRE step per level + white noise + flicker (1/f) noise or a
  random walk or a linear drift, made by shaping Gaussian noise in the frequency domain to the
  one-sided PSD S(f) (E|X_k|² = S(f_k)·fs·N/2 for numpy's rfft); the reference band-limited
  Gaussian noise. Issue 18's case: 25 µg/√Hz white and 25 µg/√Hz at 1 Hz of flicker, 10 s
  baselines and levels (coverage of ±2u was 0.56).
* simulate (sine): the closed form of a sine clipped at the rails (SPEC 1.1), evaluated here.
* campaign: k2 and k3 of two simulated parts against their (k2, k3)·|H(f)|² (SPEC 1.2, 1.3).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from vrelab.analysis import ReductionOptions, reduce_record
from vrelab.gum import coverage_factor
from vrelab.record import ArrayRecord, Schedule, Segment

# --- the claim and its binomial limits ---------------------------------------------------------


def _claimed(dofs: np.ndarray, k: float | None) -> float:
    """Mean claimed coverage of ±k·u (k None: ±U, 95.45 % by construction)."""
    if k is None:
        return 0.9545
    nu = np.where(np.isfinite(dofs), np.maximum(dofs, 1.0), 1e9)
    return float(np.mean(2 * stats.t.cdf(k, nu) - 1))


def _limits(p: float, n: int) -> tuple[float, float]:
    """99 % two-sided binomial interval for the fraction of n independent draws of probability p."""
    lo, hi = stats.binom.interval(0.99, n, p)
    return lo / n, hi / n


def _coverage(z: np.ndarray, k: np.ndarray) -> dict[str, float]:
    a = np.abs(z)
    return {"1u": float(np.mean(a <= 1)), "2u": float(np.mean(a <= 2)), "U": float(np.mean(a <= k))}


def _assert_covers(z: np.ndarray, dof: np.ndarray, n_independent: int, what: str) -> dict[str, float]:
    k = np.array([coverage_factor(d) for d in dof])
    got = _coverage(z, k)
    for key, kk in (("1u", 1.0), ("2u", 2.0), ("U", None)):
        p = _claimed(dof, kk)
        lo, hi = _limits(p, n_independent)
        assert lo <= got[key] <= hi, (what, key, got[key], (lo, hi), p)
    return got


# --- analyze: an independent generator -----------------------------------------------------------


def colored_noise(rng: np.random.Generator, n: int, fs: float, psd) -> np.ndarray:
    """Gaussian noise of one-sided PSD ``psd(f)`` [g²/Hz] (DC bin 0), by shaping white noise's FFT."""
    f = np.fft.rfftfreq(n, 1 / fs)
    s = np.zeros_like(f)
    s[1:] = psd(f[1:])
    x = (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)) * np.sqrt(s * fs * n / 4)
    return np.fft.irfft(x, n)


def test_colored_noise_has_the_psd_asked_for():
    """The generator's own check: white 25 µg/√Hz at 1 kHz has variance S·fs/2 (Parseval)."""
    rng = np.random.default_rng(0)
    x = colored_noise(rng, 200_000, 1000.0, lambda f: np.full_like(f, (25e-6) ** 2))
    assert x.var() == pytest.approx((25e-6) ** 2 * 500.0, rel=0.02)


def shaker_record(seed: int, n_levels: int = 3, seg_s: float = 10.0, fs: float = 1000.0, white: float = 25e-6,
                  flicker: float = 25e-6, walk: float = 0.0, drift: float = 0.0, rms: float = 0.5):
    """Baseline, level, baseline, ... of ``seg_s`` each; VRE steps known; noise as asked
    (``walk``: a random walk of PSD walk²/f², in g/√Hz at 1 Hz; ``drift`` in g/s)."""
    rng = np.random.default_rng(seed)
    vre = (2e-4, -1e-4, 3e-4, 1e-4, -2e-4)[:n_levels]
    m = int(seg_s * fs)
    nseg = 2 * n_levels + 1
    ref = np.zeros(m * nseg)
    shift = np.zeros(m * nseg)
    segs = []
    for j in range(nseg):
        on = j % 2 == 1
        segs.append(Segment(j * seg_s, (j + 1) * seg_s, rms if on else 0.0))
        if on:
            x = colored_noise(rng, m, fs, lambda f: ((f >= 100) & (f <= 300)) * 1.0)
            ref[j * m:(j + 1) * m] = x / x.std() * rms
            shift[j * m:(j + 1) * m] = vre[j // 2]
    n = m * nseg
    noise = colored_noise(rng, n, fs, lambda f: white**2 + flicker**2 / f + walk**2 / f**2)
    dut = 1.0 + ref + shift + noise + drift * np.arange(n) / fs
    return ArrayRecord({"reference": ref, "dut": dut}, fs), Schedule(tuple(segs)), vre


def _analyze_z(replicates: int, **kw) -> tuple[np.ndarray, np.ndarray]:
    z, dof = [], []
    for seed in range(replicates):
        rec, sched, vre = shaker_record(seed, **kw)
        levels, _ = reduce_record(rec, schedule=sched, options=ReductionOptions(band_hz=(50.0, 400.0)))
        assert len(levels) == len(vre)
        for lv, v in zip(levels, vre):
            z.append((lv.vre.value - v) / lv.vre.u)
            dof.append(lv.dof if lv.dof is not None else math.inf)
    return np.array(z), np.array(dof)


@pytest.mark.parametrize("case", [
    dict(),  # issue 18: white + flicker 25 µg/√Hz, 10 s segments
    dict(flicker=0.0, walk=2e-6),  # random walk
    dict(flicker=50e-6, n_levels=5),  # more flicker, more baselines
    dict(seg_s=4.0),  # short segments (3 s after the trim)
    dict(flicker=0.0, drift=1e-5),  # white + a linear drift of 10 µg/s (bracketing removes it)
], ids=["flicker", "random-walk", "flicker-5-levels", "flicker-short", "white-drift"])
def test_analyze_u_covers_low_frequency_noise(case):
    reps = 60
    z, dof = _analyze_z(reps, **case)
    got = _assert_covers(z, dof, reps, f"analyze {case}")
    print(f"analyze {case}: n={len(z)} ({reps} records) coverage {got}")


def test_analyze_u_on_white_noise_alone_stays_near_its_claim():
    """White noise only: the low-frequency term's own scatter (it is not truncated at a
    significance level) may add a little; coverage stays within the claim's limits."""
    reps = 60
    z, dof = _analyze_z(reps, flicker=0.0)
    got = _assert_covers(z, dof, reps, "analyze white")
    print(f"analyze white: n={len(z)} coverage {got}")


def test_flicker_noise_is_not_covered_without_the_low_frequency_term(monkeypatch):
    """The failure the low-frequency term fixes, on the same records (issue 18: 0.56 of ±2u):
    with the term switched off, u is the batch means' alone and covers far less."""
    import vrelab.analysis.pipeline as R

    monkeypatch.setattr(R, "low_frequency", lambda baselines: None)
    z, _ = _analyze_z(30)
    assert np.mean(np.abs(z) <= 2) < 0.7


# --- simulate: sine against the closed form ----------------------------------------------------


def _sine_clip_closed_form(mu: float, amp: float, lo: float, hi: float) -> float:
    """Mean shift of μ + A·cos θ censored at [lo, hi] over θ uniform (SPEC 1.1), written here:
    where μ + A > hi, θu = arccos((hi - μ)/A) and the upper rail takes (A·sin θu - (hi-μ)·θu)/π;
    the lower rail is the mirror image."""
    out = 0.0
    if mu + amp > hi:
        tu = math.acos((hi - mu) / amp)
        out -= (amp * math.sin(tu) - (hi - mu) * tu) / math.pi
    if mu - amp < lo:
        tl = math.acos((mu - lo) / amp)
        out += (amp * math.sin(tl) - (mu - lo) * tl) / math.pi
    return out


def test_closed_form_reproduces_spec_1_1_number():
    # SPEC 1.1: 1 g field, ±2 g, 1 g rms sine: -68.3 mg
    assert _sine_clip_closed_form(1.0, math.sqrt(2.0), -2.0, 2.0) == pytest.approx(-68.31e-3, abs=0.01e-3)


@pytest.mark.parametrize("freq", [500.0, 1000.0, 1003.0])
def test_sine_simulation_of_a_clipped_ideal_sensor_matches_the_closed_form(freq):
    """Issue 18: at 1000 Hz the 8 kHz simulation sampled the same 8 phases each period and gave
    -51.78 mg with u 2.4e-13 mg against -68.31 mg. Every phase is sampled now: the closed form
    lies within 2u, and u is small enough that the old error would be 10⁴ u."""
    from vrelab import shaker
    from vrelab.sensor import load_sensor

    truth = _sine_clip_closed_form(1.0, math.sqrt(2.0), -2.0, 2.0)
    res = shaker.run_sine_test(load_sensor("ideal", range_g=2.0), [freq], [1.0], static_g=1.0, seconds=2.0, seed=0)
    (lv,) = res.levels
    assert abs(lv.vre.value - truth) <= 2 * lv.vre.u, (lv.vre, truth)
    assert lv.vre.u < 1e-3 * abs(truth)
    assert lv.freq_hz == pytest.approx(freq, rel=1e-4)


def test_sine_simulation_of_the_adxl355_z_matches_its_analytic_chain():
    """The ADXL355 Z at 1 kHz, 1.5 g rms, +1 g (issue 18: -122.5 mg against -92.4): its output
    rate (4 kHz) meets 4 phases of a 1 kHz drive, so the drive runs a little off (the level
    says where); held against ``vrelab predict`` (the memoryless chain's analytic mean, SPEC
    1.1-1.3) at the frequency the level reports."""
    from vrelab import shaker
    from vrelab.prediction import predict
    from vrelab.sensor import load_sensor

    sensor = load_sensor("adxl355", axis="z")
    res = shaker.run_sine_test(sensor, [1000.0], [1.5], static_g=1.0, seconds=4.0, seed=1)
    (lv,) = res.levels
    want = predict(sensor, [lv.freq_hz], [1.5], static_g=1.0).levels[0].vre_g
    assert abs(lv.freq_hz - 1000.0) < 2.0
    assert any(getattr(w, "code", None) == "sine-drive" for w in res.warnings)
    assert abs(lv.vre.value - want) < 0.005 * abs(want)


@pytest.mark.slow
def test_sine_simulation_u_covers_the_closed_form_over_seeds():
    """A clipped ideal sensor with white noise (10 µg/√Hz: its effect on the clip's mean, ½σ²·p
    at the rail, is 1e-7 g, far below u): 80 seeds at 1000 Hz against the closed form."""
    from vrelab import shaker
    from vrelab.sensor import load_sensor

    sensor = dataclasses.replace(load_sensor("ideal", range_g=2.0), noise_ug_per_rthz=10.0)
    truth = _sine_clip_closed_form(1.0, math.sqrt(2.0), -2.0, 2.0)
    z, dof = [], []
    reps = 80
    for seed in range(reps):
        res = shaker.run_sine_test(sensor, [1000.0], [1.0], static_g=1.0, seconds=2.0, baseline_s=2.0, seed=seed)
        for lv in res.levels:
            z.append((lv.vre.value - truth) / lv.vre.u)
            dof.append(lv.dof if lv.dof is not None else math.inf)
    got = _assert_covers(np.array(z), np.array(dof), reps, "simulate sine")
    print(f"simulate sine: n={len(z)} coverage {got}")


# --- campaign: k2, k3 against the parts' truth --------------------------------------------------


@pytest.mark.slow
def test_campaign_k2_k3_cover_the_parts_truth_over_seeds(tmp_path: Path):
    """Two parts, sine at 80 Hz at +1 g and -1 g (k2 = VRC mean, k3 from the difference,
    SPEC 1.2), 16 seeds (~0.5 s each): k2·|H(80)|² and k3·|H(80)|² of each part against the
    campaign's per-frequency fit; the limits are those of 16 independent draws (the two parts
    of a seed share their drive and noise seed, k2 and k3 one fit)."""
    from vrelab.campaigns import combine, read_manifest, run_campaign
    from vrelab.example_campaign import ExampleRun, example_truth, write_campaign

    base = example_truth()
    # HDF5 runs: the same simulated samples as CSV, without formatting and parsing 16 × 4 text
    # columns (~1 s of this test's ~1.5 s of CPU per seed); the fits agree with CSV's to the
    # printed digit (the CSV's 7-digit reference is far finer than u). Each reader has its own tests.
    truth = dataclasses.replace(base, runs=(
        ExampleRun("h5", 1.0, 80.0, (0.2, 0.4, 0.6), label="Z up, 80 Hz"),
        ExampleRun("h5", -1.0, 80.0, (0.2, 0.4, 0.6), label="Z down, 80 Hz"),
    ))
    r = 80.0 / truth.fn_hz
    h2 = 1.0 / ((1 - r * r) ** 2 + (r / truth.q) ** 2)
    parts = {p.name: p for p in truth.parts}
    z, dof = [], []
    reps = 16
    for seed in range(reps):
        man = read_manifest(write_campaign(tmp_path / f"c{seed}", truth, seconds=2.0, seed=100 * seed))
        for ch in combine(run_campaign(man), man.channels):
            (fit,) = ch.k2_k3_by_freq
            p = parts[ch.channel]
            for key, true in (("k2_ug_per_g2", p.k2_ug_per_g2 * h2), ("k3_ug_per_g3", p.k3_ug_per_g3 * h2)):
                e = fit.params[key]
                z.append((e.value - true) / e.u)
                dof.append(math.inf)  # a fit's u claims a normal distribution (no dof given)
    got = _assert_covers(np.array(z), np.array(dof), reps, "campaign k2 k3")
    print(f"campaign: n={len(z)} coverage {got}")
