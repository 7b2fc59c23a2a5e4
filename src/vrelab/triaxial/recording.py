"""A triaxial profile measured from a recording: Welch cross-spectral matrix, streamed (physics §1.6).

Three acceleration channels of a reference (x, y, z) give the one-sided cross-spectral density
matrix ``S_jk(f) = E[A_j A_k*]`` [g²/Hz] by Welch's method (Hann window, 50 % overlap, mean
removed per segment, :func:`scipy.signal.csd`), fed block by block so that memory is one
segment whatever the length of the record (:class:`CsdAccumulator`, the same numbers as one
``scipy.signal.csd`` over the whole record). It is then averaged over log-spaced bands
(:func:`band_csd`): each breakpoint's value is the mean of the Welch bins in its band, placed at
the band's geometric centre. For a smooth spectrum that is the value there; where the PSD curves
within a band, or the phase turns across it (a delay), the band mean differs from the centre
value (a power law ``f^n`` over a third-octave band: 0 % for n = -2, +1.8 % for n = 2) and the
coherence of the band mean is lowered by the turning phase. Say so where it matters: choose more
points per octave.

Statistical uncertainty (Gaussian data, a spectrum locally flat over a band; Bendat & Piersol,
*Random Data*, 4th ed., Wiley 2010, Table 9.6): with ``n_d`` independent averages,

* PSD: ``u(P) = P/√n_d``;
* coherence γ²: ``u(γ²) = √2·(1-γ²)·|γ|/√n_d`` with the estimate's bias ``(1-γ²)²/n_d`` added in
  quadrature (so that a coherence near 0, where the first term vanishes, still has its spread);
* phase: ``u(θ) = √(1-γ²)/(|γ|·√(2·n_d))`` [rad], undefined (None) where γ² < 1/n_d.

``n_d`` counts the band's averages: the Welch segments, discounted for their overlap by Welch's
formula ``K/(1 + 2·Σ_{j≥1}(1-j/K)·c(j)²)`` with ``c(j)`` the window's overlap correlation
(Welch 1967, IEEE Trans. Audio Electroacoust. 15(2): 70-73; Hann at 50 %: c(1) = 0.167), times
the band's bins, discounted the same way for the window's correlation of neighbouring bins
(``ρ(d) = |Σ w² e^{-2πi d n/N}|²/(Σ w²)²``; Hann: ρ(1) = 4/9, ρ(2) = 1/36). Both discounts are
exact for white Gaussian noise; the product neglects the small correlation of neighbouring bins
in overlapping segments.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, Mapping, Sequence, TypedDict, Unpack, cast

import numpy as np
import scipy.fft
import scipy.signal
from numpy.typing import ArrayLike, NDArray

from vrelab import _keywords
from vrelab import _validate as v
from vrelab.spectra import whole_segments
from vrelab.triaxial.profile import AXES, TriaxialProfile

if TYPE_CHECKING:
    from vrelab.analysis.readers import Scale
    from vrelab.record import Record

__all__ = ["CsdAccumulator", "MeasuredCsd", "RecordingOptions", "band_csd", "measure_csd", "read_recording_profile"]

# Default block read from a record [samples]: memory is bounded by it and one Welch segment.
DEFAULT_BLOCK = 1 << 16
# Largest Welch segment [samples]: about 0.06 Hz at 4 kHz sampling, far finer than any breakpoint grid.
MAX_NPERSEG = 1 << 16


class CsdAccumulator:
    """The Welch cross-spectral matrix of three channels fed in blocks (memory: one segment).

    Segments of ``nperseg`` samples, Hann window, 50 % overlap, density scaling, each segment's
    mean removed, exactly as ``scipy.signal.csd`` on the whole record: the samples are buffered
    until whole segments are available, each run of whole segments goes through
    ``scipy.signal.csd`` and its mean is added with its segment count (the approach of
    :class:`vrelab.spectra.WelchAccumulator`, for three channels and their cross terms).
    ``csd[m, j, k]`` is ``E[A_j A_k*]``: its phase is positive when channel k lags channel j.

    Examples
    --------
    Blocks fed one at a time, then averaged over bands (:func:`band_csd`): unit white noise at
    4 kHz, its density times the 2 kHz band, 1 g²:

    >>> import numpy as np
    >>> from vrelab.triaxial.recording import CsdAccumulator, band_csd
    >>> acc = CsdAccumulator(4000.0, 1024)
    >>> rng = np.random.default_rng(0)
    >>> for _ in range(4):
    ...     acc.add(rng.normal(0.0, 1.0, (10000, 3)))
    >>> csd = band_csd(acc, (50.0, 1000.0))
    >>> print(f"{csd.csd[:, 0, 0].real.mean() * 2000:.2f} g² in 2 kHz")
    1.01 g² in 2 kHz
    """

    def __init__(self, fs_hz: float, nperseg: int) -> None:
        self.fs_hz = v.positive_scalar("fs_hz", fs_hz)
        self.nperseg = v.integer("nperseg", nperseg, 8)
        self.step = self.nperseg - self.nperseg // 2
        self._buf = np.zeros((0, 3))
        self._sum: NDArray[np.complex128] | None = None
        self.n_segments = 0
        self.n_samples = 0
        self.freq_hz = scipy.fft.rfftfreq(self.nperseg, 1.0 / self.fs_hz)

    def add(self, block: ArrayLike) -> None:
        """Add samples, shape (n, 3) (columns x, y, z) [g]."""
        x = np.asarray(block, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != 3:
            raise ValueError(f"a triaxial block is (n, 3) samples (x, y, z), got shape {x.shape}")
        if not np.isfinite(x).all():
            raise ValueError("a triaxial block holds a non-finite sample (NaN or inf)")
        self.n_samples += x.shape[0]
        run, n_seg, self._buf = whole_segments(self._buf, x, self.nperseg, self.step)
        if run is not None:
            cols = run.T
            # scipy's Pxy is conj(X)·Y; S_jk = E[A_j A_k*] is Pxy with x = channel k, y = channel j
            _, pxy = scipy.signal.csd(cols[None, :, :], cols[:, None, :], self.fs_hz, nperseg=self.nperseg,
                                      noverlap=self.nperseg - self.step)
            part = np.moveaxis(pxy, -1, 0) * n_seg
            self._sum = part if self._sum is None else self._sum + part
            self.n_segments += n_seg

    @property
    def csd(self) -> NDArray[np.complex128]:
        """Mean cross-periodogram [g²/Hz], shape (nbins, 3, 3)."""
        if self._sum is None:
            raise ValueError(f"record too short for a Welch cross-spectrum: {self.n_samples} samples < "
                             f"nperseg = {self.nperseg}")
        return np.asarray(self._sum / self.n_segments, dtype=np.complex128)

    def effective_segments(self) -> float:
        """Welch's equivalent number of independent segments (overlap discounted, module docstring)."""
        return _overlap_discount(self.n_segments, _overlap_correlations(self.nperseg, self.step))


