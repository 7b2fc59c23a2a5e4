"""Triaxial vibration: a 3×3 cross-spectral density matrix, or a sine along a direction (SPEC 1.6).

A triaxial random vibration is a one-sided cross-spectral density matrix ``S(f)`` [g²/Hz] over
the part's axes (x, y, z), held as what a test specification gives: each axis's PSD
``P_j(f)`` (breakpoints, log-log between them as for one axis, SPEC 3) and the complex
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
from typing import Any, Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vrelab.profiles import RandomProfile, segment_areas

__all__ = ["AXES", "TriaxialProfile", "TriaxialSine", "direction"]

AXES: tuple[str, str, str] = ("x", "y", "z")
# Coherency matrices are checked positive semi-definite to this (eigenvalues of a unit-diagonal
# matrix, so a relative tolerance).
_PSD_TOL = 1e-9


def direction(input_axis: str, toward_axis: str, angle_deg: float) -> NDArray[np.float64]:
    """The unit vector at ``angle_deg`` from ``input_axis`` toward ``toward_axis`` (in their plane).

    IEEE 1293's mount angle: the part's input axis i at angle φ to the vibration in the plane
    of i and p gives ``a_i = a cos φ, a_p = a sin φ`` (SPEC 1.6). ``direction("z", "x", 45)`` is
    ``(sin 45°, 0, cos 45°)``.
    """
    if input_axis not in AXES or toward_axis not in AXES:
        raise ValueError(f"axes must be x, y or z, got {input_axis!r} and {toward_axis!r}")
    if input_axis == toward_axis:
        raise ValueError(f"a mount plane needs two different axes, got {input_axis!r} twice")
    phi = float(angle_deg)
    if not math.isfinite(phi):
        raise ValueError(f"mount angle must be a finite number of degrees, got {angle_deg!r}")
    d = np.zeros(3)
    rad = math.radians(phi)
    d[AXES.index(input_axis)] = math.cos(rad)
    d[AXES.index(toward_axis)] = math.sin(rad)
    d[np.abs(d) < 1e-15] = 0.0  # cos 90° is 6e-17, not 0: no spurious vibration on a still axis
    return d


def _unit(vector: ArrayLike, what: str = "direction") -> NDArray[np.float64]:
    d = np.asarray(vector, dtype=np.float64).ravel()
    if d.size != 3 or not np.isfinite(d).all():
        raise ValueError(f"{what} must be three finite numbers (x, y, z), got {vector!r}")
    n = float(np.linalg.norm(d))
    if n == 0:
        raise ValueError(f"{what} must not be the zero vector")
    return d / n


@dataclass(frozen=True, eq=False)
class TriaxialProfile:
    """Random vibration along x, y, z as a 3×3 cross-spectral density matrix (SPEC 1.6).

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
        d = _unit(vector)
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
        coherence: Mapping[tuple[str, str], tuple[float, float]] | None = None,
        name: str | None = None,
    ) -> TriaxialProfile:
        """Per-axis profiles on one set of breakpoints, with a coherence and phase per pair.

        ``axes`` maps "x", "y", "z" to a profile (a missing axis is still); all given profiles
        share their breakpoint frequencies. ``coherence[(j, k)] = (γ², phase_deg)``, the same
        at every frequency; pairs not given are incoherent.
        """
        if not axes or set(axes) - set(AXES):
            raise ValueError(f"axes must map some of x, y, z to profiles, got {sorted(axes)!r}")
        freqs = [pr.freq_hz for pr in axes.values()]
        if any(fr.shape != freqs[0].shape or not np.array_equal(fr, freqs[0]) for fr in freqs):
            raise ValueError("the axes' profiles must share their breakpoint frequencies")
        f = freqs[0]
        p = np.zeros((f.size, 3))
        for a, pr in axes.items():
            p[:, AXES.index(a)] = pr.psd_g2_per_hz
        c = np.eye(3, dtype=np.complex128)
        for (j, k), (gamma2, phase_deg) in (coherence or {}).items():
            if j not in AXES or k not in AXES or j == k:
                raise ValueError(f"a coherence pair must be two different axes of x, y, z, got ({j!r}, {k!r})")
            if not 0 <= float(gamma2) <= 1:
                raise ValueError(f"coherence between {j} and {k} must be within 0..1, got {gamma2!r}")
            v = math.sqrt(float(gamma2)) * np.exp(1j * math.radians(float(phase_deg)))
            c[AXES.index(j), AXES.index(k)] = v
            c[AXES.index(k), AXES.index(j)] = np.conj(v)
        return cls(f, p, np.broadcast_to(c, (f.size, 3, 3)), name=name)

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

    def describe(self) -> str:
        rms = np.sqrt(self.axis_mean_square_g2)
        return (f"{self.name or 'triaxial random'}: {self.grms:.3g} g rms total "
                f"(x {rms[0]:.3g}, y {rms[1]:.3g}, z {rms[2]:.3g}), {self.band[0]:g}-{self.band[1]:g} Hz")

    def to_dict(self) -> dict[str, Any]:
        return {"kind": "triaxial-random", "name": self.name, "grms": self.grms,
                "axis_grms": [float(x) for x in np.sqrt(self.axis_mean_square_g2)],
                "freq_hz": self.freq_hz.tolist(), "axis_psd_g2_per_hz": self.axis_psd_g2_per_hz.tolist(),
                "coherence": [[[float(abs(v) ** 2) for v in row] for row in m] for m in self.coherency],
                "phase_deg": [[[float(np.degrees(np.angle(v))) for v in row] for row in m] for m in self.coherency]}

    def __repr__(self) -> str:
        return f"TriaxialProfile({self.describe()!r})"


@dataclass(frozen=True)
class TriaxialSine:
    """A sine along a direction: ``a(t) = d · √2·rms·sin(2πft)`` (SPEC 1.6).

    ``direction`` is normalised; ``rms_g`` is the rms along it (the total rms).
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
        object.__setattr__(self, "direction", tuple(float(x) for x in _unit(self.direction)))

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


