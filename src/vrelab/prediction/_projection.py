"""The sensed vibration of a triaxial one: its spectral integrals by adaptive quadrature and its single-axis profile (physics §1.6)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Callable, Sequence

import numpy as np
from numpy.typing import NDArray
from scipy import integrate

from vrelab.profiles import RandomProfile
from vrelab.sensor.meanshift import Response
from vrelab.triaxial.profile import TriaxialProfile

if TYPE_CHECKING:
    from vrelab.sensor import Sensor


_EXACT_REL = 1e-12
# Otherwise tabulated with this step in ln f (at least _MIN_PER_SEGMENT points a segment), at
# most _MAX_POINTS points.
_DENSE_STEP = 2e-3
_MIN_PER_SEGMENT = 8
_MAX_POINTS = 40000

def resonances(responses: Sequence[Response]) -> list[tuple[float, float]]:
    """(fn, Q) of each resonance among the responses (a stage's bound ``response`` method)."""
    out = []
    for r in responses:
        st = getattr(r, "__self__", r)
        fn, q = getattr(st, "fn_hz", None), getattr(st, "q", None)
        if fn and q:
            out.append((float(fn), float(q)))
    return out


def _cuts(lo: float, hi: float, corners: Sequence[float], responses: Sequence[Response]) -> list[float]:
    peaks = [fn for fn, _ in resonances(responses)]
    return sorted({lo, hi, *(c for c in [*corners, *peaks] if lo < c < hi)})


def csd_integral(profile: TriaxialProfile, responses: Sequence[Response]) -> tuple[NDArray[np.float64],
                                                                                    NDArray[np.float64]]:
    """(Re ∫S df, Re ∫S·|H|² df) [g²], 3×3, with ``H`` the responses in series.

    Adaptive quadrature (``scipy.integrate.quad_vec``) in ln f, split at the breakpoints and the
    resonances, to 1e-11 relative: the integrand (power laws times coherencies linear in ln f
    times |H|²) has no closed form in general.
    """
    def integrand(t: float) -> NDArray[np.float64]:
        f = np.array([math.exp(t)])
        s = profile.csd(f)[0].real * f[0]
        h2 = 1.0
        for r in responses:
            h2 *= float(abs(np.asarray(r(f))[0])) ** 2
        return np.stack([s, s * h2])

    cuts = _cuts(*profile.band, profile.freq_hz.tolist(), responses)
    total = np.zeros((2, 3, 3))
    for a, b in zip(cuts[:-1], cuts[1:]):
        val, _ = integrate.quad_vec(integrand, math.log(a), math.log(b), epsabs=0.0, epsrel=1e-11, limit=400)
        total += val
    return total[0], total[1]


def _scalar_integral(psd: Callable[[NDArray[np.float64]], NDArray[np.float64]], band: tuple[float, float],
                     corners: Sequence[float], responses: Sequence[Response]) -> float:
    """∫ psd(f)·|H(f)|² df over ``band``, adaptive quadrature in ln f (see :func:`csd_integral`)."""
    def integrand(t: float) -> float:
        f = np.array([math.exp(t)])
        h2 = 1.0
        for r in responses:
            h2 *= float(abs(np.asarray(r(f))[0])) ** 2
        return float(psd(f)[0]) * float(f[0]) * h2

    total = 0.0
    for a, b in zip(*(lambda c: (c[:-1], c[1:]))(_cuts(*band, corners, responses))):
        total += integrate.quad(integrand, math.log(a), math.log(b), epsabs=0.0, epsrel=1e-11, limit=400)[0]
    return total


def projected(profile: TriaxialProfile, w: NDArray[np.float64], sensor: Sensor,
               front: Sequence[Response]) -> tuple[RandomProfile | None, float, float]:
    """The sensed vibration ``w·a`` as a single-axis profile, its mean square per unit of the
    triaxial one's, and the relative error of the tabulation in what the sites see (0: exact)."""
    f = profile.freq_hz
    m_u = _scalar_integral(lambda x: profile.psd_along(w, x), profile.band, f.tolist(), [])
    if not m_u > 1e-15 * profile.mean_square_g2:
        return None, 0.0, 0.0
    ratio = m_u / profile.mean_square_g2
    pb = profile.psd_along(w, f)
    name = f"{profile.name or 'triaxial random'}, sensed along ({w[0]:.4g}, {w[1]:.4g}, {w[2]:.4g})"
    if (pb > 0).all():
        frac = np.linspace(0.0, 1.0, 9)[1:-1]
        lf = np.log(f)
        inner = np.exp((lf[:-1, None] + np.diff(lf)[:, None] * frac).ravel())
        exact = profile.psd_along(w, inner)
        interp = np.exp(np.interp(np.log(inner), lf, np.log(pb)))
        if np.all(np.abs(interp - exact) <= _EXACT_REL * exact):
            prof = RandomProfile(f, pb, name=name, source=profile.source)
            return prof, prof.mean_square_g2 / profile.mean_square_g2, 0.0
    lf = np.log(f)
    step = max(_DENSE_STEP, (lf[-1] - lf[0]) / _MAX_POINTS)
    grid = [np.linspace(a, b, max(_MIN_PER_SEGMENT, math.ceil((b - a) / step)) + 1)[:-1] for a, b in zip(lf[:-1], lf[1:])]
    fd = np.exp(np.concatenate([*grid, lf[-1:]]))
    fd[0], fd[-1] = f[0], f[-1]
    pd = profile.psd_along(w, fd)
    pd = np.maximum(pd, 1e-12 * pd.max())  # a log-log table cannot reach 0: the floor's error is measured below
    prof = RandomProfile(fd, pd, name=name, source=profile.source)
    from vrelab.models.dynamics import effective_rms

    err = 0.0
    for resp in ([], list(front), sensor.linear_responses("output")):
        if not resp and err:
            continue
        exact_ratio = _scalar_integral(lambda x: profile.psd_along(w, x), profile.band, f.tolist(), resp) / m_u
        tab = effective_rms((fd, pd), resp, *profile.band, points_hz=[fn for fn, _ in resonances(resp)]) ** 2
        tab /= prof.mean_square_g2
        err = max(err, abs(tab / exact_ratio - 1.0))
    return prof, ratio, err

