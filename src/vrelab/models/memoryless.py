"""Exact mean of a polynomial followed by rails: the memoryless part of a sensor chain (physics §1.1-1.3).

A sensor's nonlinearity and its rails are memoryless maps: the output is
``clip(P(y) + offset, L, U)`` with ``P(y) = y + k2·y² + k3·y³ + k4·y⁴`` of the total input
``y = g0 + x`` (physics §1.2), when no filter sits between them. Its mean over the distribution of
``x`` is therefore one expectation, not a sum of a clipping share and a nonlinearity share:
the rails see the polynomial's output, whose mean and spread the nonlinearity has moved.

Closed form (no quadrature error): ``clip(P(y) + offset)`` is piecewise polynomial in ``y``
with kinks at the real roots of ``P(y) + offset = L`` and ``= U``. On each piece it is a
constant (a rail) or the polynomial, and the Gaussian expectation of a polynomial over an
interval is a sum of truncated normal moments
``M_n(α, β) = ∫_α^β z^n φ(z) dz``, ``M_n = (n-1)·M_{n-2} + α^{n-1}φ(α) - β^{n-1}φ(β)``
(Johnson, Kotz & Balakrishnan, *Continuous Univariate Distributions* vol. 1, 13.10). The
polynomial is expanded about the mean (Taylor coefficients), so the constant part cancels
before anything is added and a µg mean on a 1 g static level keeps its digits.

* sine ``x = A·cos θ``: the same pieces in θ (kinks at ``arccos((y_k - m)/A)``), each
  polynomial piece by Gauss-Legendre in θ (24 nodes: a polynomial of degree ≤ 4 in cos θ is
  entire, the rule's error is below 1e-15 relative on any piece of [0, π]);
* sine-on-random: given the tones' phases the motion is Gaussian with a moving mean; the
  Gaussian closed form is averaged over the phases (:mod:`vrelab.models.tones`).

This is python-control's describing-function idea (``control/descfcn.py``: closed form for
saturation, integration otherwise) taken at the zeroth harmonic, for the composite map.

:func:`linear_part` gives what a linear filter after the polynomial passes on: the best linear
gain ``Cov(P(y), x)/Var(x)`` (for Gaussian x, Stein's lemma: ``E[P'(y)]``; for a sine, the
describing function's fundamental) and the rms of the rest (the harmonics / higher Hermite
terms), which a clip after a filter sees as a non-Gaussian remainder.

:func:`map_vre` is the numerical fallback for any other memoryless map (Gauss-Hermite
quadrature, or equally spaced phases for a sine), with an estimate of its error.
"""

from __future__ import annotations

import functools
import math
from typing import Callable, Literal, Sequence, TypedDict, Unpack, cast, overload

import numpy as np
from numpy.polynomial import Polynomial
from numpy.typing import NDArray

from vrelab import _keywords, _validate
from vrelab.models.kinds import DEFAULT_CLIP_KIND, KINDS, Kind

Shape = Literal["gaussian", "sine"]

_GL_X, _GL_W = np.polynomial.legendre.leggauss(24)
# Gauss-Hermite (probabilists'): exact for polynomials of degree <= 2·24 - 1 = 47
_GH_X, _GH_W = np.polynomial.hermite_e.hermegauss(24)
_GH_W = _GH_W / _GH_W.sum()
_SQRT2PI = math.sqrt(2.0 * math.pi)


def polynomial(k2_per_g: float = 0.0, k3_per_g2: float = 0.0, k4_per_g3: float = 0.0,
               offset_g: float = 0.0) -> Polynomial:
    """``P(y) = offset + y + k2·y² + k3·y³ + k4·y⁴`` (physics §1.2, normalised to g)."""
    return Polynomial(_coefficients(k2_per_g, k3_per_g2, k4_per_g3, offset_g))


# The closed forms below run thousands of times in one identification (least squares over the
# parameters, each residual a prediction of every level): they hold P as a tuple of floats,
# lowest power first, and do numpy.polynomial's arithmetic on it in the same order (Horner's
# rule as polyval, derivatives as polyder, trailing zeros trimmed as trimseq, roots by polyroots),
# so the numbers are those of the Polynomial objects without building one per call.
Coefficients = tuple[float, ...]


def _coefficients(k2_per_g: float, k3_per_g2: float, k4_per_g3: float, offset_g: float) -> Coefficients:
    """:func:`polynomial`'s coefficients ``(offset, 1, k2, k3, k4)``."""
    return (float(offset_g), 1.0, float(k2_per_g), float(k3_per_g2), float(k4_per_g3))


