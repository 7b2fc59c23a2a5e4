"""The triaxial (MIMO) drive against its prescribed cross-spectral density (issue 22, SPEC 1.6).

Truths: the profile's CSD (``TriaxialProfile.csd``, S_jk = E[A_j A_k*]), estimated from the
synthesised drive by Welch's method (``scipy.signal.csd``, which returns E[X* Y], the conjugate)
within the random errors of Bendat & Piersol, *Random Data*, 4th ed. (2010), Table 9.6:
PSD ``P/√n_d``, coherence ``√2(1-γ²)|γ|/√n_d``, phase ``√(1-γ²)/(|γ|√(2 n_d))``; and the
cross terms' rectification ``VRE_cross = Σ K_jk Re ∫ S_jk(f) |H(f)|² df`` (SPEC 1.6), computed
here with scipy.integrate.quad over the CSD.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import integrate
from scipy import signal as ss

from vrelab.profiles import RandomProfile
from vrelab.sensor import load_sensor
from vrelab.synthesis import random_blocks
from vrelab.triaxial.chain import triaxial_chain
from vrelab.triaxial.profile import TriaxialProfile
from vrelab.triaxial.synthesis import design_fir_matrix, rank_one, triaxial_random_blocks, triaxial_random_signal

FS = 2000.0
F = np.array([20.0, 100.0, 500.0])
P = {"x": RandomProfile(F, [0.01, 0.02, 0.005]), "y": RandomProfile(F, [0.02, 0.02, 0.02]),
     "z": RandomProfile(F, [0.005, 0.01, 0.02])}
# partly coherent x-y (γ² 0.6, y 40° behind x), y-z fully coherent in phase, so x-z as x-y
PARTLY = TriaxialProfile.from_axes(P, {("x", "y"): (0.6, 40.0), ("y", "z"): (1.0, 0.0), ("x", "z"): (0.6, 40.0)})
INCOHERENT = TriaxialProfile.from_axes(P)
NPERSEG = 512


def _n_d(n_samples: int, n_bins: int) -> float:
    """Independent averages of a Welch estimate (Hann, 50 % overlap) averaged over n_bins adjacent
    bins: Welch's overlap discount 1/(1 + 2·0.167²) on the segments, Hann's neighbour-bin
    correlations ρ(1) = 4/9, ρ(2) = 1/36 on the bins (Welch 1967; Bendat & Piersol 11.5)."""
    k = (n_samples - NPERSEG) // (NPERSEG // 2) + 1
    k_eff = k / (1 + 2 * 0.167**2)
    m = n_bins
    var = (m + 2 * (m - 1) * (4 / 9) ** 1 + 2 * (m - 2) * (1 / 36)) / m**2
    return k_eff / var


def _band(fr, lo, hi):
    return (fr >= lo) & (fr <= hi)


@pytest.mark.parametrize("profile", [PARTLY, INCOHERENT], ids=["partly-coherent", "incoherent"])
def test_welch_csd_of_the_drive_is_the_prescribed_one(profile):
    n = 1 << 18
    x = triaxial_random_signal(profile, FS, n, seed=5)
    fr, _ = ss.welch(x[0], fs=FS, nperseg=NPERSEG)
    est = np.empty((fr.size, 3, 3), dtype=complex)
    for j in range(3):
        for k in range(3):
            est[:, j, k] = np.conj(ss.csd(x[j], x[k], fs=FS, nperseg=NPERSEG)[1])  # E[X_j X_k*]
    target = profile.csd(fr)
    # bands between breakpoints, away from the band edges (Welch's Hann leaks across a kink)
    for lo, hi in ((30.0, 90.0), (120.0, 240.0), (260.0, 480.0)):
        sel = _band(fr, lo, hi)
        nd = _n_d(n, int(sel.sum()))
        for j in range(3):
            p_est, p_true = est[sel, j, j].real.mean(), target[sel, j, j].real.mean()
            assert abs(p_est / p_true - 1) < 4 / math.sqrt(nd), (lo, j, p_est, p_true)
        for j, k in ((0, 1), (1, 2), (0, 2)):
            s_est = est[sel, j, k].mean()
            g2_est = abs(s_est) ** 2 / (est[sel, j, j].real.mean() * est[sel, k, k].real.mean())
            s_true = target[sel, j, k].mean()
            g2 = abs(s_true) ** 2 / (target[sel, j, j].real.mean() * target[sel, k, k].real.mean())
            u_g2 = math.hypot(math.sqrt(2) * (1 - g2) * math.sqrt(g2) / math.sqrt(nd), (1 - g2) ** 2 / nd)
            assert abs(g2_est - g2) < 4 * u_g2 + 1e-6, (lo, j, k, g2_est, g2)
            if g2 > 0.1:
                u_ph = math.sqrt(1 - g2) / (math.sqrt(g2) * math.sqrt(2 * nd))
                d_ph = abs(np.angle(s_est / s_true))
                assert d_ph < 4 * u_ph + 1e-4, (lo, j, k, math.degrees(d_ph))
            else:
                assert g2_est < 10 / nd  # incoherent: only the estimate's bias, about 1/n_d


def test_each_axis_has_exactly_its_mean_square_and_the_filters_are_lower_triangular():
    h = design_fir_matrix(PARTLY, FS)
    np.testing.assert_allclose((h**2).sum(axis=(1, 2)), PARTLY.axis_mean_square_g2, rtol=1e-9)
    assert not h[0, 1].any() and not h[0, 2].any() and not h[1, 2].any()
    still = TriaxialProfile.from_axes({"x": P["x"], "z": P["z"]}, {("x", "z"): (0.5, -30.0)})
    hs = design_fir_matrix(still, FS)
    assert not hs[1].any() and not hs[:, 1].any()
    x = triaxial_random_signal(still, FS, 5000, seed=1)
    assert not x[1].any() and x[0].std() > 0.1


def test_values_do_not_depend_on_the_block_size_and_the_seed_matters():
    one = triaxial_random_signal(PARTLY, FS, 70000, seed=3)
    many = np.concatenate(list(triaxial_random_blocks(PARTLY, FS, 70000, 4321, seed=3)), axis=1)
    assert np.array_equal(one, many)
    other = triaxial_random_signal(PARTLY, FS, 70000, seed=4)
    assert not np.allclose(one, other)


def test_a_direction_drive_is_rank_one_and_exactly_todays_single_axis_drive():
    single = RandomProfile.flat(20.0, 500.0, grms=2.0)
    d = np.array([1.0, -2.0, 2.0]) / 3.0
    prof = TriaxialProfile.along(single, d)
    p1, d1 = rank_one(prof)
    np.testing.assert_allclose(d1, d, rtol=1e-12)
    x = triaxial_random_signal(prof, FS, 9000, seed=8)
    s = np.concatenate(list(random_blocks(p1, FS, 9000, 9000, seed=8)))
    # the same numbers to rounding: the triaxial path forms d·s through its FIR matrix, where a CPU
    # with fused multiply-add or another SIMD width may round the last bit differently (one ulp
    # seen on an AVX-512 machine); a few ulps of the signal's scale is the bound
    np.testing.assert_allclose(x, d[:, None] * s[None, :], rtol=0, atol=8 * np.finfo(float).eps * np.abs(s).max())
    assert rank_one(PARTLY) is None and rank_one(INCOHERENT) is None


def test_bad_profiles_are_refused():
    with pytest.raises(ValueError, match="exceeds fs_hz/2"):
        next(triaxial_random_blocks(PARTLY, 800.0, 10, 10, 0))
    with pytest.raises(ValueError, match="TriaxialProfile"):
        next(triaxial_random_blocks(P["x"], FS, 10, 10, 0))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="seed"):
        next(triaxial_random_blocks(PARTLY, FS, 10, 10, -1))


def _vre_cross_closed_form(profile, sensor):
    """SPEC 1.6: Σ K_jk Re ∫ S_jk |H|² df over the triad's pairs, by quad on each segment."""
    i, p, o = sensor.triad
    terms = ((sensor.kip_per_g, i, p), (sensor.kio_per_g, i, o), (sensor.kpp_per_g, p, p),
             (sensor.koo_per_g, o, o), (sensor.kpo_per_g, p, o))
    total = 0.0
    for k, a, b in terms:
        if not k:
            continue
        def integrand(f, a=a, b=b):
            return float(profile.csd(f)[0, a, b].real * abs(sensor.response(f, "proof-mass")) ** 2)
        pts = profile.freq_hz
        total += k * sum(integrate.quad(integrand, pts[m], pts[m + 1], limit=200, epsabs=0, epsrel=1e-10)[0]
                         for m in range(pts.size - 1))
    return total


