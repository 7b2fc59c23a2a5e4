"""Spectra of long records, streamed: Welch PSD in blocks and the profile tolerance check (physics §3).

One owner for the Welch PSD of the package: the synthesis checks its drives with it, the analysis
the recorded reference of each level.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Iterable

import numpy as np
import scipy.fft
import scipy.signal
from numpy.typing import ArrayLike, NDArray

from vrelab import _validate as v
from vrelab.profiles import RandomProfile

# --- tolerance check --------------------------------------------------------------------------


def whole_segments(buf: NDArray[Any], x: NDArray[Any], nperseg: int, step: int
                   ) -> tuple[NDArray[Any] | None, int, NDArray[Any]]:
    """A streamed Welch estimate's buffering: ``x`` appended to the samples kept (``buf``, along
    axis 0), returned as ``(run, n_seg, rest)``: the run of ``n_seg`` whole segments of
    ``nperseg`` samples ``step`` apart (None when there is not one yet), and the samples to keep
    for the next block (a copy: no view holds the block). Estimating each run and weighting it
    by ``n_seg`` gives exactly the estimate over the whole record."""
    joined = np.concatenate((buf, x)) if buf.size else x
    if joined.shape[0] < nperseg:
        return None, 0, joined.copy()
    n_seg = (joined.shape[0] - nperseg) // step + 1
    used = nperseg + (n_seg - 1) * step
    return joined[:used], n_seg, joined[n_seg * step :].copy()


class WelchAccumulator:
    """Welch PSD of an arbitrarily long record fed in blocks (memory: one segment).

    Segments of ``nperseg`` samples, Hann window, 50 % overlap, mean removed per segment and
    density scaling, exactly as ``scipy.signal.welch(x, fs, nperseg=nperseg)`` on the whole
    record: the samples are buffered until whole segments are available, each run of whole
    segments goes through scipy.signal.welch, and its mean periodogram is added with its
    segment count. Also accumulates the sum and the sum of squares for the overall (AC) rms.
    """

    def __init__(self, fs_hz: float, nperseg: int) -> None:
        self.fs_hz = v.positive_scalar("fs_hz", fs_hz)
        self.nperseg = v.integer("nperseg", nperseg, 8)
        self.step = self.nperseg - self.nperseg // 2
        self._buf = np.zeros(0)
        self._sum: NDArray[np.float64] | None = None
        self.n_segments = 0
        self.n_samples = 0
        self._sum_sq = 0.0
        self._sum_x = 0.0
        self.freq_hz = scipy.fft.rfftfreq(self.nperseg, 1.0 / self.fs_hz)

    def add(self, block: ArrayLike) -> None:
        x = v.finite("block", np.asarray(block, dtype=np.float64).ravel())
        self.n_samples += x.size
        self._sum_sq += float(np.dot(x, x))
        self._sum_x += float(np.sum(x))
        run, n_seg, self._buf = whole_segments(self._buf, x, self.nperseg, self.step)
        if run is not None:
            _, pxx = scipy.signal.welch(run, self.fs_hz, nperseg=self.nperseg, noverlap=self.nperseg - self.step)
            self._sum = pxx * n_seg if self._sum is None else self._sum + pxx * n_seg
            self.n_segments += n_seg

    @property
    def psd(self) -> NDArray[np.float64]:
        """Mean periodogram [unit²/Hz] over all whole segments so far."""
        if self._sum is None:
            raise ValueError(
                f"record too short for a Welch PSD: {self.n_samples} samples < nperseg = {self.nperseg}"
            )
        return self._sum / self.n_segments

    @property
    def rms(self) -> float:
        """Overall rms about the mean (a recorded channel's DC offset is not vibration)."""
        if self.n_samples == 0:
            raise ValueError("record is empty")
        mean = self._sum_x / self.n_samples
        return math.sqrt(max(self._sum_sq / self.n_samples - mean * mean, 0.0))


@dataclass(frozen=True, eq=False)
class ToleranceResult:
    """Outcome of :func:`psd_tolerance_check`.

    ``freq_hz``, ``psd_measured``, ``psd_profile`` hold the judged Welch bins; deviations are
    ``10·log10(measured/profile)`` in dB; ``out_of_tolerance_hz`` lists the contiguous
    frequency ranges (first, last judged bin) outside ±tol_db.
    """

    passed: bool
    max_dev_db: float
    min_dev_db: float
    rms_g: float
    rms_ratio: float
    tol_db: float
    rms_tol: float
    band_hz: tuple[float, float]
    freq_hz: NDArray[np.float64]
    psd_measured: NDArray[np.float64]
    psd_profile: NDArray[np.float64]
    out_of_tolerance_hz: tuple[tuple[float, float], ...]
    n_segments: int
    resolution_hz: float

    def to_dict(self) -> dict[str, Any]:
        return {
            "passed": bool(self.passed),
            "max_dev_db": float(self.max_dev_db),
            "min_dev_db": float(self.min_dev_db),
            "rms_g": float(self.rms_g),
            "rms_ratio": float(self.rms_ratio),
            "tol_db": float(self.tol_db),
            "rms_tol": float(self.rms_tol),
            "band_hz": [float(x) for x in self.band_hz],
            "out_of_tolerance_hz": [[float(a), float(b)] for a, b in self.out_of_tolerance_hz],
            "n_segments": int(self.n_segments),
            "resolution_hz": float(self.resolution_hz),
            "freq_hz": self.freq_hz.tolist(),
            "psd_measured": self.psd_measured.tolist(),
            "psd_profile": self.psd_profile.tolist(),
        }


def _default_nperseg(profile: RandomProfile, fs_hz: float) -> int:
    """Power of two with resolution ≤ f_lo/2: the lowest segment spans a few Welch bins."""
    want = fs_hz / (profile.band[0] / 2)
    return int(min(max(1 << math.ceil(math.log2(want)), 64), 2**16))


def psd_tolerance_check(
    blocks_or_array: NDArray[Any] | Iterable[ArrayLike],
    fs_hz: float,
    profile: RandomProfile,
    f_lo_hz: float | None = None,
    f_hi_hz: float | None = None,
    tol_db: float = 3.0,
    rms_tol: float = 0.10,
    nperseg: int | None = None,
) -> ToleranceResult:
    """Is a drive (or a recorded control channel) within tolerance of a profile? (physics §3)

    Parameters
    ----------
    blocks_or_array : array or iterable of arrays
        The signal [g], whole or as consecutive blocks of any length (streamed: memory does
        not grow with the record).
    fs_hz : float
        Sample rate [Hz].
    profile : RandomProfile
        The reference PSD [g²/Hz] and grms.
    f_lo_hz, f_hi_hz : float, optional
        Frequencies judged [Hz]; default the profile's band. Use e.g. f_hi_hz = 1000 with
        tol_db = 1.5 for the tighter bar below 1 kHz (MIL-STD-202 [4]).
    tol_db : float
        PSD tolerance, ± dB (default 3).
    rms_tol : float
        Overall rms tolerance, relative (default 0.10 = ±10 %), against ``profile.grms``.
    nperseg : int, optional
        Welch segment length; default a power of two with resolution ≤ f_lo/2.

    Returns
    -------
    ToleranceResult

    Notes
    -----
    Welch bins closer than two bin widths to an edge of the profile's band are not judged:
    there the Hann window's main lobe (±2 bins) straddles the PSD's step, so even an exact
    drive reads about -3 dB at the edge bin. With n_d segments the PSD's normalized random
    error is about 1/√n_d (Bendat & Piersol [1]); a record needs a few hundred segments before
    a ±1.5 dB bar over hundreds of bins is meaningful.
    """
    fs = v.positive_scalar("fs_hz", fs_hz)
    tol = v.positive_scalar("tol_db", tol_db)
    rtol = v.positive_scalar("rms_tol", rms_tol)
    if not isinstance(profile, RandomProfile):
        raise ValueError(f"profile must be a RandomProfile, got {type(profile).__name__}")
    nps = _default_nperseg(profile, fs) if nperseg is None else v.integer("nperseg", nperseg, 8)
    lo = profile.band[0] if f_lo_hz is None else v.positive_scalar("f_lo_hz", f_lo_hz)
    hi = profile.band[1] if f_hi_hz is None else v.positive_scalar("f_hi_hz", f_hi_hz)
    if hi <= lo:
        raise ValueError(f"f_hi_hz must be above f_lo_hz, got {lo:g}-{hi:g} Hz")

    acc = WelchAccumulator(fs, nps)
    if isinstance(blocks_or_array, np.ndarray):
        arr = blocks_or_array.ravel()
        chunk = max(nps, 2**18)
        for i in range(0, arr.size, chunk):
            acc.add(arr[i : i + chunk])
    else:
        for block in blocks_or_array:
            acc.add(block)

    f = acc.freq_hz
    res = fs / nps
    guard = 2.0 * res
    judged = (f >= max(lo, profile.band[0] + guard)) & (f <= min(hi, profile.band[1] - guard))
    judged &= (f >= lo) & (f <= hi)
    if not judged.any():
        raise ValueError(
            f"no Welch bin to judge in {lo:g}-{hi:g} Hz at resolution {res:g} Hz (nperseg = {nps}); "
            "lengthen nperseg"
        )
    fj = f[judged]
    meas = acc.psd[judged]
    ref = np.asarray(profile.psd(fj), dtype=np.float64)
    with np.errstate(divide="ignore"):
        dev = 10.0 * np.log10(meas / ref)
    bad = np.abs(dev) > tol
    ranges: list[tuple[float, float]] = []
    if bad.any():
        idx = np.flatnonzero(bad)
        splits = np.flatnonzero(np.diff(idx) > 1) + 1
        for run in np.split(idx, splits):
            ranges.append((float(fj[run[0]]), float(fj[run[-1]])))
    rms = acc.rms
    ratio = rms / profile.grms
    passed = (not bad.any()) and abs(ratio - 1.0) <= rtol
    return ToleranceResult(
        passed=bool(passed),
        max_dev_db=float(np.max(dev)),
        min_dev_db=float(np.min(dev)),
        rms_g=rms,
        rms_ratio=ratio,
        tol_db=tol,
        rms_tol=rtol,
        band_hz=(lo, hi),
        freq_hz=fj,
        psd_measured=meas,
        psd_profile=ref,
        out_of_tolerance_hz=tuple(ranges),
        n_segments=acc.n_segments,
        resolution_hz=res,
    )