@overload
def horner(c: Sequence[float], x: float) -> float: ...
@overload
def horner(c: Sequence[float], x: NDArray[np.float64]) -> NDArray[np.float64]: ...
def horner(c: Sequence[float], x: float | NDArray[np.float64]) -> float | NDArray[np.float64]:
    """``Σ c_n·x^n`` (``c`` lowest power first) at a float or elementwise on an array, as numpy's
    ``polyval`` computes it (the same operations in the same order, so the same bits) without its
    per-call overhead: the closed forms here and the Mills-ratio series of
    :mod:`vrelab.models.clipping` run it thousands of times in one fit."""
    v = c[-1] + x * 0
    for a in c[-2::-1]:
        v = a + v * x
    return v


def _trimmed(c: Coefficients) -> Coefficients:
    """Trailing zero coefficients dropped, one kept (numpy's ``trimseq``, which ``p - a`` applies)."""
    n = len(c)
    while n > 1 and c[n - 1] == 0:
        n -= 1
    return c[:n]


def _less(c: Coefficients, a: float) -> Coefficients:
    """``P - a``, trimmed as numpy's ``Polynomial.__sub__`` leaves it."""
    t = _trimmed(c)
    return _trimmed((t[0] - a, *t[1:]))


@functools.lru_cache(maxsize=64)
def _derivatives(c: Coefficients) -> tuple[Coefficients, ...]:
    """``P', P'', ...`` down to the constant, of ``P`` trimmed (numpy's ``polyder``: ``j·c_j``):
    those of ``P - a`` for every a. A pure function of the floats: cached, bounded."""
    out: list[Coefficients] = []
    d = _trimmed(c)
    while len(d) > 1:
        d = tuple(j * d[j] for j in range(1, len(d)))
        out.append(d)
    return tuple(out)


def _clipped(c: Coefficients, y: float, low: float, high: float) -> float:
    """``clip(P(y), low, high)``."""
    return min(max(float(horner(c, y)), low), high)


# physics §1.5: every VRE the tool states is the mean output with vibration less this reading.
REFERENCE = "vibration-off reading"


def vibration_off_reading(static_g: float, k2_per_g: float = 0.0, k3_per_g2: float = 0.0, k4_per_g3: float = 0.0,
                          offset_g: float = 0.0, rail_low_g: float = -math.inf,
                          rail_high_g: float = math.inf) -> float:
    r"""The reading with the same static field and no vibration: the VRE's reference point [g].

    .. math:: r_0 = \mathrm{clip}(P(g_0) + \mathrm{offset},\ L,\ U)

    physics §1.5: VRE is always ``E[output with vibration] - r0``, in every command (``model clip``,
    ``model poly``, ``predict``, the sweep). Where ``P(g0) + offset`` lies beyond a rail the
    reading is itself clipped (:func:`reference_note` says so); it is not μ = g0, which a
    mean shift (:func:`vrelab.models.clipping.censored_mean_shift`) is measured from.
    """
    g0 = _validate.finite_scalar("static_g", static_g)
    low, high = float(rail_low_g), float(rail_high_g)
    if not low < high:
        raise ValueError(f"rail_low_g must be < rail_high_g, got {rail_low_g!r}, {rail_high_g!r}")
    return _clipped(_coefficients(k2_per_g, k3_per_g2, k4_per_g3, offset_g), g0, low, high)


def reference_note(static_g: float, k2_per_g: float = 0.0, k3_per_g2: float = 0.0, k4_per_g3: float = 0.0,
                   offset_g: float = 0.0, rail_low_g: float = -math.inf,
                   rail_high_g: float = math.inf) -> str | None:
    """The note a result carries where the vibration-off reading is itself clipped (None otherwise)."""
    # Horner's rule on the coefficients, the operations numpy's Polynomial makes (its default
    # domain maps x to itself), so the same level without building one per prediction
    level = float(horner(_coefficients(k2_per_g, k3_per_g2, k4_per_g3, offset_g), float(static_g)))
    r0 = vibration_off_reading(static_g, k2_per_g, k3_per_g2, k4_per_g3, offset_g, rail_low_g, rail_high_g)
    if r0 == level:
        return None
    return (f"the vibration-off reading is itself clipped: the static level {level:g} g lies beyond the rail "
            f"at {r0:g} g, so the sensor reads {r0:g} g with no vibration and the VRE is referred to that")