def _window(nperseg: int) -> NDArray[np.float64]:
    return np.asarray(scipy.signal.get_window("hann", nperseg), dtype=np.float64)


def _overlap_correlations(nperseg: int, step: int) -> NDArray[np.float64]:
    """c(j)² of Welch (1967): the squared overlap correlation of segments j steps apart."""
    w = _window(nperseg)
    e = float(np.dot(w, w))
    out = []
    j = 1
    while j * step < nperseg:
        s = j * step
        out.append((float(np.dot(w[:-s], w[s:])) / e) ** 2)
        j += 1
    return np.asarray(out)


def _overlap_discount(k: int, c2: NDArray[np.float64]) -> float:
    """K/(1 + 2·Σ_j (1 - j/K)·c(j)²): the equivalent number of independent averages of K
    correlated ones with squared correlation c(j)² at lag j."""
    if k <= 0:
        return 0.0
    lags = np.arange(1, min(c2.size, k - 1) + 1)
    return k / (1.0 + 2.0 * float(np.sum((1.0 - lags / k) * c2[: lags.size])))


def _bin_correlations(nperseg: int) -> NDArray[np.float64]:
    """ρ(d): the squared correlation of two periodogram bins d apart (white Gaussian noise)."""
    w2 = _window(nperseg) ** 2
    spec = np.fft.fft(w2)
    rho = np.abs(spec[1:8]) ** 2 / float(np.sum(w2)) ** 2
    return np.asarray(rho, dtype=np.float64)


