"""Synthetic shaker recordings with a known truth (used by the other analysis tests), and checks
of the statistics the reduction relies on.

Truth: vibration-off baselines and vibration levels in a schedule; DUT = static field + offset
+ linear drift + AR(1) noise (autocorrelated, like 1/f and thermal wander) + the vibration
itself + a known VRE per level; ramps between segments; reference = Gaussian band-limited noise
or a sine at a known rms.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

from vrelab.analysis.uncertainty import batch_mean, integrated_autocorr_time
from vrelab.record import ArrayRecord, Schedule, Segment


@dataclass
class Truth:
    record: ArrayRecord
    schedule: Schedule  # exact segment times (ramps excluded)
    rms_g: list[float]  # per level, in time order
    vre_g: list[float]
    freq_hz: float | None


def ar1(rng: np.random.Generator, n: int, phi: float, sigma: float) -> np.ndarray:
    """Stationary AR(1) of marginal std ``sigma``: x[k] = φ·x[k-1] + e[k]."""
    e = rng.standard_normal(n) * sigma * np.sqrt(1 - phi**2)
    zi = np.array([rng.standard_normal() * sigma * phi])
    return signal.lfilter([1.0], [1.0, -phi], e, zi=zi)[0]


def make_record(
    seed: int,
    levels_g: tuple[float, ...] = (0.5, 1.0, 2.0),
    vre_g: tuple[float, ...] = (1e-3, 2e-3, -3e-3),
    fs_hz: float = 500.0,
    t_off_s: float = 10.0,
    t_on_s: float = 20.0,
    t_ramp_s: float = 1.0,
    phi: float = 0.98,
    noise_g: float = 2e-3,
    drift_g_per_s: float = 1e-4,
    static_g: float = 1.0,
    sine_hz: float | None = None,
    band_hz: tuple[float, float] = (80.0, 200.0),
    rail_g: float | None = None,
) -> Truth:
    rng = np.random.default_rng(seed)
    sos = signal.butter(4, band_hz, btype="band", fs=fs_hz, output="sos")
    ref_parts: list[np.ndarray] = []
    shift_parts: list[np.ndarray] = []
    segs: list[Segment] = []
    t = 0.0

    def vib(n: int, rms: float) -> np.ndarray:
        if sine_hz is not None:
            k = np.arange(n)
            return rms * np.sqrt(2) * np.sin(2 * np.pi * sine_hz * k / fs_hz + rng.uniform(0, 2 * np.pi))
        x = signal.sosfilt(sos, rng.standard_normal(n + 4000))[4000:]
        return x / x.std() * rms

    def add(n_s: float, rms: float, shift: float, ramp: int = 0) -> None:
        nonlocal t
        n = int(round(n_s * fs_hz))
        if ramp:  # vibration ramps up (+1) or down (-1): no clean segment
            ref_parts.append(vib(n, 1.0) * np.linspace(0.0, rms, n)[:: ramp])
            shift_parts.append(np.zeros(n))
        else:
            ref_parts.append(vib(n, rms) if rms > 0 else np.zeros(n))
            shift_parts.append(np.full(n, shift))
            segs.append(Segment(t, t + n / fs_hz, rms, sine_hz if rms > 0 else None))
        t += n / fs_hz

    add(t_off_s, 0.0, 0.0)
    for rms, v in zip(levels_g, vre_g):
        add(t_ramp_s, rms, 0.0, ramp=1)
        add(t_on_s, rms, v)
        add(t_ramp_s, rms, 0.0, ramp=-1)
        add(t_off_s, 0.0, 0.0)
    ref = np.concatenate(ref_parts)
    shift = np.concatenate(shift_parts)
    n = len(ref)
    tt = np.arange(n) / fs_hz
    dut = static_g + 0.012 + drift_g_per_s * tt + ar1(rng, n, phi, noise_g) + shift + ref
    if rail_g is not None:
        dut = np.clip(dut, -rail_g, rail_g)
    rec = ArrayRecord({"reference": ref, "dut": dut}, fs_hz)
    return Truth(rec, Schedule(tuple(segs)), list(levels_g), list(vre_g), sine_hz)


def test_integrated_autocorr_time_matches_ar1_closed_form():
    """AR(1): τ_int = (1+φ)/(1-φ) (Sokal 1996, eq. for exponential autocorrelation)."""
    rng = np.random.default_rng(1)
    for phi in (0.0, 0.5, 0.9):
        x = ar1(rng, 200_000, phi, 1.0)
        tau = integrated_autocorr_time(x)
        assert abs(tau / ((1 + phi) / (1 - phi)) - 1) < 0.1, (phi, tau)


def test_batch_mean_uncertainty_is_honest_on_ar1_and_naive_is_not():
    """Over 400 seeded AR(1) series (φ = 0.9, τ = 19): |mean| <= u in about 68 % of them."""
    rng = np.random.default_rng(2)
    hit, naive_hit = 0, 0
    n_rep = 400
    for _ in range(n_rep):
        y = ar1(rng, 4000, 0.9, 1.0)
        est = batch_mean(y, detrend=False)
        hit += abs(est.mean) <= est.u
        naive_hit += abs(est.mean) <= y.std(ddof=1) / np.sqrt(len(y))
    assert 0.58 <= hit / n_rep <= 0.78
    assert naive_hit / n_rep < 0.35  # σ/√N ignores τ: about erf(1/√(2·19)) = 0.18


def test_batch_mean_detrend_ignores_linear_drift():
    rng = np.random.default_rng(3)
    y = rng.standard_normal(2000) * 0.1 + 5e-3 * np.arange(2000)
    est = batch_mean(y)
    assert est.u < 0.1 / np.sqrt(2000) * 2  # the drift does not inflate u
    assert batch_mean(y, detrend=False).u > 10 * est.u