@functools.lru_cache(maxsize=256)
def _pieces(c: Coefficients, low: float, high: float) -> tuple[tuple[float, float, str], ...]:
    """``clip(P(y), low, high)`` as pieces ``(a, b, what)`` covering the real line, ``what`` one of
    ``"low"``, ``"high"``, ``"poly"``. A pure function of the floats: cached, bounded (a fit
    asks for the same polynomial and rails at every level)."""
    kinks: set[float] = set()
    for rail in (low, high):
        if math.isfinite(rail):
            q = _less(c, rail)
            for r in np.polynomial.polynomial.polyroots(q) if len(q) > 1 else ():
                if abs(r.imag) <= 1e-12 * max(1.0, abs(r.real)):
                    kinks.add(float(r.real))
    edges = [-math.inf, *sorted(kinks), math.inf]
    out: list[tuple[float, float, str]] = []
    for a, b in zip(edges[:-1], edges[1:]):
        if math.isinf(a) and math.isinf(b):
            mid = 0.0
        elif math.isinf(a):
            mid = b - 1.0 - abs(b)
        elif math.isinf(b):
            mid = a + 1.0 + abs(a)
        else:
            mid = 0.5 * (a + b)
        v = float(horner(c, mid))
        what = "low" if v < low else "high" if v > high else "poly"
        if out and out[-1][2] == what:
            out[-1] = (out[-1][0], b, what)
        else:
            out.append((a, b, what))
    return tuple(out)


def _phi(z: NDArray[np.float64]) -> NDArray[np.float64]:
    with np.errstate(over="ignore", invalid="ignore"):
        return np.where(np.isfinite(z), np.exp(-0.5 * z * z) / _SQRT2PI, 0.0)