@dataclass(frozen=True, eq=False)
class MeasuredCsd:
    """A cross-spectral matrix measured from three channels, on log-spaced bands.

    ``freq_hz`` (n,) band centres; ``csd`` (n, 3, 3) the band-mean cross-spectral matrix
    [g²/Hz]; ``n_averages`` (n,) the equivalent independent averages ``n_d`` of each band
    (module docstring); ``band_edges_hz`` (n+1,). The PSDs, coherences and phases and their
    standard uncertainties are properties. ``profile`` is the :class:`TriaxialProfile` with
    these breakpoints.

    Examples
    --------
    What :func:`measure_csd` returns: a 3×3 matrix per band, and how many averages each has.

    >>> import numpy as np
    >>> from vrelab.triaxial.recording import measure_csd
    >>> x = np.random.default_rng(0).normal(0.0, 1.0, (40000, 3))
    >>> csd = measure_csd([x], 4000.0, (50.0, 1000.0))
    >>> csd.csd.shape[1:], len(csd.freq_hz) == csd.csd.shape[0], csd.fs_hz
    ((3, 3), True, 4000.0)
    """

    freq_hz: NDArray[np.float64]
    csd: NDArray[np.complex128]
    n_averages: NDArray[np.float64]
    band_edges_hz: NDArray[np.float64]
    fs_hz: float
    nperseg: int
    n_segments: int
    n_samples: int
    notes: tuple[str, ...] = field(default=())

    @property
    def psd(self) -> NDArray[np.float64]:
        """Per-axis PSD [g²/Hz], shape (n, 3)."""
        return np.asarray(np.diagonal(self.csd, axis1=1, axis2=2).real, dtype=np.float64)

    @property
    def u_psd(self) -> NDArray[np.float64]:
        return np.asarray(self.psd / np.sqrt(self.n_averages)[:, None], dtype=np.float64)

    @property
    def coherence(self) -> NDArray[np.float64]:
        """γ²_jk = |S_jk|²/(P_j P_k), shape (n, 3, 3) (0 where an axis has no power)."""
        p = self.psd
        den = p[:, :, None] * p[:, None, :]
        with np.errstate(invalid="ignore", divide="ignore"):
            g = np.where(den > 0, np.abs(self.csd) ** 2 / np.where(den > 0, den, 1.0), 0.0)
        return np.asarray(np.minimum(g, 1.0), dtype=np.float64)

    @property
    def u_coherence(self) -> NDArray[np.float64]:
        g2 = self.coherence
        nd = self.n_averages[:, None, None]
        spread = math.sqrt(2.0) * (1.0 - g2) * np.sqrt(g2) / np.sqrt(nd)
        bias = (1.0 - g2) ** 2 / nd
        return np.asarray(np.hypot(spread, bias), dtype=np.float64)

    @property
    def phase_deg(self) -> NDArray[np.float64]:
        """arg S_jk [deg]: positive when axis k lags axis j."""
        return np.asarray(np.degrees(np.angle(self.csd)), dtype=np.float64)

    @property
    def u_phase_deg(self) -> NDArray[np.float64]:
        """u(θ) [deg]; NaN where γ² < 1/n_d (the phase of noise is undefined)."""
        g2 = self.coherence
        nd = self.n_averages[:, None, None]
        with np.errstate(invalid="ignore", divide="ignore"):
            u = np.degrees(np.sqrt(1.0 - g2) / (np.sqrt(g2) * np.sqrt(2.0 * nd)))
        return np.asarray(np.where(g2 >= 1.0 / nd, u, np.nan), dtype=np.float64)

    @property
    def axis_mean_square_g2(self) -> NDArray[np.float64]:
        """∫P_j df over the bands [g²] (band mean × band width)."""
        return np.asarray(self.psd.T @ np.diff(self.band_edges_hz), dtype=np.float64)

    @property
    def profile(self) -> TriaxialProfile:
        """The measured CSD as a triaxial profile on the band centres (log-log PSDs, coherency
        linear in ln f between them)."""
        p = self.psd
        amp = np.sqrt(p)
        with np.errstate(invalid="ignore", divide="ignore"):
            den = amp[:, :, None] * amp[:, None, :]
            c = np.where(den > 0, self.csd / np.where(den > 0, den, 1.0), 0.0)
        c[:, [0, 1, 2], [0, 1, 2]] = 1.0
        c = np.asarray(0.5 * (c + np.conj(np.swapaxes(c, 1, 2))), dtype=np.complex128)
        return TriaxialProfile(self.freq_hz, p, c, name="measured", source="Welch CSD of a recording")

    def to_dict(self) -> dict[str, Any]:
        pairs = [(0, 1), (0, 2), (1, 2)]
        g2, ug, ph, uph = self.coherence, self.u_coherence, self.phase_deg, self.u_phase_deg

        def fin(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        ms = self.axis_mean_square_g2
        return {
            "freq_hz": self.freq_hz.tolist(),
            "band_edges_hz": self.band_edges_hz.tolist(),
            "n_averages": [float(x) for x in self.n_averages],
            "axis_rms_g": {a: math.sqrt(float(m)) for a, m in zip(AXES, ms)},
            "rms_g": math.sqrt(float(ms.sum())),
            "psd_g2_per_hz": {a: self.psd[:, j].tolist() for j, a in enumerate(AXES)},
            "u_psd_g2_per_hz": {a: self.u_psd[:, j].tolist() for j, a in enumerate(AXES)},
            "coherence": {AXES[j] + AXES[k]: g2[:, j, k].tolist() for j, k in pairs},
            "u_coherence": {AXES[j] + AXES[k]: ug[:, j, k].tolist() for j, k in pairs},
            "phase_deg": {AXES[j] + AXES[k]: ph[:, j, k].tolist() for j, k in pairs},
            "u_phase_deg": {AXES[j] + AXES[k]: [fin(x) for x in uph[:, j, k]] for j, k in pairs},
            "welch": {"fs_hz": self.fs_hz, "nperseg": self.nperseg, "window": "hann", "overlap": 0.5,
                      "n_segments": self.n_segments, "n_samples": self.n_samples},
            "notes": list(self.notes),
        }


def band_edges(band_hz: tuple[float, float], points_per_octave: float) -> NDArray[np.float64]:
    """Edges of equal log-width bands tiling ``band_hz``, about ``points_per_octave`` per octave."""
    lo, hi = float(band_hz[0]), float(band_hz[1])
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
        raise ValueError(f"band must satisfy 0 < F1 < F2 (Hz), got {band_hz!r}")
    ppo = v.positive_scalar("points_per_octave", points_per_octave)
    n = max(1, round(ppo * math.log2(hi / lo)))
    return np.asarray(lo * (hi / lo) ** (np.arange(n + 1) / n), dtype=np.float64)


def band_csd(acc: CsdAccumulator, band_hz: tuple[float, float], points_per_octave: float = 3.0) -> MeasuredCsd:
    """The accumulated cross-spectrum averaged over log-spaced bands (module docstring).

    Refuses a band with no Welch bin (the frequency resolution ``fs/nperseg`` is coarser than
    the band: a longer segment or fewer points per octave) and a band above Nyquist.

    Examples
    --------
    White noise of 1 g rms at 4 kHz has a one-sided density of 1/2000 g²/Hz on every axis:

    >>> import numpy as np
    >>> from vrelab.triaxial.recording import CsdAccumulator, band_csd
    >>> acc = CsdAccumulator(4000.0, 1024)
    >>> acc.add(np.random.default_rng(0).normal(0.0, 1.0, (40000, 3)))
    >>> csd = band_csd(acc, (50.0, 1000.0))
    >>> print(f"{csd.csd[:, 2, 2].real.mean() * 2000:.2f}")
    1.02
    """
    edges = band_edges(band_hz, points_per_octave)
    if edges[-1] > acc.fs_hz / 2:
        raise ValueError(f"band {edges[0]:g}-{edges[-1]:g} Hz reaches above Nyquist ({acc.fs_hz / 2:g} Hz)")
    s = acc.csd
    f = acc.freq_hz
    rho = _bin_correlations(acc.nperseg)
    k_eff = acc.effective_segments()
    centres, means, nd = [], [], []
    for i in range(edges.size - 1):
        last = i == edges.size - 2
        sel = (f >= edges[i]) & ((f <= edges[i + 1]) if last else (f < edges[i + 1]))
        m = int(sel.sum())
        if m == 0:
            raise ValueError(f"band {edges[i]:.4g}-{edges[i + 1]:.4g} Hz holds no Welch bin (resolution "
                             f"{acc.fs_hz / acc.nperseg:.4g} Hz): fewer points per octave or a longer segment")
        centres.append(math.sqrt(edges[i] * edges[i + 1]))
        means.append(s[sel].mean(axis=0))
        nd.append(k_eff * _overlap_discount(m, rho))
    return MeasuredCsd(np.asarray(centres), np.asarray(means), np.asarray(nd), edges, acc.fs_hz, acc.nperseg,
                       acc.n_segments, acc.n_samples)


def default_nperseg(fs_hz: float, band_hz: tuple[float, float], points_per_octave: float) -> int:
    """A power of 2 giving at least about 4 bins in the narrowest (lowest) band."""
    edges = band_edges(band_hz, points_per_octave)
    width = float(edges[1] - edges[0])
    n = 2 ** math.ceil(math.log2(4.0 * fs_hz / width))
    return int(min(max(n, 256), MAX_NPERSEG))


def measure_csd(
    blocks: Iterable[NDArray[np.float64]],
    fs_hz: float,
    band_hz: tuple[float, float],
    points_per_octave: float = 3.0,
    nperseg: int | None = None,
) -> MeasuredCsd:
    """The band-mean CSD of a triaxial signal given as (n, 3) blocks [g] (module docstring).

    Examples
    --------
    Three axes of seeded white noise sampled at 4 kHz, x and z the same signal (fully coherent),
    y independent: the measured coherence between x and z is 1, between x and y near 0.

    >>> import numpy as np
    >>> from vrelab.triaxial.recording import measure_csd
    >>> rng = np.random.default_rng(0)
    >>> a, b = rng.normal(0.0, 1.0, (2, 40000))
    >>> csd = measure_csd([np.column_stack([a, b, a])], 4000.0, (50.0, 1000.0))
    >>> s = csd.csd.mean(axis=0)
    >>> print(f"xz {abs(s[0, 2]) ** 2 / (s[0, 0] * s[2, 2]).real:.3f}, xy {abs(s[0, 1]) ** 2 / (s[0, 0] * s[1, 1]).real:.3f}")
    xz 1.000, xy 0.000
    """
    fs = v.positive_scalar("fs_hz", fs_hz)
    n = default_nperseg(fs, band_hz, points_per_octave) if nperseg is None else int(nperseg)
    acc = CsdAccumulator(fs, n)
    for b in blocks:
        acc.add(b)
    return band_csd(acc, band_hz, points_per_octave)


def record_blocks(record: Record, channels: Sequence[str], start: int = 0, stop: int | None = None,
                  block: int = DEFAULT_BLOCK) -> Iterable[NDArray[np.float64]]:
    """(n, 3) blocks of three channels of a :class:`vrelab.record.Record` (x, y, z order)."""
    for b in record.blocks(block, list(channels), start, stop):
        yield np.column_stack([b[c] for c in channels])


class RecordingOptions(TypedDict, total=False):
    """The keywords of :func:`read_recording_profile` after ``fs_hz`` (its docstring).

    Examples
    --------
    >>> from vrelab.triaxial.recording import RecordingOptions
    >>> sorted(RecordingOptions.__annotations__)
    ['nperseg', 'scale', 'start_s', 'stop_s']
    """

    scale: Scale | float | None | Mapping[str, Scale | float | None]
    nperseg: int | None
    start_s: float
    stop_s: float | None


def read_recording_profile(
    path: str | Path,
    channels: Sequence[str] | Mapping[str, str],
    band_hz: tuple[float, float],
    points_per_octave: float = 3.0,
    fs_hz: float | None = None,
    *legacy: object,
    **options: Unpack[RecordingOptions],
) -> MeasuredCsd:
    """The CSD of a triaxial reference recorded in a lab file of any format vrelab reads.

    ``channels`` names the file's x, y, z channels (a sequence in that order, or a mapping
    "x"/"y"/"z" -> channel; an axis left out is refused: a triaxial recording has three);
    ``scale`` is :func:`vrelab.analysis.readers.open_record`'s ``dut_scale`` (one for all, or
    per axis); ``start_s``/``stop_s`` the stretch to use. ``.profile`` of the result is the
    measured :class:`TriaxialProfile`. ``scale``, ``nperseg``, ``start_s`` and ``stop_s`` are
    keywords (:class:`RecordingOptions`); given by position, as before, they still work for one
    release with a ``DeprecationWarning``.

    Examples
    --------
    The triaxial vibration of a recording: three channels of seeded white noise (x and z the same
    signal, y still) at 4 kHz in a CSV file; the x-z coherence is 1:

    >>> import numpy as np
    >>> from vrelab.triaxial.recording import read_recording_profile
    >>> a = np.random.default_rng(0).normal(0.0, 1.0, 8000)
    >>> np.savetxt("tri.csv", np.column_stack([a, 0.0 * a, a]), delimiter=",", header="x,y,z", comments="")
    >>> csd = read_recording_profile("tri.csv", ["x", "y", "z"], (50.0, 1000.0), fs_hz=4000.0)
    >>> s = csd.csd.mean(axis=0)
    >>> print(f"{abs(s[0, 2]) ** 2 / (s[0, 0] * s[2, 2]).real:.3f}")
    1.000
    """
    from vrelab.analysis.readers import open_record

    o = cast(RecordingOptions, _keywords.merged("read_recording_profile", list(RecordingOptions.__annotations__),
                                                legacy, options))
    start_s, stop_s = o.get("start_s", 0.0), o.get("stop_s")

    if isinstance(channels, Mapping):
        names = dict(channels)
    else:
        names = dict(zip(AXES, channels)) if len(channels) == 3 else {}
    if sorted(names) != list(AXES):
        raise ValueError(f"a triaxial recording needs three channels x, y, z, got {channels!r}")
    with open_record(path, names, None, fs_hz, o.get("scale")) as rec:
        fs = rec.fs_hz
        i0 = int(round(v.finite_scalar("start_s", start_s) * fs))
        i1 = None if stop_s is None else int(round(v.finite_scalar("stop_s", stop_s) * fs))
        if i0 < 0 or (i1 is not None and i1 <= i0):
            raise ValueError(f"stretch {start_s!r}-{stop_s!r} s: give 0 <= start < stop")
        keys = [f"dut:{a}" for a in AXES]
        return measure_csd(record_blocks(rec, keys, i0, i1), fs, band_hz, points_per_octave, o.get("nperseg"))
