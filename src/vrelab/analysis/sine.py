"""A sine level's second pass over the record (physics §4, the sine method of IEEE Std 1293).

The drive frequency from the reference (:func:`estimate_frequency`: Hann-windowed FFT peak,
log-parabolic interpolation, then a sine-fit refinement), then batches of a whole number of
drive periods (:func:`whole_period_batch`: the number chosen so that a batch is within a small
fraction of a sample of whole periods), in each a three-parameter sine fit (IEEE Std 1057:
offset, cos, sin at the drive frequency) of reference and DUT (:func:`sine_level`): level = rms
of the reference's fitted sine, DUT mean = the DUT's fitted offset, the drive removed exactly.
A plain mean over a non-integer number of periods would leave a residual of order A/(2π·f·T)
(physics §4). The fit's frequency error left in the coefficients is measured from the batches'
phases and removed (:func:`_frequency_corrected`); u carries what that leaves, the leakage of
harmonics beyond the fit, and the arithmetic's rounding (:func:`_rounding_u`), so a noiseless
record does not claim a u of 1e-16 over an error of 1e-10.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vrelab.analysis.segmentation import channel_labels, check_finite, exact_blocks
from vrelab.analysis.uncertainty import MeanEstimate, batch_mean
from vrelab.record import WINDOW_S, Record
from vrelab.results import NOTABLE_THD, DriveWaveform, Estimate, Notice

# Harmonics of the drive measured on the reference per sine level (physics §4.4), at most this many
# (and only those below Nyquist): a shaker's distortion lives in its first few harmonics, and
# ten of them (IEC 61000-4-7 goes to 40 for mains) keep the pass's cost at 21 basis functions.
DRIVE_HARMONICS = 10


@dataclass(frozen=True)
class SineLevel:
    """What the second pass over one sine level found (:func:`sine_level`)."""

    freq_hz: float  # the drive frequency, from the reference
    dut_mean: MeanEstimate  # the DUT's fitted offset, batch means over whole-period batches [g]
    ref_rms: MeanEstimate  # rms of the reference's fitted sine [g]
    t_centre_s: float  # centre time of the samples used
    n_samples: int  # samples used (whole batches)
    warnings: list[str]
    # the 2f estimate of the rectified shift (None: no reference, or 2f at or above Nyquist)
    shift_2f: MeanEstimate | None
    # the reference's waveform: harmonics, THD, E[x²], E[x³] (None: no reference)
    drive: DriveWaveform | None = None
    # the DUT's fitted offset per batch (in time order), whose mean is ``dut_mean``: the
    # level's own low-frequency noise (vrelab.analysis.levels.thirds_difference)
    batch_offsets: NDArray[np.float64] | None = None


def estimate_frequency(x: NDArray[np.float64], fs_hz: float) -> float:
    """Drive frequency: peak of a Hann-windowed FFT, a parabola through the log peak, then a
    least-squares sine-fit refinement.

    For a Hann window the log-magnitude peak is close to a parabola; the interpolated bin is
    good to about 0.01 bin for a clean sine (Gasior & Gonzalez, CERN AB-Note-2004-021). The
    refinement minimises the residual of the least-squares sine over the probe (IEEE Std 1057,
    four-parameter fit), to about 1e-8 bin, then Gauss-Newton steps of the same fit take it to
    the arithmetic's precision (1e-16 relative for a clean sine).
    """
    x = np.asarray(x, dtype=np.float64)
    n = len(x)
    if n < 16:
        raise ValueError(f"segment too short to find the drive frequency ({n} samples)")
    spec = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(n)))
    spec[:2] = 0.0
    k = int(np.argmax(spec))
    if spec[k] <= 0:
        raise ValueError("reference has no oscillation to find the drive frequency from")
    if 1 <= k < len(spec) - 1 and spec[k - 1] > 0 and spec[k + 1] > 0:
        a, b, c = np.log(spec[k - 1 : k + 2])
        den = a - 2 * b + c
        delta = 0.5 * (a - c) / den if den != 0 else 0.0
    else:
        delta = 0.0
    f0 = (k + delta) * fs_hz / n
    # Refine: the frequency whose least-squares sine (offset, cos, sin) leaves the smallest
    # residual over the probe (the four-parameter fit of IEEE Std 1057), searched within ±0.2 bin
    # of the interpolated peak; Hann-parabola interpolation alone is biased by up to ~0.01 bin.
    from scipy.optimize import minimize_scalar

    t = np.arange(n) / fs_hz
    xc = x - x.mean()
    xx = float(xc @ xc)
    sx = float(xc.sum())

    def residual(f: float) -> float:
        # the 3x3 normal equations of the (offset, cos, sin) fit: the residual is xᵀx − coefᵀ·Bᵀx
        # (no n×3 design matrix and SVD per evaluation; columns this well conditioned need none)
        ph = 2 * np.pi * f * t
        c, s = np.cos(ph), np.sin(ph)
        G = np.array([[n, c.sum(), s.sum()], [0.0, c @ c, c @ s], [0.0, 0.0, s @ s]])
        G = np.triu(G) + np.triu(G, 1).T
        rhs = np.array([sx, c @ xc, s @ xc])
        coef = np.linalg.solve(G, rhs)
        return xx - float(coef @ rhs)

    bw = fs_hz / n
    bounds = (f0 - 0.2 * bw, f0 + 0.2 * bw)
    res = minimize_scalar(residual, bounds=bounds, method="bounded", options={"xatol": 1e-7 * bw})
    f1 = float(res.x) if res.success else f0
    # The residual is flat to second order at its minimum, so its arithmetic resolves the
    # frequency only to about √ε_machine (1e-8 of a bin: a 1e-10 relative error that leaves
    # 1e-10 of the amplitude in a fitted offset). Finish with Gauss-Newton steps of the same
    # four-parameter fit (IEEE Std 1057, 4.1.3.3: the linearised frequency column
    # t·(-a·sin + b·cos) beside offset, cos, sin), which solve a linear system for the step
    # and so converge to the arithmetic's precision.
    for _ in range(3):
        ph = 2 * np.pi * f1 * t
        c, s = np.cos(ph), np.sin(ph)
        ab = np.linalg.lstsq(np.stack([np.ones(n), c, s], axis=1), xc, rcond=None)[0]
        tc = t - t.mean()
        d = tc * (-ab[1] * s + ab[2] * c)
        A = np.stack([np.ones(n), c, s, d], axis=1)
        step = float(np.linalg.lstsq(A, xc, rcond=None)[0][3]) / (2 * np.pi)
        if not (math.isfinite(step) and abs(step) < 0.1 * bw):
            break
        f1 += step
        if abs(step) < 1e-15 * f1:
            break
    return f1


def whole_period_batch(freq_hz: float, fs_hz: float, target_s: float = WINDOW_S) -> tuple[int, int]:
    """(periods m, samples L) per batch: L = round(m·fs/f) closest to a whole number of periods.

    m is searched around ``target_s·f``; the one whose m·fs/f lies nearest an integer wins, so
    the leftover of the drive in a batch mean is a tiny fraction of A/(2π·f·T).
    """
    p = fs_hz / freq_hz
    m0 = max(1, int(round(target_s * freq_hz)))
    cands = np.arange(max(1, int(0.6 * m0)), int(1.6 * m0) + 2)
    frac = np.abs(cands * p - np.round(cands * p))
    m = int(cands[int(np.argmin(frac + 1e-6 * np.abs(cands - m0) / m0))])
    return m, int(round(m * p))


def sine_level(
    record: Record, i0: int, i1: int, ref: str, block_size: int, freq_hint: float | None,
    shared: dict[Any, Any] | None = None,
) -> SineLevel:
    """Second pass over one sine level, samples ``i0:i1`` of ``record`` (channels ``dut`` and
    ``ref``; ``ref`` is ``"dut"`` when the record has no reference), read in blocks of about
    ``block_size``; ``freq_hint`` is the schedule's frequency (a warning when the drive is found
    more than 5 % away).

    ``shared``: what the DUT channels of one record share (their window stats' ``shared``): the
    drive frequency of a level is the reference's, found once for all of them.

    The 2f estimate (physics §6.1): a quadratic term k·m² on the DUT's motion m = Re[c1·e^{jθ}]
    (c1 the DUT's fitted phasor at f) adds k·|c1|²/2 at DC and k·c1²/2 at 2f, the same
    coefficient. So ``Re[(c2 - r2)·conj(c1)²]/|c1|²``, with c2 the DUT's fitted 2f phasor and r2
    the reference's (the shaker's own distortion, which the DUT merely follows), estimates the
    rectified shift k·|c1|²/2 without using the DC, hence immune to drift. None without a
    reference, or when 2f is at or above Nyquist."""
    fs = record.fs_hz
    warnings: list[str] = []
    f = _drive_frequency(record, i0, i1, ref, shared)
    if freq_hint is not None and abs(f - freq_hint) > 0.05 * freq_hint:
        warnings.append(Notice("frequency", f"drive found at {f:.4g} Hz, schedule says {freq_hint:.4g} Hz"))
    m, L = whole_period_batch(f, fs)
    nb = (i1 - i0) // L
    if nb < 3:
        raise ValueError(
            f"sine level {i0 / fs:.3g}-{i1 / fs:.3g} s holds fewer than 3 batches of {m} periods at {f:.4g} Hz"
        )
    stop = i0 + nb * L
    w = 2 * np.pi * f / fs
    # Per batch, the three-parameter sine fit of IEEE Std 1057 (offset + cos + sin at the drive
    # frequency, least squares): its offset is the DUT mean with the drive removed exactly, its
    # amplitude the reference level with no leakage from the negative-frequency image (a
    # single-bin DFT over not-quite-whole periods would bias the rms by up to |Σe^{-2jωn}|²/L²).
    # offset, cos, sin at f, and at 2f when it is below Nyquist (and a reference gives r2): five
    # orthogonal functions over whole periods, so the offset is the same as the three-term fit's
    two_f = ref != "dut" and 2 * f < 0.5 * fs
    nf = 5 if two_f else 3
    basis_sums = np.zeros((nb, nf, nf))
    # Σ (dut - fit)² per batch, for the leakage term below: summed directly (Σdut² - coefᵀ·Bᵀdut
    # cancels to ε·Σdut², whose square root, ~1e-8 of the offset, would pose as harmonics)
    dut_ss = np.zeros(nb)
    rhs = {c: np.zeros((nb, nf)) for c in ("dut", ref)}
    blk_len = max(L, (block_size // L) * L)
    chans = ["dut"] if ref == "dut" else ["dut", ref]
    labels = channel_labels(record)
    n_h = min(DRIVE_HARMONICS, int(math.ceil(0.5 * fs / f)) - 1) if ref != "dut" else 0
    n0, B0, G0, BH, GH = _batch_bases(w, L, two_f, n_h)
    rhs_h = np.zeros((nb, 2 * n_h + 1))
    ref_ss = np.zeros(nb)  # Σ (ref - its harmonic fit)² per batch: what the harmonics leave
    pos = i0
    for blk in exact_blocks(record, blk_len, chans, i0, stop):
        nn = len(blk["dut"])
        k = nn // L
        sl = slice((pos - i0) // L, (pos - i0) // L + k)
        # Phase from the segment start: batches of whole periods line up with it.
        R = _harmonic_rotations(w * ((pos - i0) + L * np.arange(k, dtype=np.float64)), nf)  # (batch, nf, nf)
        basis_sums[sl] = R @ G0 @ R.transpose(0, 2, 1)
        for c in chans:
            x = blk[c]
            check_finite(labels[c], x, pos)
            rhs[c][sl] = np.einsum("kij,kj->ki", R, x.reshape(k, L) @ B0.T)
            if c == ref and BH is not None and GH is not None:
                xr = x.reshape(k, L)
                rhs_h[sl] = xr @ BH.T
                # summed directly, as dut_ss above: Σx² - coefᵀ·Bᵀx would cancel to ε·Σx²
                e = xr - np.linalg.solve(GH, rhs_h[sl].T).T @ BH
                ref_ss[sl] = np.einsum("ij,ij->i", e, e)
            if c == "dut":
                th = np.linalg.solve(basis_sums[sl], rhs[c][sl][..., None])[..., 0]
                e = x.reshape(k, L) - np.einsum("kji,kj->ki", R, th) @ B0  # the fit, unrotated
                dut_ss[sl] = np.einsum("ij,ij->i", e, e)
        pos += nn
    raw = {c: np.linalg.solve(basis_sums, rhs[c][..., None])[..., 0] for c in chans}
    coef, u_df = _frequency_corrected(raw, ref, w, L, n0, B0, G0)
    dut_means = coef["dut"][:, 0]
    ref_ms = (coef[ref][:, 1] ** 2 + coef[ref][:, 2] ** 2) / 2.0  # mean square at the drive frequency
    dm = batch_mean(dut_means)
    # A batch is L samples, ε = |m·fs/f - L| samples off m whole periods: the fit removes the
    # drive's f (and 2f) exactly, but what the DUT holds beyond them (harmonics of a clipped or
    # nonlinear output, rms r from the fit's residual) is averaged over ε samples too many or
    # too few, the same in every batch (they start at the same phase), so their scatter cannot
    # show it: up to (π/2)·ε·√2·r/L in the offset, taken as a rectangular bound (÷√3). (A
    # harmonic at θ = h·ω rad/sample leaves |sin(h·ω·ε/2)/sin(θ/2)|/L of its amplitude in a
    # mean over L samples; for θ up to π, i.e. below Nyquist, that is at most (π/2)·ε/L.)
    eps = abs(m * fs / f - L)
    resid = dut_ss / L
    u_leak = 0.5 * math.pi * eps * math.sqrt(2.0 * float(np.mean(resid))) / L / math.sqrt(3.0)
    peak = float(np.max(np.abs(dut_means)) + np.max(np.hypot(coef["dut"][:, 1], coef["dut"][:, 2])))
    u_extra = math.hypot(u_leak, u_df["dut"], _rounding_u(peak, L))
    dm = MeanEstimate(dm.mean, math.hypot(dm.u, u_extra), dm.tau, dm.batch, dm.n_batches)
    rm = batch_mean(ref_ms, detrend=False)
    rms = math.sqrt(max(rm.mean, 0.0))
    # the rms's share of the frequency correction's u and the arithmetic's rounding
    u_rms = math.hypot(rm.u / (2 * rms), u_df["rms"], _rounding_u(rms, L)) if rms > 0 else math.nan
    t_c = (i0 + stop) / 2 / fs
    h2 = _two_f_shift(coef["dut"], coef[ref]) if two_f else None
    drive = None
    if GH is not None:
        coef_h = np.asarray(np.linalg.solve(GH, rhs_h.T).T, dtype=np.float64)
        drive = _drive_waveform(coef_h[:, 1:], w * L, ref_ss / L, rms, u_rms)
        if two_f:
            note = _response_at_2f(coef["dut"], coef[ref], drive, f)
            if note:
                warnings.append(Notice("drive", note))
    return SineLevel(f, dm, MeanEstimate(rms, u_rms, rm.tau, rm.batch, rm.n_batches), t_c, stop - i0, warnings, h2,
                     drive, np.asarray(dut_means, dtype=np.float64))


def _drive_frequency(record: Record, i0: int, i1: int, ref: str, shared: dict[Any, Any] | None) -> float:
    """The drive's frequency on samples ``i0:i1``, estimated on the first 2**17 samples of
    ``ref``; found once per level for all the DUT channels sharing ``shared``."""
    key = ("frequency", i0, i1)
    if shared is not None and key in shared:
        return float(shared[key])
    n_probe = min(i1 - i0, 1 << 17)
    probe = next(record.blocks(n_probe, [ref], i0, i0 + n_probe))[ref]
    f = estimate_frequency(probe, record.fs_hz)
    if shared is not None:
        shared[key] = f
    return f


def _batch_bases(w: float, L: int, two_f: bool, n_h: int) -> tuple[NDArray[np.int_], NDArray[np.float64],
                                                                   NDArray[np.float64], NDArray[np.float64] | None,
                                                                   NDArray[np.float64] | None]:
    """(n0, B0, G0, BH, GH): the first batch's sample index, fit basis and its Gram matrix, and
    the reference's harmonic basis and Gram matrix (None without harmonics, ``n_h`` = 0).

    The basis of a batch starting at phase φ is the first batch's, rotated: each harmonic h's
    (cos, sin) pair turns by h·φ. So the functions are evaluated once, on L samples; each
    batch's sums are the first batch's sums rotated (Gram matrix R·G0·Rᵀ, right side R·(B0·x)),
    with no trigonometry per sample. The reference's harmonics 1..H (physics §4.4) are fitted
    per batch in the batch's own phase frame (amplitudes and moments do not depend on the frame;
    _drive_waveform turns the phasors to a common one): the same basis for every batch, so one
    Gram matrix."""
    n0 = np.arange(L)
    rows = [np.ones(L), np.cos(w * n0), np.sin(w * n0)] + ([np.cos(2 * w * n0), np.sin(2 * w * n0)] if two_f else [])
    B0 = np.stack(rows)  # (functions, L)
    G0 = B0 @ B0.T
    BH = np.stack([np.ones(L)] + [g(h * w * n0) for h in range(1, n_h + 1) for g in (np.cos, np.sin)]) if n_h else None
    GH: NDArray[np.float64] | None = BH @ BH.T if BH is not None else None
    return n0, B0, G0, BH, GH


def _two_f_shift(dut: NDArray[np.float64], ref: NDArray[np.float64]) -> MeanEstimate | None:
    """The 2f estimate of the rectified shift, ``Re[(c2 - r2)·conj(c1)²]/|c1|²`` per batch
    (``sine_level``'s docstring), from the batches' fitted phasors (columns 1-4: cos, sin at f
    and 2f); None where a batch has no response at f."""
    c1 = dut[:, 1] - 1j * dut[:, 2]
    c2 = (dut[:, 3] - ref[:, 3]) - 1j * (dut[:, 4] - ref[:, 4])
    m2 = np.abs(c1) ** 2
    if np.all(m2 > 0):
        return batch_mean(np.real(c2 * np.conj(c1) ** 2) / m2, detrend=False)
    return None


# A distorted drive's moments are the reference's: the DUT is taken to see the same waveform,
# i.e. its response at 2f relative to f to be 1. Beyond this departure (on a drive whose second
# harmonic reaches results.NOTABLE_THD of the fundamental) the level says that E[x³] may not be
# the one the DUT's nonlinearity saw.
DRIVE_RESPONSE_TOL = 0.05


def _response_at_2f(dut: NDArray[np.float64], ref: NDArray[np.float64], drive: DriveWaveform, f: float) -> str | None:
    """A note when the DUT's output shows a response at 2f, relative to the one at f, that
    departs from 1 by more than ``DRIVE_RESPONSE_TOL`` while the drive's second harmonic reaches
    ``NOTABLE_THD`` of the fundamental: ``ρ = (c2_dut/c2_ref)/(c1_dut/c1_ref)`` from the
    level's mean phasors (columns 1-4 of the pass's fit: cos, sin at f and 2f). The DUT's output at 2f also holds its own k2·A²/2
    line, negligible against a drive's percent-level harmonic at µg/g² nonlinearity; its output
    filter acts after the nonlinearity, so a departure says the assumption *may* fail, not
    that it does."""
    h = drive.harmonics_rms_g
    if len(h) < 2 or not (h[0].value > 0 and h[1].value >= NOTABLE_THD * h[0].value):
        return None
    d1 = complex(np.mean(dut[:, 1]), -np.mean(dut[:, 2]))
    d2 = complex(np.mean(dut[:, 3]), -np.mean(dut[:, 4]))
    r1 = complex(np.mean(ref[:, 1]), -np.mean(ref[:, 2]))
    r2 = complex(np.mean(ref[:, 3]), -np.mean(ref[:, 4]))
    if 0 in (d1, r1, r2):
        return None
    rho = (d2 / r2) / (d1 / r1)
    if abs(rho - 1) <= DRIVE_RESPONSE_TOL:
        return None
    return (f"sine {f:.4g} Hz: the drive holds {100 * h[1].value / h[0].value:.2g} % of second harmonic and the DUT's "
            f"output responds at 2f {abs(rho):.3g}x (phase {math.degrees(np.angle(rho)):+.0f}°) as at f: the DUT may not "
            "see the reference's waveform, so the E[x³] its VRC is corrected with may be off by that much (physics §4.4)")


def _drive_waveform(coef: NDArray[np.float64], batch_phase: float, resid_ms: NDArray[np.float64],
                    rms: float, u_rms: float) -> DriveWaveform:
    """The reference's waveform over a sine level from its per-batch harmonic fits.

    ``coef``: per batch (rows), the (cos, sin) coefficients of harmonics 1..H in the batch's
    own frame (phase 0 at its first sample); ``batch_phase``: the drive's phase advance from
    one batch to the next [rad]; ``resid_ms``: each batch's mean square about its harmonic fit;
    ``rms``, ``u_rms``: the level's fundamental rms and its u from the pass's own fit.

    * Each harmonic's amplitude: its phasors turned to the first batch's frame (harmonic h's
      turns by h·batch_phase a batch) and projected on their mean's direction, the mean of the
      projections by batch means (:func:`batch_mean`): coherent, so a harmonic the drive does
      not hold is not lifted to the noise's Rayleigh mean. The fundamental is the level's rms.
    * E[x²] = rms² + Σ_{h≥2} A_h²/2 (per batch, batch means for its u): for a pure sine it is the
      level's rms² to the harmonics' noise power. E[x³]: per batch, the mean of the cube of the
      fitted waveform on 3H+1 equally spaced phases, which is exact for a trigonometric
      polynomial of degree H (the cube has degree 3H), batch means for its u.
    * THD = √(Σ_{h≥2} A_h²)/A_1, its u by first-order propagation of the amplitudes' u.
    """
    nb, two_h = coef.shape
    n_h = two_h // 2
    a, b = coef[:, 0::2], coef[:, 1::2]
    h = np.arange(1, n_h + 1)
    turn = np.exp(-1j * np.outer(np.arange(nb), h) * batch_phase)  # (batch, harmonic)
    ph = (a - 1j * b) * turn  # x = Re[ph·e^{jhθ}] in the first batch's frame
    mean = ph.mean(axis=0)
    unit = np.where(np.abs(mean) > 0, mean / np.where(np.abs(mean) > 0, np.abs(mean), 1.0), 1.0)
    amps = []
    for i in range(n_h):
        est = batch_mean(np.real(ph[:, i] * np.conj(unit[i])) / math.sqrt(2.0), detrend=False)
        amps.append(Estimate(abs(est.mean), est.u, "g"))
    amps[0] = Estimate(rms, u_rms, "g")
    power_h = (a[:, 1:] ** 2 + b[:, 1:] ** 2).sum(axis=1) / 2.0  # Σ_{h≥2} A_h²/2 per batch
    m2 = batch_mean(rms * rms + power_h, detrend=False)
    m2 = MeanEstimate(m2.mean, math.hypot(m2.u, 2 * rms * u_rms), m2.tau, m2.batch, m2.n_batches)
    n_grid = 3 * n_h + 1
    th = 2 * np.pi * np.arange(n_grid) / n_grid
    x = a @ np.cos(np.outer(h, th)) + b @ np.sin(np.outer(h, th))  # (batch, phase)
    m3 = batch_mean((x**3).mean(axis=1), detrend=False)
    harm = np.array([e.value for e in amps[1:]])
    total = float(np.sqrt(np.sum(harm**2)))
    thd = total / rms if rms > 0 else math.nan
    if total > 0 and rms > 0:
        u_harm = np.array([e.u for e in amps[1:]])
        u_thd = math.hypot(float(np.sqrt(np.sum((harm * u_harm) ** 2))) / (total * rms), thd * u_rms / rms)
    else:
        u_thd = math.nan
    resid = math.sqrt(float(np.mean(resid_ms)))
    return DriveWaveform(tuple(amps), Estimate(thd, u_thd, "1"), Estimate(m2.mean, m2.u, "g^2"),
                         Estimate(m3.mean, m3.u, "g^3"), resid)


def _frequency_corrected(
    raw: dict[str, NDArray[Any]], ref: str, w: float, L: int, n0: NDArray[Any],
    B0: NDArray[np.float64], G0: NDArray[np.float64],
) -> tuple[dict[str, NDArray[Any]], dict[str, float]]:
    """Per-batch fit coefficients with the first-order error of the fit's frequency removed,
    and the standard uncertainty that correction leaves (keys ``"dut"``: the offset, ``"rms"``:
    the reference's rms).

    The fit's frequency ``w`` [rad/sample] is the probe's estimate, good to about 1e-8 of a
    bin (:func:`estimate_frequency` minimises a residual, which is flat to second order at
    its minimum, so its arithmetic resolves the frequency only to about √ε_machine). A fit at
    ``w`` of a drive at ``w + Δ`` leaves every coefficient off by ``Δ·M·θ`` to first order,
    ``M = G⁻¹·B·Dᵀ`` with ``D = ∂B/∂w`` (rows ``0, -n·sin, n·cos, -2n·sin 2θ, 2n·cos 2θ``
    over a batch's samples n); for the offset that is the fundamental's amplitude times
    ``|Σ_n e^{jwn}|/L ≈ Δ/w``: a relative frequency error of 1e-10 puts 1e-10 of the drive's
    amplitude into the DC, the same in every batch (they start at the same phase of the
    drive), so no scatter shows it. Δ is measured here to the arithmetic's precision: the
    fundamental's phase (the reference's; the DUT's without one) advances by ``Δ·L`` from one
    batch to the next, so Δ is the slope of the batches' phases against their start sample
    (least squares), and its standard error carries into the coefficients through the same M.
    The basis of batch b is the first one's rotated by R_b (:func:`_harmonic_rotations`), so
    is D, and ``M_b = R_b·M₀·R_bᵀ``.
    """
    nf = B0.shape[0]
    D0 = np.zeros_like(B0)
    for h in range(1, (nf - 1) // 2 + 1):
        D0[2 * h - 1] = -h * n0 * B0[2 * h]
        D0[2 * h] = h * n0 * B0[2 * h - 1]
    M0 = np.linalg.solve(G0, B0 @ D0.T)
    nb = next(iter(raw.values())).shape[0]
    R = _harmonic_rotations(w * L * np.arange(nb, dtype=np.float64), nf)
    M = R @ M0 @ R.transpose(0, 2, 1)
    src = raw[ref]
    phase = np.unwrap(np.angle(src[:, 1] - 1j * src[:, 2]))
    s = L * np.arange(nb, dtype=np.float64)
    sc = s - s.mean()
    delta = float(sc @ (phase - phase.mean()) / (sc @ sc))
    r = phase - phase.mean() - delta * sc
    u_delta = math.sqrt(float(r @ r) / max(nb - 2, 1) / float(sc @ sc))
    if not (math.isfinite(delta) and math.isfinite(u_delta) and abs(delta) * L < 0.1):
        # a phase that wanders by more than 0.1 rad a batch is no drive at one frequency (a
        # reference without the sine): no correction rather than one made of noise
        return raw, {"dut": 0.0, "rms": 0.0}
    out = {c: th - delta * np.einsum("kij,kj->ki", M, th) for c, th in raw.items()}
    d_off = float(np.mean(np.einsum("kj,kj->k", M[:, 0, :], raw["dut"])))
    a, b = out[ref][:, 1], out[ref][:, 2]
    amp = np.hypot(a, b)
    # ∂(rms)/∂Δ = (a·∂a + b·∂b)/(√2·amp), ∂θ = -M·θ
    dth = np.einsum("kij,kj->ki", M, raw[ref])
    d_rms = float(np.mean(np.where(amp > 0, (a * dth[:, 1] + b * dth[:, 2]) / (math.sqrt(2.0) * np.maximum(amp, 1e-300)), 0.0)))
    return out, {"dut": abs(d_off) * u_delta, "rms": abs(d_rms) * u_delta}


def _rounding_u(scale: float, n: int) -> float:
    """Standard uncertainty of a fitted coefficient of size ``scale`` from float64 arithmetic
    on ``n`` samples. Each recorded sample is rounded to half an ulp (relative ε/2, ε = 2.2e-16)
    and the batch's sums (BLAS, blocked) accumulate at most about ε·log₂(n) of their terms'
    magnitude, for which ``scale`` (the offset plus the fundamental's amplitude) stands; the
    rotations and the 3×3 or 5×5 solves (condition number ≈ 2: the columns are orthogonal over
    whole periods, each of norm √(n/2) against √n) add a few ε. A rectangular bound of
    ``4·ε·(1 + log₂ n)·scale``, ÷√3. It keeps a noiseless record's u from claiming more than
    the arithmetic can (its scatter alone can be 0)."""
    return 4.0 * float(np.finfo(np.float64).eps) * (1.0 + math.log2(max(n, 1))) * abs(scale) / math.sqrt(3.0)


def _harmonic_rotations(phi: NDArray[np.float64], nf: int) -> NDArray[np.float64]:
    """Per phase φ, the matrix turning [1, cos θ, sin θ, cos 2θ, sin 2θ] (its first ``nf``)
    into the same functions of θ + φ: block-diagonal, 1 then the rotation by h·φ of harmonic h."""
    R = np.zeros((len(phi), nf, nf))
    R[:, 0, 0] = 1.0
    for h in range(1, (nf - 1) // 2 + 1):
        c, s = np.cos(h * phi), np.sin(h * phi)
        i = 2 * h - 1
        R[:, i, i], R[:, i, i + 1] = c, -s
        R[:, i + 1, i], R[:, i + 1, i + 1] = s, c
    return R



__all__ = ["SineLevel", "estimate_frequency", "sine_level", "whole_period_batch"]