@pytest.mark.parametrize("profile", [PARTLY, INCOHERENT], ids=["partly-coherent", "incoherent"])
def test_cross_terms_rectify_as_the_closed_form_through_a_resonance(profile):
    # An otherwise linear, unclipped axis (the ideal sensor with a 300 Hz, Q 4 proof mass) with
    # all five IEEE 1293 terms: the mean output shift against the static reading is VRE_cross.
    sensor = dataclasses.replace(load_sensor("ideal", axis="y", range_g=100.0), fn_hz=300.0, q=4.0,
                                 kip_per_g=0.05, kio_per_g=-0.03, kpp_per_g=0.02, koo_per_g=0.01, kpo_per_g=0.04)
    truth = _vre_cross_closed_form(profile, sensor)
    n, batches = 1 << 18, 32
    g = np.array([[0.0], [0.0], [1.0]])
    run = triaxial_chain(sensor, FS).start(FS, 0)
    out = np.concatenate([run.process(a + g) for a in triaxial_random_blocks(profile, FS, n, 1 << 15, seed=2)])
    static = triaxial_chain(sensor, FS).apply(np.tile(g, (1, 100)), FS)[0].mean()
    means = out.reshape(batches, -1).mean(axis=1) - static
    vre, u = means.mean(), means.std(ddof=1) / math.sqrt(batches)
    assert abs(vre - truth) < 4 * u
    assert u < 0.1 * abs(truth)
