"""A sine level's second pass over the record (SPEC 4, the sine method of IEEE Std 1293).

The drive frequency from the reference (:func:`estimate_frequency`: Hann-windowed FFT peak,
log-parabolic interpolation, then a sine-fit refinement), then batches of a whole number of
drive periods (:func:`whole_period_batch`: the number chosen so that a batch is within a small
fraction of a sample of whole periods), in each a three-parameter sine fit (IEEE Std 1057:
offset, cos, sin at the drive frequency) of reference and DUT (:func:`sine_level`): level = rms
of the reference's fitted sine, DUT mean = the DUT's fitted offset, the drive removed exactly.
A plain mean over a non-integer number of periods would leave a residual of order A/(2π·f·T)
(SPEC 4).
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
from vrelab.results import Notice


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


def estimate_frequency(x: NDArray[np.float64], fs_hz: float) -> float:
    """Drive frequency: peak of a Hann-windowed FFT, a parabola through the log peak, then a
    least-squares sine-fit refinement.

    For a Hann window the log-magnitude peak is close to a parabola; the interpolated bin is
    good to about 0.01 bin for a clean sine (Gasior & Gonzalez, CERN AB-Note-2004-021). The
    refinement minimises the residual of the least-squares sine over the probe (IEEE Std 1057,
    four-parameter fit), good to about 1e-6 bin for a clean sine.
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
    return float(res.x) if res.success else f0


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

    The 2f estimate (SPEC 6.1): a quadratic term k·m² on the DUT's motion m = Re[c1·e^{jθ}]
    (c1 the DUT's fitted phasor at f) adds k·|c1|²/2 at DC and k·c1²/2 at 2f, the same
    coefficient. So ``Re[(c2 - r2)·conj(c1)²]/|c1|²``, with c2 the DUT's fitted 2f phasor and r2
    the reference's (the shaker's own distortion, which the DUT merely follows), estimates the
    rectified shift k·|c1|²/2 without using the DC, hence immune to drift. None without a
    reference, or when 2f is at or above Nyquist."""
    fs = record.fs_hz
    warnings: list[str] = []
    key = ("frequency", i0, i1)
    if shared is not None and key in shared:
        f = shared[key]
    else:
        n_probe = min(i1 - i0, 1 << 17)
        probe = next(record.blocks(n_probe, [ref], i0, i0 + n_probe))[ref]
        f = estimate_frequency(probe, fs)
        if shared is not None:
            shared[key] = f
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
    dut_ss = np.zeros(nb)  # Σ dut² per batch: the fit's residual, for the leakage term below
    rhs = {c: np.zeros((nb, nf)) for c in ("dut", ref)}
    blk_len = max(L, (block_size // L) * L)
    chans = ["dut"] if ref == "dut" else ["dut", ref]
    labels = channel_labels(record)
    # The basis of a batch starting at phase φ is the first batch's, rotated: each harmonic h's
    # (cos, sin) pair turns by h·φ. So the functions are evaluated once, on L samples; each
    # batch's sums are the first batch's sums rotated (Gram matrix R·G0·Rᵀ, right side R·(B0·x)),
    # with no trigonometry per sample.
    n0 = np.arange(L)
    rows = [np.ones(L), np.cos(w * n0), np.sin(w * n0)] + ([np.cos(2 * w * n0), np.sin(2 * w * n0)] if two_f else [])
    B0 = np.stack(rows)  # (functions, L)
    G0 = B0 @ B0.T
    pos = i0
    for blk in exact_blocks(record, blk_len, chans, i0, stop):
        nn = len(blk["dut"])
        k = nn // L
        sl = slice((pos - i0) // L, (pos - i0) // L + k)
        # Phase from the segment start: batches of whole periods line up with it.
        R = _harmonic_rotations(w * ((pos - i0) + L * np.arange(k)), nf)  # (batch, nf, nf)
        basis_sums[sl] = R @ G0 @ R.transpose(0, 2, 1)
        for c in chans:
            x = blk[c]
            check_finite(labels[c], x, pos)
            rhs[c][sl] = np.einsum("kij,kj->ki", R, x.reshape(k, L) @ B0.T)
            if c == "dut":
                dut_ss[sl] = np.einsum("ij,ij->i", x.reshape(k, L), x.reshape(k, L))
        pos += nn
    coef = {c: np.linalg.solve(basis_sums, rhs[c][..., None])[..., 0] for c in chans}
    dut_means = coef["dut"][:, 0]
    ref_ms = (coef[ref][:, 1] ** 2 + coef[ref][:, 2] ** 2) / 2.0  # mean square at the drive frequency
    dm = batch_mean(dut_means)
    # A batch is L samples, ε = |m·fs/f - L| samples off m whole periods: the fit removes the
    # drive's f (and 2f) exactly, but what the DUT holds beyond them (harmonics of a clipped or
    # nonlinear output, rms r from the fit's residual) is averaged over ε samples too many or
    # too few, the same in every batch (they start at the same phase), so their scatter cannot
    # show it: up to ε·√2·r/L in the offset, taken as a rectangular bound (÷√3).
    eps = abs(m * fs / f - L)
    resid = np.maximum(dut_ss - np.einsum("ki,ki->k", coef["dut"], rhs["dut"]), 0.0) / L
    u_leak = eps * math.sqrt(2.0 * float(np.mean(resid))) / L / math.sqrt(3.0)
    if u_leak > 0:
        dm = MeanEstimate(dm.mean, math.hypot(dm.u, u_leak), dm.tau, dm.batch, dm.n_batches)
    rm = batch_mean(ref_ms, detrend=False)
    rms = math.sqrt(max(rm.mean, 0.0))
    u_rms = rm.u / (2 * rms) if rms > 0 else math.nan
    t_c = (i0 + stop) / 2 / fs
    h2 = None
    if two_f:
        c1 = coef["dut"][:, 1] - 1j * coef["dut"][:, 2]
        c2 = (coef["dut"][:, 3] - coef[ref][:, 3]) - 1j * (coef["dut"][:, 4] - coef[ref][:, 4])
        m2 = np.abs(c1) ** 2
        if np.all(m2 > 0):
            h2 = batch_mean(np.real(c2 * np.conj(c1) ** 2) / m2, detrend=False)
    return SineLevel(f, dm, MeanEstimate(rms, u_rms, rm.tau, rm.batch, rm.n_batches), t_c, stop - i0, warnings, h2)


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
