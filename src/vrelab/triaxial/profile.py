"""Triaxial vibration: a 3×3 cross-spectral density matrix, or a sine along a direction (physics §1.6).

A triaxial random vibration is a one-sided cross-spectral density matrix ``S(f)`` [g²/Hz] over
the part's axes (x, y, z), held as what a test specification gives: each axis's PSD
``P_j(f)`` (breakpoints, log-log between them as for one axis, physics §3) and the complex
coherency ``C_jk(f) = S_jk / sqrt(P_j P_k)`` between axes (``|C_jk|²`` the coherence,
``arg C_jk`` the phase of k behind j... as ``S_jk = E[A_j A_k*]``), linear in ln f between
breakpoints. So ``S_jk(f) = sqrt(P_j(f) P_k(f)) · C_jk(f)``. Linear interpolation keeps a
coherency matrix that is positive semi-definite at every breakpoint positive semi-definite
between them (a convex combination), so ``S(f)`` is a valid cross-spectral matrix at every f.

The level of a triaxial vibration is its total rms, ``sqrt(trace ∫S df)`` (the rms of the
acceleration vector's magnitude): for a vibration along one direction it is the rms along it,
as for one axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping, SupportsFloat

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vrelab import _validate as V
from vrelab.profiles import RandomProfile, segment_areas

__all__ = ["AXES", "PairCoherence", "TriaxialProfile", "TriaxialSine", "direction"]

AXES: tuple[str, str, str] = ("x", "y", "z")
# Coherency matrices are checked positive semi-definite to this (eigenvalues of a unit-diagonal
# matrix, so a relative tolerance).
_PSD_TOL = 1e-9


def direction(input_axis: str, toward_axis: str, angle_deg: float) -> NDArray[np.float64]:
    """The unit vector at ``angle_deg`` from ``input_axis`` toward ``toward_axis`` (in their plane).

    IEEE 1293's mount angle: the part's input axis i at angle φ to the vibration in the plane
    of i and p gives ``a_i = a cos φ, a_p = a sin φ`` (physics §1.6). ``direction("z", "x", 45)`` is
    ``(sin 45°, 0, cos 45°)``.

    Examples
    --------
    45° from the input axis z toward x:

    >>> from vrelab.triaxial.profile import direction
    >>> print(direction("z", "x", 45.0).round(4))
    [0.7071 0.     0.7071]
    """
    if input_axis not in AXES or toward_axis not in AXES:
        raise ValueError(f"axes must be x, y or z, got {input_axis!r} and {toward_axis!r}")
    if input_axis == toward_axis:
        raise ValueError(f"a mount plane needs two different axes, got {input_axis!r} twice")
    phi = V.mount_angle("mount angle", angle_deg)
    d = np.zeros(3)
    rad = math.radians(phi)
    d[AXES.index(input_axis)] = math.cos(rad)
    d[AXES.index(toward_axis)] = math.sin(rad)
    d[np.abs(d) < 1e-15] = 0.0  # cos 90° is 6e-17, not 0: no spurious vibration on a still axis
    return d


def unit_vector(vector: ArrayLike, what: str = "direction") -> NDArray[np.float64]:
    d = np.asarray(vector, dtype=np.float64).ravel()
    if d.size != 3 or not np.isfinite(d).all():
        raise ValueError(f"{what} must be three finite numbers (x, y, z), got {vector!r}")
    n = float(np.linalg.norm(d))
    if n == 0:
        raise ValueError(f"{what} must not be the zero vector")
    return d / n


@dataclass(frozen=True, eq=False)
class PairCoherence:
    """The coherence ``γ²`` and phase between two axes, constant or a table over frequency.

    ``freq_hz`` None: one value at every frequency. Else breakpoints [Hz] (at least 2, strictly
    increasing) with ``coherence`` (0..1) and ``phase_deg`` at each, linear in ln f between them.
    The phase is the one of ``S_jk = E[A_j A_k*]``: positive when axis k lags axis j.

    Examples
    --------
    Half coherent (γ² = 0.5) at every frequency, axis k lagging by 90°:

    >>> from vrelab.triaxial.profile import PairCoherence
    >>> pair = PairCoherence(0.5, 90.0)
    >>> print(pair.coherence, pair.phase_deg, pair.freq_hz)
    [0.5] [90.] None
    """

    coherence: NDArray[np.float64]
    phase_deg: NDArray[np.float64]
    freq_hz: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        g = np.array(self.coherence, dtype=np.float64, copy=True).ravel()
        ph = np.array(self.phase_deg, dtype=np.float64, copy=True).ravel()
        if self.freq_hz is None:
            if g.size != 1 or ph.size != 1:
                raise ValueError("a constant coherence is one coherence and one phase")
        else:
            f = np.array(self.freq_hz, dtype=np.float64, copy=True).ravel()
            if f.size < 2 or g.size != f.size or ph.size != f.size:
                raise ValueError(f"a coherence table needs >= 2 breakpoints with a coherence and a phase at each, "
                                 f"got {f.size} frequencies, {g.size} coherences, {ph.size} phases")
            if not np.isfinite(f).all():
                raise ValueError("a coherence table's frequencies must be finite (got NaN or inf)")
            if f[0] <= 0 or (np.diff(f) <= 0).any():
                raise ValueError("non-monotonic coherence table: its frequencies must be positive and strictly increasing")
            f.setflags(write=False)
            object.__setattr__(self, "freq_hz", f)
        if not (np.isfinite(g).all() and np.isfinite(ph).all()):
            raise ValueError("a coherence and its phase must be finite numbers (got NaN or inf)")
        if ((g < 0) | (g > 1)).any():
            bad = float(g[(g < 0) | (g > 1)][0])
            raise ValueError(f"coherence must be within 0..1, got {bad:g}")
        for a in (g, ph):
            a.setflags(write=False)
        object.__setattr__(self, "coherence", g)
        object.__setattr__(self, "phase_deg", ph)

    @classmethod
    def constant(cls, coherence: float, phase_deg: float = 0.0) -> PairCoherence:
        return cls(np.array([coherence], dtype=np.float64), np.array([phase_deg], dtype=np.float64))

    def coherency(self, f_hz: ArrayLike) -> NDArray[np.complex128]:
        """``sqrt(γ²)·exp(i·phase)`` at ``f_hz`` (γ² and phase linear in ln f; held at the ends)."""
        f = np.atleast_1d(np.asarray(f_hz, dtype=np.float64))
        if self.freq_hz is None:
            g = np.full(f.size, self.coherence[0])
            ph = np.full(f.size, self.phase_deg[0])
        else:
            lf, lb = np.log(f), np.log(self.freq_hz)
            g = np.interp(lf, lb, self.coherence)
            ph = np.interp(lf, lb, self.phase_deg)
        return np.asarray(np.sqrt(g) * np.exp(1j * np.radians(ph)), dtype=np.complex128)


@dataclass(frozen=True, eq=False)
class TriaxialProfile:
    """Random vibration along x, y, z as a 3×3 cross-spectral density matrix (physics §1.6).

    Parameters
    ----------
    freq_hz : array_like, shape (n,)
        Breakpoints [Hz], at least 2, strictly increasing; the band of every moving axis.
    axis_psd_g2_per_hz : array_like, shape (n, 3)
        Each axis's PSD at the breakpoints [g²/Hz]: positive on a moving axis, 0 at every
        breakpoint on a still one.
    coherency : array_like, shape (n, 3, 3), complex
        ``C_jk = S_jk / sqrt(P_j P_k)``: Hermitian, unit diagonal, positive semi-definite.
    name, source : str, optional

    Examples
    --------
    The flat 50-2000 Hz profile along a direction at 45° in the x-z plane (one rank: every pair of
    axes fully coherent):

    >>> import vrelab
    >>> tri = vrelab.TriaxialProfile.along(vrelab.parse_profile("flat:50-2000").scaled_to(1.0), (1, 0, 1))
    >>> print(f"{tri.grms:.3f} g rms", [f"{g:.3f}" for g in tri.axis_mean_square_g2 ** 0.5])
    1.000 g rms ['0.707', '0.000', '0.707']
    """

    freq_hz: NDArray[np.float64]
    axis_psd_g2_per_hz: NDArray[np.float64]
    coherency: NDArray[np.complex128]
    name: str | None = None
    source: str | None = None

    def __post_init__(self) -> None:
        f = np.array(self.freq_hz, dtype=np.float64, copy=True).ravel()
        p = np.array(self.axis_psd_g2_per_hz, dtype=np.float64, copy=True)
        c = np.array(self.coherency, dtype=np.complex128, copy=True)
        if f.size < 2 or p.shape != (f.size, 3) or c.shape != (f.size, 3, 3):
            raise ValueError(f"a triaxial profile needs n >= 2 breakpoints, an (n, 3) PSD and an (n, 3, 3) "
                             f"coherency; got {f.shape}, {p.shape}, {c.shape}")
        if not (np.isfinite(f).all() and np.isfinite(p).all() and np.isfinite(c).all()):
            raise ValueError("a triaxial profile's frequencies, PSDs and coherencies must be finite")
        if f[0] <= 0 or (np.diff(f) <= 0).any():
            raise ValueError("non-monotonic profile: freq_hz must be positive and strictly increasing")
        still = (p == 0).all(axis=0)
        if (p < 0).any() or ((p <= 0) & ~still).any():
            raise ValueError("each axis's PSD must be > 0 at every breakpoint, or 0 at all of them (a still axis)")
        if not np.allclose(c, np.conj(np.swapaxes(c, 1, 2)), atol=1e-12, rtol=0):
            raise ValueError("the coherency matrix must be Hermitian (C_kj = conj(C_jk))")
        if not np.allclose(np.diagonal(c, axis1=1, axis2=2), 1.0, atol=1e-12, rtol=0):
            raise ValueError("the coherency matrix must have a unit diagonal (each axis fully coherent with itself)")
        low = np.linalg.eigvalsh(c).min(axis=1)
        if (low < -_PSD_TOL).any():
            i = int(np.argmax(low < -_PSD_TOL))
            raise ValueError(f"at {f[i]:g} Hz the coherences and phases between x, y and z are inconsistent: "
                             "no vibration has that cross-spectral matrix (it is not positive semi-definite)")
        for a in (f, p, c):
            a.setflags(write=False)
        object.__setattr__(self, "freq_hz", f)
        object.__setattr__(self, "axis_psd_g2_per_hz", p)
        object.__setattr__(self, "coherency", c)

    # --- constructors -------------------------------------------------------------------------

    @classmethod
    def along(cls, profile: RandomProfile, vector: ArrayLike, name: str | None = None) -> TriaxialProfile:
        """A single-axis profile applied along a direction (rank one: the axes fully coherent).

        ``a(t) = d · x(t)`` with ``d`` the unit vector of ``vector``: ``S(f) = d dᵀ P(f)``; the
        total rms is the profile's.
        """
        d = unit_vector(vector)
        n = profile.freq_hz.size
        p = np.outer(profile.psd_g2_per_hz, d * d)
        s = np.where(d == 0, 1.0, np.sign(d))
        c = np.broadcast_to(np.outer(s, s).astype(np.complex128), (n, 3, 3))
        label = name or f"{profile.name or profile.describe_shape()} along ({d[0]:.4g}, {d[1]:.4g}, {d[2]:.4g})"
        return cls(profile.freq_hz, p, c, name=label, source=profile.source)

    @classmethod
    def from_axes(
        cls,
        axes: Mapping[str, RandomProfile],
        coherence: Mapping[tuple[str, str], tuple[float, float] | PairCoherence] | None = None,
        name: str | None = None,
        source: str | None = None,
    ) -> TriaxialProfile:
        """Per-axis profiles with a coherence and phase per pair, on the union of their breakpoints.

        ``axes`` maps "x", "y", "z" to a profile (a missing axis is still). Axes whose breakpoints
        differ are each evaluated, log-log, on the union of all breakpoints: exact, as every
        segment is a power law and a point added inside it lies on it. Every moving axis must
        span the same band: an axis narrower than another would be 0 where the other moves, which
        a log-log breakpoint table cannot hold, and is refused.

        ``coherence[(j, k)]`` is ``(γ², phase_deg)``, the same at every frequency, or a
        :class:`PairCoherence` table (γ² and phase linear in ln f between its breakpoints, which
        join the union; it must span the band); pairs not given are incoherent. The profile then
        holds the complex coherency at every breakpoint of the union and interpolates it linearly
        in ln f (the class Notes): at the breakpoints it is the table's γ² and phase exactly.
        """
        if not axes or set(axes) - set(AXES):
            raise ValueError(f"axes must map some of x, y, z to profiles, got {sorted(axes)!r}")
        bands = {a: pr.band for a, pr in axes.items()}
        lo = max(b[0] for b in bands.values())
        hi = min(b[1] for b in bands.values())
        for a, (a_lo, a_hi) in sorted(bands.items()):
            if a_lo < lo or a_hi > hi:
                narrow = min(bands, key=lambda k: bands[k][1] - bands[k][0])
                raise ValueError(
                    f"axis {narrow} spans {bands[narrow][0]:g}-{bands[narrow][1]:g} Hz but axis {a} spans "
                    f"{a_lo:g}-{a_hi:g} Hz: every moving axis must span the same band (a log-log breakpoint "
                    "table cannot fall to 0 inside the band)")
        pairs = dict(coherence or {})
        grids = [pr.freq_hz for pr in axes.values()]
        tables: dict[tuple[int, int], PairCoherence] = {}
        for (j, k), value in pairs.items():
            if j not in AXES or k not in AXES or j == k:
                raise ValueError(f"a coherence pair must be two different axes of x, y, z, got ({j!r}, {k!r})")
            if j not in axes or k not in axes:
                still = j if j not in axes else k
                raise ValueError(f"coherence between {j} and {k} given, but axis {still} is still (no PSD)")
            table = value if isinstance(value, PairCoherence) else PairCoherence.constant(*value)
            jj, kk = AXES.index(j), AXES.index(k)
            if (jj, kk) in tables or (kk, jj) in tables:
                raise ValueError(f"coherence between {j} and {k} given twice")
            if table.freq_hz is not None:
                if table.freq_hz[0] > lo * (1 + 1e-12) or table.freq_hz[-1] < hi * (1 - 1e-12):
                    raise ValueError(
                        f"the coherence table of {j}{k} spans {table.freq_hz[0]:g}-{table.freq_hz[-1]:g} Hz, "
                        f"not the whole band {lo:g}-{hi:g} Hz")
                inside = table.freq_hz[(table.freq_hz > lo) & (table.freq_hz < hi)]
                grids.append(inside)
            tables[(jj, kk)] = table
        f = np.unique(np.concatenate(grids))
        f = f[(f >= lo) & (f <= hi)]
        p = np.zeros((f.size, 3))
        for a, pr in axes.items():
            p[:, AXES.index(a)] = np.asarray(pr.psd(f))
            own = np.isin(f, pr.freq_hz)  # the axis's own breakpoints keep their values bit for bit
            p[own, AXES.index(a)] = pr.psd_g2_per_hz[np.isin(pr.freq_hz, f[own])]
        c = np.zeros((f.size, 3, 3), dtype=np.complex128)
        c[:, [0, 1, 2], [0, 1, 2]] = 1.0
        for (jj, kk), table in tables.items():
            v = table.coherency(f)
            c[:, jj, kk] = v
            c[:, kk, jj] = np.conj(v)
        return cls(f, p, c, name=name, source=source)

    # --- what it is ---------------------------------------------------------------------------

    @property
    def band(self) -> tuple[float, float]:
        return float(self.freq_hz[0]), float(self.freq_hz[-1])

    @property
    def still(self) -> NDArray[np.bool_]:
        """Which axes do not move."""
        return np.asarray((self.axis_psd_g2_per_hz == 0).all(axis=0))

    @property
    def axis_mean_square_g2(self) -> NDArray[np.float64]:
        """∫P_j df per axis [g²] (exact on the log-log segments)."""
        out = np.zeros(3)
        for j in range(3):
            if not self.still[j]:
                out[j] = float(segment_areas(self.freq_hz, self.axis_psd_g2_per_hz[:, j]).sum())
        return out

    @property
    def mean_square_g2(self) -> float:
        """trace ∫S df [g²]."""
        return float(self.axis_mean_square_g2.sum())

    @property
    def grms(self) -> float:
        """The level: the total rms [g], sqrt(trace ∫S df)."""
        return math.sqrt(self.mean_square_g2)

    def scaled_to(self, grms: float) -> TriaxialProfile:
        """The same shape, coherences and phases at total rms ``grms`` [g]."""
        g = float(grms)
        if not math.isfinite(g) or g <= 0:
            raise ValueError(f"a level must be a finite number > 0 g rms, got {grms!r}")
        k = (g / self.grms) ** 2
        return TriaxialProfile(self.freq_hz, self.axis_psd_g2_per_hz * k, self.coherency, self.name, self.source)

    def axis_psd(self, f_hz: ArrayLike) -> NDArray[np.float64]:
        """P_j(f) [g²/Hz], shape (m, 3); 0 outside the band and on a still axis."""
        f = np.atleast_1d(np.asarray(f_hz, dtype=np.float64))
        out = np.zeros((f.size, 3))
        inside = (f >= self.freq_hz[0]) & (f <= self.freq_hz[-1])
        lf = np.log(f[inside])
        for j in range(3):
            if not self.still[j]:
                out[inside, j] = np.exp(np.interp(lf, np.log(self.freq_hz), np.log(self.axis_psd_g2_per_hz[:, j])))
        return out

    def csd(self, f_hz: ArrayLike) -> NDArray[np.complex128]:
        """S(f) [g²/Hz], shape (m, 3, 3): ``S_jk = sqrt(P_j P_k) C_jk``, 0 outside the band."""
        f = np.atleast_1d(np.asarray(f_hz, dtype=np.float64))
        lf = np.log(np.clip(f, self.freq_hz[0], self.freq_hz[-1]))
        lb = np.log(self.freq_hz)
        c = np.empty((f.size, 3, 3), dtype=np.complex128)
        for j in range(3):
            for k in range(3):
                c[:, j, k] = (np.interp(lf, lb, self.coherency[:, j, k].real)
                              + 1j * np.interp(lf, lb, self.coherency[:, j, k].imag))
        amp = np.sqrt(self.axis_psd(f))
        return np.asarray(amp[:, :, None] * amp[:, None, :] * c, dtype=np.complex128)

    def psd_along(self, vector: ArrayLike, f_hz: ArrayLike) -> NDArray[np.float64]:
        """The PSD [g²/Hz] of ``w·a`` for a real weight vector ``w`` (not normalised): ``wᵀ Re S(f) w``."""
        w = np.asarray(vector, dtype=np.float64).ravel()
        if w.size != 3 or not np.isfinite(w).all():
            raise ValueError(f"weights must be three finite numbers, got {vector!r}")
        return np.asarray(np.einsum("j,mjk,k->m", w, self.csd(f_hz).real, w), dtype=np.float64)

    def _defined(self, j: int, k: int) -> bool:
        """Whether the pair (j, k) has a coherence: a still axis has none (its entries in
        :attr:`coherency` only keep the matrix valid)."""
        return not (self.still[j] or self.still[k])

    def _coherence_text(self) -> str:
        pairs = []
        for j, k in ((0, 1), (0, 2), (1, 2)):
            if self._defined(j, k):
                g2 = np.abs(self.coherency[:, j, k]) ** 2
                lo, hi = float(g2.min()), float(g2.max())
                pairs.append(f"{AXES[j]}{AXES[k]} {lo:.3g}" + (f"-{hi:.3g}" if hi - lo > 1e-9 else ""))
        return f"; coherence {', '.join(pairs)}" if pairs else ""

    def describe(self) -> str:
        rms = np.sqrt(self.axis_mean_square_g2)
        return (f"{self.name or 'triaxial random'}: {self.grms:.3g} g rms total "
                f"(x {rms[0]:.3g}, y {rms[1]:.3g}, z {rms[2]:.3g}), {self.band[0]:g}-{self.band[1]:g} Hz"
                f"{self._coherence_text()}")

    def describe_shape(self) -> str:
        """The profile without its level (a run scales it to each level): each axis's share of
        the total rms, the band and the coherences."""
        frac = np.sqrt(self.axis_mean_square_g2 / self.mean_square_g2)
        return (f"{self.name or 'triaxial random'}: rms x {frac[0]:.3g}, y {frac[1]:.3g}, z {frac[2]:.3g} of the "
                f"total, {self.band[0]:g}-{self.band[1]:g} Hz{self._coherence_text()}")

    def to_dict(self) -> dict[str, Any]:
        """The profile as JSON: ``coherence`` (γ²) and ``phase_deg`` per breakpoint as 3×3
        matrices, null for a pair involving a still axis (it has no coherence)."""
        defined = [[self._defined(j, k) for k in range(3)] for j in range(3)]

        def pairs(value: Callable[[complex], SupportsFloat]) -> list[list[list[float | None]]]:
            return [[[float(value(m[j, k])) if defined[j][k] else None for k in range(3)] for j in range(3)]
                    for m in self.coherency]

        return {"kind": "triaxial-random", "name": self.name, "grms": self.grms,
                "axis_grms": [float(x) for x in np.sqrt(self.axis_mean_square_g2)],
                "freq_hz": self.freq_hz.tolist(), "axis_psd_g2_per_hz": self.axis_psd_g2_per_hz.tolist(),
                "coherence": pairs(lambda v: abs(v) ** 2), "phase_deg": pairs(lambda v: np.degrees(np.angle(v)))}

    def __repr__(self) -> str:
        return f"TriaxialProfile({self.describe()!r})"


@dataclass(frozen=True)
class TriaxialSine:
    """A sine along a direction: ``a(t) = d · √2·rms·sin(2πft)`` (physics §1.6).

    ``direction`` is normalised; ``rms_g`` is the rms along it (the total rms).

    Examples
    --------
    A 1 g rms sine at 100 Hz at 45° between x and z:

    >>> import vrelab
    >>> sine = vrelab.TriaxialSine(100.0, (1.0, 0.0, 1.0))
    >>> print(sine.freq_hz, [round(d, 4) for d in sine.direction])
    100.0 [0.7071, 0.0, 0.7071]
    """

    freq_hz: float
    direction: tuple[float, float, float]
    rms_g: float = 1.0

    def __post_init__(self) -> None:
        f = float(self.freq_hz)
        if not math.isfinite(f) or f <= 0:
            raise ValueError(f"sine frequency must be a finite number > 0 Hz, got {self.freq_hz!r}")
        r = float(self.rms_g)
        if not math.isfinite(r) or r < 0:
            raise ValueError(f"rms_g must be a finite number >= 0, got {self.rms_g!r}")
        object.__setattr__(self, "freq_hz", f)
        object.__setattr__(self, "rms_g", r)
        object.__setattr__(self, "direction", tuple(float(x) for x in unit_vector(self.direction)))

    @property
    def grms(self) -> float:
        return self.rms_g

    def scaled_to(self, grms: float) -> TriaxialSine:
        return TriaxialSine(self.freq_hz, self.direction, grms)

    def amplitudes_g(self) -> NDArray[np.float64]:
        """Peak amplitude along x, y, z [g]."""
        return np.asarray(self.direction) * self.rms_g * math.sqrt(2.0)

    def describe(self) -> str:
        d = self.direction
        return f"sine {self.freq_hz:g} Hz, {self.rms_g:.3g} g rms along ({d[0]:.4g}, {d[1]:.4g}, {d[2]:.4g})"

    def to_dict(self) -> dict[str, Any]:
        return {"kind": "triaxial-sine", "freq_hz": self.freq_hz, "rms_g": self.rms_g, "direction": list(self.direction)}