def _prob(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Φ(b) - Φ(a), from the tail nearer the interval (no 1 - 1 cancellation)."""
    from scipy import special  # here, not at the top: `vrelab model poly` needs no scipy (issue 29)

    upper = a > 0
    prob: NDArray[np.float64] = np.where(upper, special.ndtr(-a) - special.ndtr(-b), special.ndtr(b) - special.ndtr(a))
    return prob


def _truncated_moments(a: NDArray[np.float64], b: NDArray[np.float64], n_max: int) -> list[NDArray[np.float64]]:
    """``M_n = ∫_a^b z^n φ(z) dz`` for n = 0..n_max (a, b may be ±inf)."""
    pa, pb = _phi(a), _phi(b)
    m = [_prob(a, b), pa - pb]
    fa, fb = np.isfinite(a), np.isfinite(b)
    a0, b0 = np.where(fa, a, 0.0), np.where(fb, b, 0.0)
    with np.errstate(invalid="ignore"):
        for n in range(2, n_max + 1):
            # the edges' z^(n-1)·φ(z), 0 at an infinite edge
            m.append((n - 1) * m[n - 2] + np.where(fa, a0 ** (n - 1) * pa, 0.0) - np.where(fb, b0 ** (n - 1) * pb, 0.0))
    return m


def _gaussian(c: Coefficients, pieces: Sequence[tuple[float, float, str]], low: float, high: float,
              m: NDArray[np.float64], sigma: float, ref: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(E[clip(P(Y)) - ref; kept], P(kept)) for Y ~ N(m, σ²), elementwise in m; kept = the
    polynomial pieces (the rail pieces are in the first term, as the rail)."""
    # every piece at once, one row each (the same elementwise operations as piece by piece, a
    # few array calls instead of a few per piece), summed below in the pieces' order
    a = np.array([p[0] for p in pieces])[:, None]
    b = np.array([p[1] for p in pieces])[:, None]
    za, zb = (a - m) / sigma, (b - m) / sigma
    prob = _prob(za, zb)
    poly = [i for i, p in enumerate(pieces) if p[2] == "poly"]
    if poly:
        derivs = (_less(c, ref), *_derivatives(c))
        moments = _truncated_moments(za[poly], zb[poly], len(derivs) - 1)
        part = np.zeros_like(moments[0])
        # the Taylor coefficients at the mean: at a single mean on floats (the same arithmetic)
        at = float(m[0]) if m.size == 1 else m
        for n, d in enumerate(derivs):
            part += horner(d, at) / math.factorial(n) * sigma**n * moments[n]
    total = np.zeros_like(m)
    inside = np.zeros_like(m)
    for i, (_, _, what) in enumerate(pieces):
        if what != "poly":
            total += ((low if what == "low" else high) - ref) * prob[i]
            continue
        j = poly.index(i)
        total += part[j]
        inside += moments[0][j]
    return total, inside


def _sine(c: Coefficients, pieces: Sequence[tuple[float, float, str]], low: float, high: float,
          m: float, amp: float, ref: float) -> tuple[float, float]:
    """(E[clip(P(m + A cos θ)) - ref; kept], P(kept)) over θ uniform on [0, π]."""
    touched = [w for a, b, w in pieces if a < m + amp and b > m - amp]
    if touched == ["poly"]:
        # the sine stays on one polynomial piece: its moments, E[(A cos θ)^n] = A^n·C(n, n/2)/2^n
        # for even n (0 for odd), exactly, so a sine clear of the rails adds exactly 0
        total = 0.0
        for n, q in enumerate((_less(c, ref), *_derivatives(c))):
            if n % 2 == 0:
                total += float(horner(q, m)) / math.factorial(n) * amp**n * math.comb(n, n // 2) / 2**n
        return total, 1.0
    total = inside = 0.0
    for a, b, what in pieces:
        # y = m + A cos θ decreases in θ: the piece (a, b) is θ in (θ(b), θ(a))
        t_hi = math.pi if a <= m - amp else (0.0 if a >= m + amp else math.acos((a - m) / amp))
        t_lo = 0.0 if b >= m + amp else (math.pi if b <= m - amp else math.acos((b - m) / amp))
        if t_hi <= t_lo:
            continue
        frac = (t_hi - t_lo) / math.pi
        if what != "poly":
            total += ((low if what == "low" else high) - ref) * frac
            continue
        th = 0.5 * (t_hi + t_lo) + 0.5 * (t_hi - t_lo) * _GL_X
        total += 0.5 * frac * float(_GL_W @ (horner(c, m + amp * np.cos(th)) - ref))
        inside += frac
    return total, inside


class PolyClipOptions(TypedDict, total=False):
    """The keywords of :func:`poly_clip_vre` after the polynomial (its parameters' docs)."""

    offset_g: float
    rail_low_g: float
    rail_high_g: float
    shape: Shape
    kind: Kind
    tone_peaks_g: Sequence[float]


def poly_clip_vre(
    static_g: float,
    rms_g: float,
    k2_per_g: float = 0.0,
    k3_per_g2: float = 0.0,
    k4_per_g3: float = 0.0,
    *legacy: object,
    **options: Unpack[PolyClipOptions],
) -> float:
    r"""VRE [g] of ``clip(P(g0 + x) + offset, L, U)``: polynomial and rails as one memoryless map.

    Parameters
    ----------
    static_g : float
        Static level g0 at the polynomial's input [g].
    rms_g : float
        rms of the vibration x there [g]: Gaussian σ, or a sine's rms (A = rms·√2); with
        ``tone_peaks_g``, the Gaussian part's σ.
    k2_per_g, k3_per_g2, k4_per_g3 : float
        Nonlinearity (physics §1.2).
    offset_g : float
        Offset added between the polynomial and the rails [g].
    rail_low_g, rail_high_g : float
        Rails L < U [g] (±inf: none).
    shape : {"gaussian", "sine"}
    kind : {"censored", "truncated"}
        Censored: beyond a rail reads the rail. Truncated: samples beyond are discarded (the
        article's model), the mean is over the kept ones.
    tone_peaks_g : sequence of float
        Sine tones [g peak] on the Gaussian part (sine-on-random), independent uniform phases.

    The parameters after ``k4_per_g3`` are keywords (:class:`PolyClipOptions`); given by
    position, as before, they still work for one release with a ``DeprecationWarning``.

    Returns
    -------
    float
        ``E[out] - out(x = 0)``: the mean output with vibration less the vibration-off reading
        ``clip(P(g0) + offset)`` (:func:`vibration_off_reading`, physics §1.5). With no rails this is
        physics §1.2's polynomial VRE exactly; with k = 0, physics §1.1's clipped mean
        (:func:`vrelab.models.design.clip_vre`), which differs from the mean shift measured
        from μ only where g0 lies beyond a rail.

    Notes
    -----
    Closed form: see the module notes (truncated normal moments on the pieces between the
    kinks; Gauss-Legendre in θ for a sine; the tones' phase average for sine-on-random).
    """
    o = cast(PolyClipOptions, _keywords.merged("poly_clip_vre", list(PolyClipOptions.__annotations__), legacy, options))
    rail_low_g, rail_high_g = o.get("rail_low_g", -math.inf), o.get("rail_high_g", math.inf)
    shape, kind = o.get("shape", "gaussian"), o.get("kind", DEFAULT_CLIP_KIND)
    g0 = _validate.finite_scalar("static_g", static_g)
    rms = _validate.non_negative_scalar("rms_g", rms_g)
    low, high = float(rail_low_g), float(rail_high_g)
    if not low < high:
        raise ValueError(f"rail_low_g must be < rail_high_g, got {rail_low_g!r}, {rail_high_g!r}")
    _validate.one_of("shape", shape, ("gaussian", "sine"))
    _validate.one_of("kind", kind, KINDS)
    p = _coefficients(k2_per_g, k3_per_g2, k4_per_g3, o.get("offset_g", 0.0))
    peaks = _motion_peaks(rms, shape, o.get("tone_peaks_g", ()))
    if rms == 0 and not peaks:
        return 0.0
    return _poly_clip(p, (low, high), g0, rms, shape, kind, peaks)


def _motion_peaks(rms: float, shape: Shape, tone_peaks_g: Sequence[float]) -> list[float]:
    """The tones' peaks (those > 0) of a motion of Gaussian (or sine) rms ``rms``, refused where
    the two do not go together (tones on a sine, tones without a random part)."""
    peaks = [float(a) for a in tone_peaks_g if a > 0]
    if rms == 0 and not peaks:
        return peaks
    if shape == "sine" and peaks:
        raise ValueError("tone_peaks_g ride on Gaussian vibration: shape must be 'gaussian'")
    if shape != "sine" and peaks and rms == 0:
        raise ValueError("tones alone (no random part) are not a Gaussian motion: give rms_g > 0")
    return peaks


def _poly_clip(p: Coefficients, rails: tuple[float, float], g0: float, rms: float, shape: Shape, kind: Kind,
               peaks: Sequence[float]) -> float:
    """:func:`poly_clip_vre` of checked inputs (``p`` the map's coefficients, offset first; a
    motion with rms > 0 or tones)."""
    low, high = rails
    ref = _clipped(p, g0, low, high)  # vibration_off_reading
    pieces = _pieces(p, low, high)
    total, inside = _piecewise_mean(p, pieces, (low, high), g0, rms, ref, shape, peaks)
    if kind == "censored":
        return total
    if not inside > 0:
        return math.nan
    # kept samples only: subtract the rail pieces' share (what truncation discards), divide by
    # the kept probability
    only_rails = [(a, b, w) for a, b, w in pieces if w != "poly"]
    kept = total - (_piecewise_mean(p, only_rails, (low, high), g0, rms, ref, shape, peaks)[0] if only_rails else 0.0)
    return kept / inside


def poly_clip_each(static_g: float, rms_g: float, k: Sequence[float], rails: Sequence[tuple[float, float]],
                   offset_g: float = 0.0, shape: Shape = "gaussian", kind: Kind = DEFAULT_CLIP_KIND,
                   tone_peaks_g: Sequence[float] = ()) -> list[float]:
    """:func:`poly_clip_vre` of one polynomial ``k = (k2, k3, k4)`` and one motion for each pair of
    ``rails`` (``(L, U)``, ±inf: none), the same numbers, the inputs checked once.

    What a prediction asks at every level (:meth:`vrelab.sensor.stages.Clip.mean_shift`: both
    rails, each rail alone): for Gaussian vibration (no tones) with censoring, every pair's
    pieces are evaluated in one pass of array operations (:func:`_gaussian_each`), each piece the
    same elementwise operations :func:`poly_clip_vre` makes on it, so the same bits.

    Examples
    --------
    k2 = 100 µg/g² and ±2 g rails at 1 g rms of Gaussian vibration on a 1 g field: both rails
    (the article's Figure 1 with the polynomial), the lower alone, the upper alone; each what
    :func:`poly_clip_vre` gives for that pair.

    >>> from vrelab.models.memoryless import poly_clip_each, poly_clip_vre
    >>> rails = [(-2.0, 2.0), (-2.0, float("inf")), (float("-inf"), 2.0)]
    >>> both, low, high = poly_clip_each(1.0, 1.0, (1e-4, 0.0, 0.0), rails)
    >>> print(f"{both * 1e3:.2f} {low * 1e3:.2f} {high * 1e3:.2f} mg")
    -82.94 0.48 -83.32 mg
    >>> import numpy as np  # the same operations (bit for bit here); 1e-12 for any CPU's rounding
    >>> np.allclose([both, low, high], [poly_clip_vre(1.0, 1.0, 1e-4, rail_low_g=a, rail_high_g=b) for a, b in rails],
    ...             rtol=1e-12, atol=0.0)
    True
    """
    g0 = _validate.finite_scalar("static_g", static_g)
    rms = _validate.non_negative_scalar("rms_g", rms_g)
    pairs = [(float(lo), float(hi)) for lo, hi in rails]
    for (low, high), (given_low, given_high) in zip(pairs, rails):
        if not low < high:
            raise ValueError(f"rail_low_g must be < rail_high_g, got {given_low!r}, {given_high!r}")
    _validate.one_of("shape", shape, ("gaussian", "sine"))
    _validate.one_of("kind", kind, KINDS)
    p = _coefficients(k[0], k[1], k[2], offset_g)
    peaks = _motion_peaks(rms, shape, tone_peaks_g)
    if rms == 0 and not peaks:
        return [0.0] * len(pairs)
    if shape == "gaussian" and not peaks and kind == "censored":
        return _gaussian_each(p, pairs, g0, rms)
    if shape == "sine" and kind == "censored":
        return _sine_each(p, pairs, g0, rms)
    return [_poly_clip(p, pair, g0, rms, shape, kind, peaks) for pair in pairs]


def _sine_each(c: Coefficients, rails: Sequence[tuple[float, float]], g0: float, rms: float) -> list[float]:
    """The censored :func:`_sine` mean for each pair of rails: a sine that stays on the polynomial
    piece between a pair's rails has the mean of its moments, which depends on the pair only
    through its reference (the vibration-off reading), so pairs with the same reference share it."""
    amp = rms * math.sqrt(2.0)
    clear: dict[tuple[float, float], float] = {}
    out = []
    for low, high in rails:
        ref = _clipped(c, g0, low, high)
        pieces = _pieces(c, low, high)
        if [w for a, b, w in pieces if a < g0 + amp and b > g0 - amp] == ["poly"]:
            key = (ref, math.copysign(1.0, ref))  # the reference's bits (0.0 and -0.0 apart)
            if key not in clear:
                clear[key] = _sine(c, pieces, low, high, g0, amp, ref)[0]
            out.append(clear[key])
        else:
            out.append(_sine(c, pieces, low, high, g0, amp, ref)[0])
    return out


def _gaussian_each(c: Coefficients, rails: Sequence[tuple[float, float]], g0: float, sigma: float) -> list[float]:
    """The censored :func:`_gaussian` mean of ``clip(P(Y))`` less its vibration-off reading for each
    pair of rails, Y ~ N(g0, σ²): every pair's pieces stacked as rows of one array, each row the
    elementwise operations :func:`_gaussian` makes on it (the Taylor coefficients at g0 per row,
    the n = 0 one of ``P - ref`` with that pair's reference), summed per pair in its pieces' order."""
    refs = [_clipped(c, g0, low, high) for low, high in rails]
    pieces = [_pieces(c, low, high) for low, high in rails]
    rows = [(v, piece) for v, ps in enumerate(pieces) for piece in ps]
    m = np.array([g0])
    za = (np.array([piece[0] for _, piece in rows])[:, None] - m) / sigma
    zb = (np.array([piece[1] for _, piece in rows])[:, None] - m) / sigma
    prob = _prob(za, zb)
    poly = [i for i, (_, piece) in enumerate(rows) if piece[2] == "poly"]
    place = {i: j for j, i in enumerate(poly)}
    if poly:
        derivs = _derivatives(c)
        moments = _truncated_moments(za[poly], zb[poly], len(derivs))
        part = np.zeros_like(moments[0])
        for n in range(len(derivs) + 1):
            # per row what _gaussian multiplies moments[n] by: (horner / n!)·σ^n, in that order
            coef = [horner(_less(c, refs[rows[i][0]]) if n == 0 else derivs[n - 1], g0) / math.factorial(n) * sigma**n
                    for i in poly]
            part += np.array(coef)[:, None] * moments[n]
    out = []
    for v, ps in enumerate(pieces):
        low, high = rails[v]
        total = np.zeros_like(m)
        first = next(i for i, (w, _) in enumerate(rows) if w == v)
        for i, (_, _, what) in enumerate(ps, start=first):
            if what == "poly":
                total += part[place[i]]
            else:
                total += ((low if what == "low" else high) - refs[v]) * prob[i]
        out.append(float(total[0]))
    return out


def _piecewise_mean(p: Coefficients, pieces: Sequence[tuple[float, float, str]], rails: tuple[float, float],
                    g0: float, rms: float, ref: float, shape: Shape, peaks: Sequence[float]) -> tuple[float, float]:
    """(sum over ``pieces`` of the map's mean less ``ref``, probability of the polynomial pieces)
    for the vibration's shape: a sine, Gaussian, or Gaussian with tones (phase-averaged)."""
    low, high = rails
    if shape == "sine":
        return _sine(p, pieces, low, high, g0, rms * math.sqrt(2.0), ref)
    if peaks:
        from vrelab.models.tones import phase_grid

        grid = phase_grid(list(peaks), rms)
        t, i = _gaussian(p, pieces, low, high, g0 + grid.sum_of(peaks), rms, ref)
        return float(np.mean(t)), float(np.mean(i))
    t, i = _gaussian(p, pieces, low, high, np.array([g0]), rms, ref)
    return float(t[0]), float(i[0])


def _nodes(rms: float, shape: Shape, peaks: Sequence[float], n_gauss: int = 24, n_sine: int = 32) -> NDArray[np.float64]:
    """Quadrature nodes (x, w) of the vibration's distribution: Gauss-Hermite on ``n_gauss``
    nodes (exact for polynomials of degree < 2·n_gauss in x: 47 by default), ``n_sine`` equally
    spaced phases for a sine (exact for degree < n_sine), their product with the tones' phase
    grid for sine-on-random."""
    if shape == "sine":
        th = 2.0 * np.pi * np.arange(n_sine) / n_sine
        return np.stack([rms * math.sqrt(2.0) * np.cos(th), np.full(n_sine, 1.0 / n_sine)])
    z, w = (_GH_X, _GH_W) if n_gauss == _GH_X.size else _hermite_nodes(n_gauss)
    x = rms * z
    if peaks:
        from vrelab.models.tones import phase_grid

        s = phase_grid(list(peaks), max(rms, 1e-300)).sum_of(list(peaks))
        x = (x[:, None] + s[None, :]).ravel()
        w = (w[:, None] * np.full(s.size, 1.0 / s.size)[None, :]).ravel()
    return np.stack([x, w])


def linear_part(
    static_g: float,
    rms_g: float,
    k2_per_g: float = 0.0,
    k3_per_g2: float = 0.0,
    k4_per_g3: float = 0.0,
    shape: Shape = "gaussian",
    tone_peaks_g: Sequence[float] = (),
) -> tuple[float, float]:
    """(gain, rest_rms_g) of ``P(g0 + x)`` as ``E[P] + gain·x + rest``: what a filter after the
    polynomial passes on.

    ``gain = Cov(P(g0 + x), x)/Var(x)`` (Gaussian: ``E[P'(g0 + x)]`` by Stein's lemma; a sine:
    the describing function's fundamental), ``rest`` uncorrelated with x, its rms
    ``sqrt(Var(P) - gain²·Var(x))`` (the higher Hermite terms, or the harmonics). By
    quadrature exact for these polynomials (:func:`_nodes`).
    """
    x, w = _nodes(float(rms_g), shape, [float(a) for a in tone_peaks_g if a > 0])
    if not (w @ (x * x)) > 0:
        return 1.0, 0.0
    p = polynomial(k2_per_g, k3_per_g2, k4_per_g3)
    y = p(static_g + x) - p(static_g)
    ey = float(w @ y)
    var_x = float(w @ (x * x))
    gain = float(w @ ((y - ey) * x)) / var_x
    rest = float(w @ (y - ey - gain * x) ** 2)
    return gain, math.sqrt(max(rest, 0.0))


def hermite_rms(static_g: float, rms_g: float, k2_per_g: float = 0.0, k3_per_g2: float = 0.0,
                k4_per_g3: float = 0.0) -> list[float]:
    """rms of the Hermite components n = 1..4 of ``P(g0 + x)``, x ~ N(0, σ²) [g].

    ``P(g0 + σz) = E[P] + Σ_n c_n·He_n(z)``, ``c_n = E[P·He_n(z)]/n!``, component rms
    ``|c_n|·sqrt(n!)`` (He_n orthogonal, ``E[He_n²] = n!``). The n-th component of a Gaussian
    process's image lies in the n-th Wiener chaos, orthogonal to the others, through any
    linear filter: what a clip after a filter can correlate with. Gauss-Hermite, exact here.
    """
    z, w = _GH_X, _GH_W
    p = polynomial(k2_per_g, k3_per_g2, k4_per_g3)
    y = p(static_g + rms_g * z)
    out = []
    for n in range(1, 5):
        he = np.polynomial.hermite_e.hermeval(z, [0.0] * n + [1.0])
        c = float(w @ (y * he)) / math.factorial(n)
        out.append(abs(c) * math.sqrt(math.factorial(n)))
    return out


@functools.lru_cache(maxsize=8)
def _hermite_nodes(n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Gauss-Hermite (probabilists') nodes and weights normalised to 1: E[g(Z)], Z ~ N(0, 1)."""
    x, w = np.polynomial.hermite_e.hermegauss(n)
    return x, w / w.sum()


# Gauss-Hermite on this many nodes and twice as many; where the two differ by more than the
# tolerance the map is not smooth enough (a kink: rails) and adaptive quadrature takes over.
_MAP_NODES = 64
_MAP_RTOL, _MAP_ATOL = 1e-10, 1e-13
_MAP_SAFETY = 10.0


def map_vre(f: Callable[[NDArray[np.float64]], NDArray[np.float64]], static_g: float, rms_g: float,
            shape: Shape = "gaussian", tone_peaks_g: Sequence[float] = ()) -> tuple[float, float]:
    r"""VRE [g] of any memoryless map ``f`` by quadrature, with an estimate of the quadrature's error.

    .. math:: \mathrm{VRE} = E[f(g_0 + x)] - f(g_0)

    The numerical fallback of a stage with no closed form (:class:`vrelab.sensor.meanshift.Numerical`);
    the closed forms (:func:`poly_clip_vre`) are held against it in the tests. ``f`` takes and
    returns a float array.

    * Gaussian x ~ N(0, σ²): Gauss-Hermite quadrature (numpy's ``hermegauss``) on 64 and 128
      nodes, exact for a polynomial of degree < 128;
    * a sine of rms σ (``x = σ·√2·cos θ``): the mean over 64 and 128 equally spaced phases (the
      trapezoid rule on a period: exact for a polynomial of degree < 64);
    * Gaussian plus tones (``tone_peaks_g`` [g peak], independent uniform phases): Gauss-Hermite
      over the Gaussian part times the tones' phase grid (:func:`vrelab.models.tones.phase_grid`).

    Where the two node counts agree (within 1e-10 relative, 1e-13 g) the finer one is returned
    with their difference as the error. Where they do not, the map has a kink or a steep part
    that a fixed rule converges on slowly and erratically (rails: 0.5 % off on 192 nodes), and
    adaptive quadrature takes over (scipy's ``quad_vec`` over the Gaussian density, ``quad`` over
    the sine's phase), ten times its own error estimate returned.

    Returns ``(vre_g, error_g)``.

    python-control's ``describing_function`` is not used (nor a dependency): it gives the first
    harmonic (gain and phase) of a nonlinearity under a zero-bias sine, after checking
    ``f(0) = 0``; the rectified mean of ``f`` about a static level g0 is its zeroth harmonic,
    which it does not return, and it has no Gaussian drive. (The first harmonic, what a filter
    after a polynomial passes on, is :func:`linear_part`, exact by quadrature.)
    """
    from scipy import integrate

    g0 = _validate.finite_scalar("static_g", static_g)
    rms = float(_validate.non_negative("rms_g", rms_g))
    _validate.one_of("shape", shape, ("gaussian", "sine"))
    peaks = [float(a) for a in tone_peaks_g if a > 0]
    if shape == "sine" and peaks:
        raise ValueError("tone_peaks_g ride on Gaussian vibration: shape must be 'gaussian'")
    if rms == 0 and not peaks:
        return 0.0, 0.0
    if peaks and rms == 0:
        raise ValueError("tones alone (no random part) are not a Gaussian motion: give rms_g > 0")

    def values(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.asarray(f(np.asarray(x, dtype=np.float64)), dtype=np.float64)

    ref = float(values(np.array([g0]))[0])

    def mean(n: int) -> float:
        x, w = _nodes(rms, shape, peaks, n_gauss=n, n_sine=n)
        return float(w @ values(g0 + x))

    coarse, fine = mean(_MAP_NODES) - ref, mean(2 * _MAP_NODES) - ref
    if abs(fine - coarse) <= _MAP_ATOL + _MAP_RTOL * abs(fine):
        return fine, abs(fine - coarse)
    if shape == "sine":
        amp = rms * math.sqrt(2.0)
        value, err = integrate.quad(lambda t: float(values(np.array([g0 + amp * math.cos(t)]))[0]) / math.pi,
                                    0.0, math.pi, epsabs=_MAP_ATOL, epsrel=_MAP_RTOL, limit=500)
    else:
        from vrelab.models.tones import phase_grid

        tones = phase_grid(peaks, rms).sum_of(peaks) if peaks else np.zeros(1)

        def weighted(z: float, /) -> float:  # the map's mean over the tones' phases, times the normal density
            return math.exp(-0.5 * z * z) / _SQRT2PI * float(np.mean(values(g0 + rms * z + tones)))

        value, err = integrate.quad_vec(weighted, -math.inf, math.inf, epsabs=_MAP_ATOL, epsrel=_MAP_RTOL, limit=500)
    # scipy's estimate, widened tenfold: averaged over the tones' phases (a kink per phase) it
    # was seen to fall short of the true error by up to 2x (at 1e-11 g, against the closed form)
    return float(value) - ref, _MAP_SAFETY * float(err) + _MAP_ATOL
