"""Rectification by asymmetric rails (physics §1.1): the mean shift of a clipped vibration.

A sensor with rails ``[L, U]`` in a static field ``g0`` clips the vibration asymmetrically and the
mean of its output moves. Two models of what happens beyond a rail:

* **censored** (physical saturation, the default): a sample beyond a rail reads as the rail;
* **truncated** (the article's model): a sample beyond a rail is discarded.

Closed forms exist for Gaussian and sine vibration; any other distribution goes through
:func:`clip_mean_shift` (numerical expectation over a pdf, or over samples). Every ``*mean_shift``
function returns the mean shift ``E[output] - E[input]`` (measured from μ = g0) in g, and
broadcasts its array arguments.

Reference point: the VRE the tool states (physics §1.5) is referred to the vibration-off reading
``clip(μ)`` (:func:`vrelab.models.memoryless.vibration_off_reading`), not to μ: :func:`vrelab.models.design.clip_vre`.
The two are the same number wherever μ lies within the rails; beyond a rail the mean shift
also counts the static level's own clipping ``clip(μ) - μ``, which no vibration causes (±2 g
rails, μ = 2.5 g, 1 g rms: mean shift -698 mg, VRE -198 mg). The mean shifts stay as they are
because they are the textbook quantity (a truncated normal's mean less μ) and what a caller
composing clip stages needs (``E[clip(N(m, σ²))] = m + shift``).

Numerics: the textbook forms subtract nearly equal numbers (a 1 µg shift out of two 0.4 g
terms; two tail probabilities of 1e-300); the forms used here are free of that cancellation, so
the result keeps full relative precision from sigma = 1e-6 g to 1e6 g and with rails far inside
or far outside the vibration. Each function's Notes say how.
"""

from __future__ import annotations

from typing import Callable, Literal, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vrelab import _validate

# re-exported (`X as X`, explicit for mypy's no_implicit_reexport): the clipping model's kinds
from vrelab.models.kinds import DEFAULT_CLIP_KIND as DEFAULT_CLIP_KIND
from vrelab.models.kinds import KINDS as KINDS
from vrelab.models.kinds import Kind as Kind
from vrelab.models.memoryless import horner

# scipy.special (ndtr, erfcx) is imported by the functions that use it, not here: its import
# (0.3-0.4 s of CPU with SciPy's array-API layer) would otherwise be paid by every command that
# imports this module (issue 29: `vrelab model poly`, the design helpers) without evaluating a
# normal tail probability.

Shape = Literal["gaussian", "sine"]
SHAPES: tuple[str, ...] = ("gaussian", "sine")

_SQRT_HALF_PI = np.sqrt(np.pi / 2.0)
_LOG_SQRT_2PI = 0.5 * np.log(2.0 * np.pi)
# 10-point Gauss-Legendre: on an interval where the integrand's log changes by at most ~2 (the
# only place the closed forms cancel) its error is below 1e-16 relative.
_GL_X, _GL_W = np.polynomial.legendre.leggauss(10)
_GL_XP, _GL_WP = _GL_X[_GL_X > 0], _GL_W[_GL_X > 0]
_NARROW = 2.0
# Above this, 1 - t·R(t) (R the Mills ratio) loses more than t²·eps to cancellation, so the
# asymptotic series takes over; 9 terms leave < 1e-16 relative at t = 25.
_SERIES_T = 25.0
_SERIES_COEF = (1.0, -3.0, 15.0, -105.0, 945.0, -10395.0, 135135.0, -2027025.0, 34459425.0)


def _check_rails(rail_low_g: NDArray[np.float64], rail_high_g: NDArray[np.float64]) -> None:
    if (rail_low_g >= rail_high_g).any():
        bad = np.broadcast_arrays(rail_low_g, rail_high_g)
        i = np.flatnonzero((bad[0] >= bad[1]).ravel())[0]
        raise ValueError(
            f"rail_low_g must be < rail_high_g, got rail_low_g={bad[0].ravel()[i]!r}, "
            f"rail_high_g={bad[1].ravel()[i]!r}"
        )


def _inputs(
    mean_g: ArrayLike, spread: ArrayLike, spread_name: str, low: ArrayLike, high: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    # The common case checked at once: float arrays with finite μ, finite spread >= 0 and L < U
    # (False for a NaN or an infinite rail on the wrong side); anything else goes through the
    # checks below, which name the problem. (A rail fit calls this thousands of times: the
    # separate checks were a third of the derivatives' time.)
    try:
        fast = tuple(np.asarray(x, dtype=np.float64) for x in (mean_g, spread, low, high))
    except (TypeError, ValueError):
        fast = ()
    if fast:
        mu, s, lo, hi = fast
        if np.isfinite(mu).all() and np.isfinite(s).all() and (s >= 0).all() and (lo < hi).all():
            mu_b, s_b, lo_b, hi_b = np.broadcast_arrays(mu, s, lo, hi)
            return mu_b, s_b, lo_b, hi_b
    mu = _validate.finite("mean_g", mean_g)
    s = _validate.non_negative(spread_name, spread)
    lo = _validate.as_float_array("rail_low_g", low)
    hi = _validate.as_float_array("rail_high_g", high)
    if (lo == np.inf).any():
        raise ValueError("rail_low_g must be < +inf, got inf")
    if (hi == -np.inf).any():
        raise ValueError("rail_high_g must be > -inf, got -inf")
    _check_rails(lo, hi)
    mu_b, s_b, lo_b, hi_b = np.broadcast_arrays(mu, s, lo, hi)
    return mu_b, s_b, lo_b, hi_b


def _scalar_or_array(x: NDArray[np.float64]) -> NDArray[np.float64]:
    return x[()] if x.ndim == 0 else x


def _two_sum(a: NDArray[np.float64], b: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Knuth's TwoSum: s + e == a + b exactly (s the rounded sum)."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


def _rail_asymmetry(mu: NDArray[np.float64], low: NDArray[np.float64], high: NDArray[np.float64]) -> NDArray[np.float64]:
    """(L - μ) + (U - μ), accurate to rounding of the result itself.

    This is σ·(α + β), how far the rails' centre sits from μ; it decides the sign and size of
    every shift, and it is a small difference of large numbers whenever μ is near the centre.
    Error-free transformations keep it exact to a few ulps whatever the magnitudes.
    """
    with np.errstate(invalid="ignore", over="ignore"):
        d1, e1 = _two_sum(low, -mu)
        d2, e2 = _two_sum(high, -mu)
        s, e3 = _two_sum(d1, d2)
        out = s + (e3 + (e1 + e2))
        # TwoSum's error terms are NaN for infinite operands; the plain sum is right there.
        return np.where(np.isfinite(out), out, (low - mu) + (high - mu))


def _mills_gap(t: NDArray[np.float64]) -> NDArray[np.float64]:
    """``q(t) = 1 - t·R(t)`` for t >= 0, where R(t) = (1-Φ(t))/φ(t) is Mills' ratio."""
    from scipy import special  # at first use: see the module's imports

    small = t < _SERIES_T
    if small.all():  # the common case, without the masked copies
        out: NDArray[np.float64] = 1.0 - t * _SQRT_HALF_PI * special.erfcx(t / np.sqrt(2.0))
        return out
    q = np.empty_like(t)
    ts = t[small]
    q[small] = 1.0 - ts * _SQRT_HALF_PI * special.erfcx(ts / np.sqrt(2.0))
    # 1 - tR(t) ~ Σ (-1)^(k+1) (2k-1)!! / t^(2k): the asymptotic series of Mills' ratio [A&S 26.2.12]
    with np.errstate(over="ignore", divide="ignore"):
        u = 1.0 / np.square(t[~small])
    q[~small] = u * horner(_SERIES_COEF, u)  # numpy's polyval, bit for bit, without its overhead
    return q


def _partial_expectation(t: NDArray[np.float64]) -> NDArray[np.float64]:
    """``G(t) = E[(Z - t)+] = φ(t) - t·(1 - Φ(t))`` for Z ~ N(0, 1), any t (±inf included).

    For t >= 0 as ``φ(t)·(1 - t·R(t))`` (no cancellation between φ and the tail); for t < 0 from
    ``G(t) = G(-t) - t``, a sum of two positive terms.
    """
    a = np.abs(t)
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        pos = np.exp(-0.5 * a * a - _LOG_SQRT_2PI) * _mills_gap(a)
    pos = np.where(np.isinf(a), 0.0, pos)
    return np.where(t < 0, pos + a, pos)


def censored_mean_shift(
    mean_g: ArrayLike, sigma_g: ArrayLike, rail_low_g: ArrayLike, rail_high_g: ArrayLike
) -> NDArray[np.float64] | float:
    r"""Mean shift of Gaussian vibration saturated ("censored") at the rails.

    Parameters
    ----------
    mean_g : array_like
        Static acceleration along the sensing axis, μ = g0 [g].
    sigma_g : array_like
        rms of the zero-mean Gaussian vibration, σ >= 0 [g].
    rail_low_g, rail_high_g : array_like
        Rails L < U [g]; ±inf means no rail on that side.

    Returns
    -------
    numpy.ndarray or float
        VRE = E[clip(X, L, U)] - μ for X ~ N(μ, σ²) [g]. σ = 0 gives clip(μ) - μ.
        Measured from μ; :func:`vrelab.models.design.clip_vre` refers it to the vibration-off reading clip(μ).

    Notes
    -----
    With α = (L-μ)/σ, β = (U-μ)/σ (physics §1.1, from the article's section on range clipping):

    .. math:: E[\mathrm{clip}(X)] = L\,Φ(α) + U\,(1-Φ(β)) + μ\,(Φ(β)-Φ(α)) + σ\,(φ(α)-φ(β))

    Evaluated without cancellation as the difference of what the lower rail adds and what the
    upper rail removes,

    .. math:: \mathrm{VRE} = σ\,[G(-α) - G(β)] = \int_{μ-L}^{U-μ} Φ(-s/σ)\,ds,
              \qquad G(t) = E[(Z-t)^+] = φ(t) - t\,(1-Φ(t)),

    with G from Mills' ratio (``scipy.special.erfcx``) and its asymptotic series. When the two
    rail terms nearly balance (the mean near the mid-rail, or σ large against the rails) the
    integral form is used instead, by 10-point Gauss-Legendre quadrature, and keeps relative
    precision. The integral form also shows that, for μ in [L, U] with μ >= (L+U)/2, the VRE is
    <= 0 and its magnitude grows with σ, towards (L+U)/2 - μ.

    References
    ----------
    .. [1] Analog Devices, "Vibration rectification error in MEMS accelerometers" (the seed
       article; ADXL355 case study): the clipping mechanism. physics §1.1.
    .. [2] M. Abramowitz, I. Stegun, Handbook of Mathematical Functions, 26.2.12 (Mills' ratio).

    Examples
    --------
    The article's Figure 1: ±2 g rails, the axis in a 1 g field, 1 g rms Gaussian vibration. The
    saturated output reads 83 mg low:

    >>> from vrelab.models.clipping import censored_mean_shift
    >>> print(f"{censored_mean_shift(1.0, 1.0, -2.0, 2.0) * 1e3:.1f} mg")
    -82.9 mg
    """
    mu, sigma, low, high = _inputs(mean_g, sigma_g, "sigma_g", rail_low_g, rail_high_g)
    det = sigma == 0
    if not det.any():  # the common case (a rail fit's thousands of calls): no mask to apply
        return _scalar_or_array(_censored_random(*(_compact(x) for x in (mu, sigma, low, high))))
    out = np.empty(mu.shape)
    out[det] = np.clip(mu[det], low[det], high[det]) - mu[det]
    r = ~det
    out[r] = _censored_random(mu[r], sigma[r], low[r], high[r])
    return _scalar_or_array(out)


def _compact(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """A broadcast view's own values: length 1 along the axes it was broadcast over (stride 0)."""
    return x[tuple(slice(0, 1) if st == 0 and n > 1 else slice(None) for st, n in zip(x.strides, x.shape))]


def _censored_random(mu: NDArray[np.float64], sigma: NDArray[np.float64], low: NDArray[np.float64],
                     high: NDArray[np.float64]) -> NDArray[np.float64]:
    """:func:`censored_mean_shift` where σ > 0 (arrays that broadcast together). Every value is
    computed elementwise, so the rail terms are taken over the whole array and the balanced rails'
    quadrature then replaces them where it applies, and what depends on the rails alone (their
    asymmetry) is taken once per rail, not once per rail and level of a rail fit's grid: the
    same operations on the same values as taking each branch over its own elements of the
    broadcast arrays, without the masked copies (a third of a rail fit's time)."""
    from scipy import special  # at first use: see the module's imports

    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        a = (mu - low) / sigma  # = -α, distance to the lower rail in σ
        b = (high - mu) / sigma  # = β
        gap = _rail_asymmetry(mu, low, high)  # σ·(b - a)
        width = np.abs(gap / sigma)
        reach = np.maximum(1.0, np.maximum(np.abs(a), np.abs(b)))
        narrow = np.isfinite(gap) & (width * reach <= _NARROW)
        # Rail terms, each a positive physical contribution. σ·G(t) for t < 0 is σ·G(-t) + distance
        # beyond the rail, and the distance is taken from the inputs, not from σ·|t| (σ may be 1e-300).
        lower = sigma * _partial_expectation(np.abs(a)) + np.maximum(low - mu, 0.0)
        upper = sigma * _partial_expectation(np.abs(b)) + np.maximum(mu - high, 0.0)
    res: NDArray[np.float64] = np.asarray(lower - upper)  # 0-d: an array, not a numpy scalar
    if narrow.any():
        # Balanced rails: VRE = σ∫_a^b Φ(-t) dt = gap · mean of Φ(-t) over [a, b].
        n = narrow
        a, b, gap = (np.broadcast_to(x, res.shape)[n] for x in (a, b, gap))
        mid = 0.5 * (a + b)
        half = 0.5 * (b - a)
        nodes = mid[:, None] + half[:, None] * _GL_X
        res[n] = gap * (0.5 * special.ndtr(-nodes) @ _GL_W)
    return res


def censored_rail_derivatives(
    mean_g: ArrayLike, sigma_g: ArrayLike, rail_low_g: ArrayLike, rail_high_g: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    r"""Derivatives of :func:`censored_mean_shift` with respect to its rails.

    Returns
    -------
    (d_low, d_high) : tuple of numpy.ndarray
        ``∂VRE/∂L = Φ(α) = P(X < L)`` and ``∂VRE/∂U = 1 - Φ(β) = P(X > U)`` for X ~ N(μ, σ²),
        α = (L-μ)/σ, β = (U-μ)/σ; at σ = 0 the one-sided limits (1 where μ lies beyond that rail).

    Notes
    -----
    Differentiating physics §1.1's ``E[clip(X)] = L·Φ(α) + U·(1-Φ(β)) + ∫_L^U x f(x) dx`` under the
    integral sign: the boundary terms ``±L·f(L)``, ``±U·f(U)`` cancel and leave the probability
    mass on each rail (Leibniz's rule). Both are tail probabilities from ``scipy.special.ndtr``,
    exact in relative terms far into the tails. The rail fit (:func:`vrelab.fits.fit_rail`)
    gives them to its least-squares solver as the model's Jacobian.

    Examples
    --------
    How the mean shift of the article's Figure 1 (±2 g rails, 1 g field, 1 g rms) moves with each
    rail [g/g]: the upper rail, nearer the mean, dominates.

    >>> from vrelab.models.clipping import censored_rail_derivatives
    >>> d_low, d_high = censored_rail_derivatives(1.0, 1.0, -2.0, 2.0)
    >>> print(f"{float(d_low):.4f} {float(d_high):.4f}")
    0.0013 0.1587
    """
    from scipy import special  # at first use: see the module's imports

    mu, sigma, low, high = _inputs(mean_g, sigma_g, "sigma_g", rail_low_g, rail_high_g)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        d_low = special.ndtr((low - mu) / sigma)
        d_high = special.ndtr((mu - high) / sigma)
    det = sigma == 0
    d_low = np.where(det, (mu < low).astype(np.float64), d_low)
    d_high = np.where(det, (mu > high).astype(np.float64), d_high)
    return _scalar_or_array(np.asarray(d_low, dtype=np.float64)), _scalar_or_array(np.asarray(d_high, dtype=np.float64))


def truncated_mean_shift(
    mean_g: ArrayLike, sigma_g: ArrayLike, rail_low_g: ArrayLike, rail_high_g: ArrayLike
) -> NDArray[np.float64] | float:
    r"""Mean shift of Gaussian vibration whose samples beyond the rails are discarded.

    This is the article's model: the mean of a doubly truncated normal distribution minus μ.

    Parameters
    ----------
    mean_g : array_like
        Static acceleration along the sensing axis, μ = g0 [g].
    sigma_g : array_like
        rms of the zero-mean Gaussian vibration, σ >= 0 [g].
    rail_low_g, rail_high_g : array_like
        Rails L < U [g]; ±inf means no rail on that side.

    Returns
    -------
    numpy.ndarray or float
        VRE = E[X | L < X < U] - μ for X ~ N(μ, σ²) [g]. σ = 0 gives clip(μ) - μ (the limit).
        Measured from μ; :func:`vrelab.models.design.clip_vre` refers it to the vibration-off reading clip(μ).

    Notes
    -----
    With α = (L-μ)/σ, β = (U-μ)/σ:

    .. math:: \mathrm{VRE} = σ\,\frac{φ(α) - φ(β)}{Φ(β) - Φ(α)}

    **Seed erratum**: the article writes Φ for both the pdf and the cdf; the numerator holds
    pdfs (φ) and the denominator cdfs (Φ), as above (physics §1.1).

    Numerics, as in ``scipy.stats.truncnorm`` but vectorised: the numerator is
    ``-φ(α)·expm1(-(β-α)(β+α)/2)`` with (β-α) and (β+α) taken exactly from the inputs; when both
    rails lie on the same side of μ the ratio is formed from the tail nearer μ, as
    ``[1/R(α)]·expm1(-(β²-α²)/2)/expm1(-(β²-α²)/2 + log(R(β)/R(α)))`` with R Mills' ratio
    (``erfcx``), so rails 1e9 σ away still give the right answer; and for a narrow window (where those
    differences cancel) the conditional mean is a 10-point Gauss-Legendre ratio of φ-weighted
    sums, scaled by φ at the window's centre so that nothing underflows.

    References
    ----------
    .. [1] Analog Devices, "Vibration rectification error in MEMS accelerometers" (seed
       article), VRE model by truncation; physics §1.1 with its erratum.
    .. [2] N. L. Johnson, S. Kotz, N. Balakrishnan, Continuous Univariate Distributions vol. 1,
       2nd ed., Wiley 1994, section 10.1 (moments of the truncated normal).

    Examples
    --------
    The article's truncated model at its Figure 1 (±2 g rails, 1 g field, 1 g rms), far larger
    than the saturated output's -83 mg (:func:`censored_mean_shift`):

    >>> from vrelab.models.clipping import truncated_mean_shift
    >>> print(f"{truncated_mean_shift(1.0, 1.0, -2.0, 2.0) * 1e3:.0f} mg")
    -283 mg
    """
    from scipy import special  # at first use: see the module's imports

    mu, sigma, low, high = _inputs(mean_g, sigma_g, "sigma_g", rail_low_g, rail_high_g)
    out = np.empty(mu.shape)
    det = sigma == 0
    out[det] = np.clip(mu[det], low[det], high[det]) - mu[det]
    r = ~det
    # Mirror so that the window's centre is at or above μ: then the wide case below only ever
    # needs the upper-tail form (α >= 0) or the two-sided form.
    centre_all = _rail_asymmetry(mu, low, high)  # NaN only when both rails are infinite
    both_open = np.isnan(centre_all)
    out[r & both_open] = 0.0
    r &= ~both_open
    flip = centre_all < 0
    sgn = np.where(flip, -1.0, 1.0)[r]
    mu_r = (sgn * mu[r])
    low_r = np.where(flip, -high, low)[r]
    high_r = np.where(flip, -low, high)[r]
    sigma = sigma[r]
    with np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore"):
        al = (low_r - mu_r) / sigma
        be = (high_r - mu_r) / sigma
        span = high_r - low_r  # σ·(β-α)
        centre = 0.5 * np.abs(centre_all[r])  # σ·(α+β)/2, >= 0 after the mirror
        hw = 0.5 * span / sigma
        m = centre / sigma
        reach = np.maximum(1.0, np.maximum(np.abs(al), np.abs(be)))
        narrow = np.isfinite(span) & (2.0 * hw * reach <= _NARROW)
        res = np.empty(mu_r.shape)

        # Narrow window: E[t] over [α, β] by quadrature with weights φ(t)/φ(m), nodes paired
        # ±x so that E[t - m] = -Σ w·x·e^(-d²/2)·sinh(d·m) / Σ w·e^(-d²/2)·cosh(d·m) is exactly
        # zero for a centred window and has the sign of -m otherwise.
        n = narrow
        d = hw[n][:, None] * _GL_XP  # t - m at the positive nodes
        dm = d * m[n][:, None]
        g = _GL_WP * np.exp(-0.5 * d * d)
        res[n] = centre[n] - 0.5 * span[n] * ((g * np.sinh(dm)) @ _GL_XP) / ((g * np.cosh(dm)).sum(axis=1))

        # Wide window. num = φ(α) - φ(β) = -φ(α)·expm1(-(β-α)(β+α)/2).
        w = ~narrow
        al_w, be_w, s_w = al[w], be[w], sigma[w]
        prod = np.where(np.isinf(be_w), np.inf, (2.0 * hw[w]) * (2.0 * m[w]) / 2.0)
        ratio_num = -np.expm1(-prod)
        upper_tail = al_w >= 0
        wide = np.empty(al_w.shape)
        # Both rails above μ: divide by the upper tail Φ(-α); φ(α)/Φ(-α) = 1/R(α).
        u = upper_tail
        # log Φ(-β) - log Φ(-α) = -(β²-α²)/2 + log(R(β)/R(α)): the two log Φ are huge (-2e18
        # for rails 2e9 σ away) and their difference would be lost; these two terms are not.
        erfcx_al = special.erfcx(al_w[u] / np.sqrt(2.0))
        log_r_ratio = np.log(special.erfcx(be_w[u] / np.sqrt(2.0)) / erfcx_al)
        den_u = -np.expm1(np.where(np.isinf(prod[u]), -np.inf, -prod[u] + log_r_ratio))
        inv_mills = 1.0 / (_SQRT_HALF_PI * erfcx_al)
        wide[u] = s_w[u] * inv_mills * ratio_num[u] / den_u
        # μ inside the window: Φ(β) - Φ(α) is at least ~0.68 here, no tail trick needed.
        v = ~upper_tail
        phi_al = np.exp(-0.5 * al_w[v] ** 2 - _LOG_SQRT_2PI)
        den_v = special.ndtr(be_w[v]) - special.ndtr(al_w[v])
        wide[v] = s_w[v] * phi_al * ratio_num[v] / den_v
        res[w] = wide
    out[r] = sgn * res
    return _scalar_or_array(out)


def _arccos_from_gaps(one_minus_c: NDArray[np.float64], one_plus_c: NDArray[np.float64]) -> NDArray[np.float64]:
    """arccos(c) from 1 - c and 1 + c: accurate near c = ±1, where arccos(c) itself is not."""
    return 2.0 * np.arctan2(np.sqrt(np.maximum(one_minus_c, 0.0)), np.sqrt(np.maximum(one_plus_c, 0.0)))


def _sin_minus_t_cos(t: NDArray[np.float64]) -> NDArray[np.float64]:
    """sin t - t·cos t, by its Taylor series Σ (-1)^(k+1) 2k·t^(2k+1)/(2k+1)! where it cancels."""
    small = t < 0.5
    ts = t[small]
    t2 = ts * ts
    series = np.zeros_like(ts)
    term = ts**3 / 3.0
    for k in range(1, 9):
        series += term
        # ratio of consecutive terms: -t²·(2k+2)/((2k)(2k+2)(2k+3)) = -t²/((2k)(2k+3))
        term = -term * t2 / ((2 * k) * (2 * k + 3))
    out = np.sin(t) - t * np.cos(t)
    out[small] = series
    return out


def _sine_rail_loss(beyond: NDArray[np.float64], amp: NDArray[np.float64]) -> NDArray[np.float64]:
    """E[(μ + A cos θ - U)+] over θ, given ``beyond = μ + A - U`` (how far the peak passes U).

    Peak past the rail: θu = arccos((U-μ)/A), loss = (A·sin θu - (U-μ)·θu)/π = A·(sin θu -
    θu·cos θu)/π. The whole sine past the rail (beyond >= 2A): loss = μ - U.
    """
    out = np.zeros_like(beyond)
    part = (beyond > 0) & (beyond < 2.0 * amp)
    th = _arccos_from_gaps(beyond[part] / amp[part], (2.0 * amp[part] - beyond[part]) / amp[part])
    out[part] = amp[part] * _sin_minus_t_cos(th) / np.pi
    full = beyond >= 2.0 * amp
    out[full] = beyond[full] - amp[full]
    return out


def sine_clip_mean_shift(
    mean_g: ArrayLike,
    amplitude_g: ArrayLike,
    rail_low_g: ArrayLike,
    rail_high_g: ArrayLike,
    kind: Kind = DEFAULT_CLIP_KIND,
) -> NDArray[np.float64] | float:
    r"""Mean shift of a sine vibration clipped at the rails (closed form).

    Parameters
    ----------
    mean_g : array_like
        Static acceleration along the sensing axis, μ [g].
    amplitude_g : array_like
        Sine amplitude A >= 0 [g peak] (rms·√2).
    rail_low_g, rail_high_g : array_like
        Rails L < U [g].
    kind : {"censored", "truncated"}
        Samples beyond a rail read as the rail (censored) or are discarded (truncated).

    Returns
    -------
    numpy.ndarray or float
        VRE [g], the average over one period of the output minus μ. Truncated: NaN where no
        part of the sine lies between the rails (nothing is left to average).

    Notes
    -----
    x = A·cos θ, θ uniform over a period (physics §1.1). Censored: where μ + A > U,
    θu = arccos((U-μ)/A) and the upper rail removes

    .. math:: (A \sin θ_u - (U-μ)\,θ_u)/π ;

    the lower rail adds the mirror image, with θl = arccos((μ-L)/A). Check value (physics §1.1):
    1 g field, ±2 g rails, 1 g rms (A = √2): -68.3 mg. Near first contact the bracket cancels
    (it is A·θ³/3); a Taylor series takes over there, and θ comes from μ + A - U directly.

    Truncated: the samples kept are those with cos θ in [cl, cu], cl = max((L-μ)/A, -1),
    cu = min((U-μ)/A, 1), i.e. θ in [θ1, θ2] = [arccos cu, arccos cl]; their mean is
    A·(sin θ2 - sin θ1)/(θ2 - θ1) = A·cos(θm)·sinc(Δ), θm the centre and Δ the half width.

    When the two censored rail terms nearly cancel (mean near mid-rail), the equivalent
    ``VRE = ∫_{μ-L}^{U-μ} arccos(s/A)/π ds`` is integrated by Gauss-Legendre instead.

    References
    ----------
    .. [1] Analog Devices, "Vibration rectification error in MEMS accelerometers" (seed
       article); physics §1.1.

    Examples
    --------
    A 2 g-amplitude sine on a 1 g field against ±2 g rails: its peaks pass the upper rail by 1 g.

    >>> from vrelab.models.clipping import sine_clip_mean_shift
    >>> print(f"{sine_clip_mean_shift(1.0, 2.0, -2.0, 2.0) * 1e3:.1f} mg")
    -218.0 mg
    """
    _validate.one_of("kind", kind, KINDS)
    mu, amp, low, high = _inputs(mean_g, amplitude_g, "amplitude_g", rail_low_g, rail_high_g)
    out = np.empty(mu.shape)
    det = amp == 0
    out[det] = np.clip(mu[det], low[det], high[det]) - mu[det]
    r = ~det
    mu, amp, low, high = mu[r], amp[r], low[r], high[r]
    with np.errstate(invalid="ignore", over="ignore"):
        beyond_up = mu + amp - high  # how far the peak passes U
        beyond_low = low - (mu - amp)  # how far the trough passes L
    if kind == "censored":
        res = _sine_rail_loss(np.nan_to_num(beyond_low, neginf=-1.0), amp) - _sine_rail_loss(
            np.nan_to_num(beyond_up, neginf=-1.0), amp
        )
        # Balanced rails (mean near mid-rail, both rails inside the swing): the two rail terms
        # cancel. VRE = ∫_{μ-L}^{U-μ} P(A·cos θ > s) ds = ∫ arccos(s/A)/π ds instead, by
        # Gauss-Legendre, where the interval keeps clear of ±A (arccos is analytic there).
        with np.errstate(invalid="ignore", over="ignore"):
            a, b = mu - low, high - mu
            reach = np.maximum(np.abs(a), np.abs(b))
            gap = _rail_asymmetry(mu, low, high)
            n = (reach < amp) & (np.abs(gap) <= 0.5 * (amp - reach))
        nodes = 0.5 * (a[n] + b[n])[:, None] + 0.5 * gap[n][:, None] * _GL_X
        c = np.clip(nodes / amp[n][:, None], -1.0, 1.0)
        res[n] = gap[n] * (0.5 * (np.arccos(c) / np.pi) @ _GL_W)
    else:
        # θ1 = arccos(cu): 1 - cu = max(beyond_up, 0)/A; θ2 = arccos(cl): 1 + cl = max(beyond_low, 0)/A
        with np.errstate(invalid="ignore", over="ignore"):
            one_m_cu = np.clip(np.nan_to_num(beyond_up, neginf=-1.0), 0.0, None) / amp
            one_p_cl = np.clip(np.nan_to_num(beyond_low, neginf=-1.0), 0.0, None) / amp
            th1 = _arccos_from_gaps(one_m_cu, 2.0 - one_m_cu)
            th2 = _arccos_from_gaps(2.0 - one_p_cl, one_p_cl)
            empty = (one_m_cu >= 2.0) | (one_p_cl >= 2.0) | (th2 < th1)
            centre = 0.5 * (th1 + th2)
            half = 0.5 * (th2 - th1)
            res = amp * np.cos(centre) * np.sinc(half / np.pi)
        res = np.where(empty, np.nan, res)
    out[r] = res
    return _scalar_or_array(out)


def clip_mean_shift(
    mean_g: float,
    rail_low_g: float,
    rail_high_g: float,
    *,
    pdf: Callable[[float], float] | None = None,
    samples: ArrayLike | None = None,
    kind: Kind = DEFAULT_CLIP_KIND,
) -> float:
    r"""Mean shift of any vibration distribution clipped at the rails (numerical expectation).

    Give exactly one of ``pdf`` (a callable density of the zero-mean vibration x, in 1/g) or
    ``samples`` (vibration values in g). The input is ``μ + x``.

    Parameters
    ----------
    mean_g : float
        Static acceleration μ [g].
    rail_low_g, rail_high_g : float
        Rails L < U [g].
    pdf : callable, optional
        Density of x; integrated with ``scipy.integrate.quad`` over (-inf, L-μ), (L-μ, U-μ),
        (U-μ, inf): split at the rails, where the integrands have kinks.
    samples : array_like, optional
        Samples of x (e.g. a simulated drive or a recorded reference channel).
    kind : {"censored", "truncated"}

    Returns
    -------
    float
        VRE [g]: E[clip(μ+x)] - E[μ+x] (censored) or E[μ+x | L < μ+x < U] - E[μ+x] (truncated).
        For samples, the sample version of the same (mean of the clipped or kept samples minus
        the mean of all). NaN for truncated samples when none lies inside the rails.

    Notes
    -----
    For a sigma-clipped drive, a kurtosis > 3 drive, or anything without a closed form (the
    python-control describing-function idea at the zeroth harmonic: closed forms for Gaussian
    and sine, numerics for the rest). Censored:
    ``VRE = ∫_{-inf}^{L} (L-a) p(a) da - ∫_{U}^{inf} (a-U) p(a) da``.

    Examples
    --------
    The numerical expectation agrees with the closed form for a Gaussian pdf (the article's
    Figure 1: ±2 g rails, 1 g field, 1 g rms):

    >>> from scipy.stats import norm
    >>> from vrelab.models.clipping import clip_mean_shift
    >>> print(f"{clip_mean_shift(1.0, -2.0, 2.0, pdf=norm(0.0, 1.0).pdf) * 1e3:.1f} mg")
    -82.9 mg

    Measured samples instead of a pdf (here uniform vibration of ±2 g):

    >>> import numpy as np
    >>> x = np.random.default_rng(1).uniform(-2.0, 2.0, 100_000)
    >>> print(f"{clip_mean_shift(1.0, -2.0, 2.0, samples=x) * 1e3:.0f} mg")
    -125 mg
    """
    _validate.one_of("kind", kind, KINDS)
    mu = _validate.finite_scalar("mean_g", mean_g)
    low = float(_validate.as_float_array("rail_low_g", rail_low_g))
    high = float(_validate.as_float_array("rail_high_g", rail_high_g))
    _check_rails(np.asarray(low), np.asarray(high))
    if (pdf is None) == (samples is None):
        raise ValueError("clip_mean_shift needs exactly one of pdf or samples")
    if samples is not None:
        x = _validate.finite("samples", samples).ravel()
        if x.size == 0:
            raise ValueError("samples must not be empty")
        total = mu + x
        if kind == "censored":
            return float(np.mean(np.clip(total, low, high)) - np.mean(total))
        kept = total[(total >= low) & (total <= high)]
        return float(np.mean(kept) - np.mean(total)) if kept.size else float("nan")

    assert pdf is not None  # exactly one of pdf and samples, checked above
    lo_x, hi_x = low - mu, high - mu  # rails in vibration coordinates

    from scipy import integrate  # here: scipy.integrate costs 0.3 s to import, the closed forms need none

    def quad(f: Callable[[float], float], a: float, b: float) -> float:
        if a >= b:
            return 0.0
        return float(integrate.quad(f, a, b, limit=200, epsabs=1e-15, epsrel=1e-12)[0])

    if kind == "censored":
        gain = quad(lambda x: (lo_x - x) * pdf(x), -np.inf, lo_x)
        loss = quad(lambda x: (x - hi_x) * pdf(x), hi_x, np.inf)
        return gain - loss
    mean_x = quad(lambda x: x * pdf(x), -np.inf, min(lo_x, 0.0)) + quad(
        lambda x: x * pdf(x), min(lo_x, 0.0), max(hi_x, 0.0)
    ) + quad(lambda x: x * pdf(x), max(hi_x, 0.0), np.inf)
    mass_in = quad(pdf, lo_x, hi_x)
    if mass_in <= 0:
        return float("nan")
    return quad(lambda x: x * pdf(x), lo_x, hi_x) / mass_in - mean_x


def _inside_probability(mean_g: NDArray[np.float64], sigma_g: float, low: float, high: float) -> NDArray[np.float64]:
    """P(L < X < U) for X ~ N(mean, σ²), from the tail nearer the window (no 1 - 1 cancellation)."""
    from scipy import special  # at first use: see the module's imports

    a = (low - mean_g) / sigma_g
    b = (high - mean_g) / sigma_g
    upper = a > 0  # both rails above the mean: difference of upper tails
    inside: NDArray[np.float64] = np.where(upper, special.ndtr(-a) - special.ndtr(-b), special.ndtr(b) - special.ndtr(a))
    return inside


def sine_on_random_mean_shift(
    mean_g: float,
    sigma_g: float,
    peaks_g: Sequence[float],
    rail_low_g: float,
    rail_high_g: float,
    kind: Kind = DEFAULT_CLIP_KIND,
) -> float:
    r"""Mean shift of Gaussian vibration plus sine tones (sine-on-random) clipped at the rails.

    Parameters
    ----------
    mean_g : float
        Static acceleration μ [g].
    sigma_g : float
        rms σ > 0 of the Gaussian (random) part [g].
    peaks_g : sequence of float
        Tone amplitudes A_i >= 0 [g peak], each with its own independent uniform phase.
    rail_low_g, rail_high_g : float
        Rails L < U [g] (±inf: none).
    kind : {"censored", "truncated"}

    Returns
    -------
    float
        VRE [g] = E[clip(X)] - μ (censored) or E[X | L < X < U] - μ (truncated), X = μ + G +
        Σ A_i cos θ_i.

    Notes
    -----
    Given the phases, X is Gaussian with mean m = μ + s, s = Σ A_i cos θ_i (physics §1.1 applies
    with μ → m). Averaging over the phases (:mod:`vrelab.models.tones`):

    * censored: :math:`\mathrm{VRE} = E_θ[c(μ + s, σ)]`, c the censored shift of
      :func:`censored_mean_shift` (E_θ[s] = 0, so E[clip(X)] - μ = E_θ[c + s] = E_θ[c]);
    * truncated: the kept samples are pooled over the phases, so the conditional mean is a
      ratio, :math:`\mathrm{VRE} = E_θ[P(m)\,(s + t(m, σ))] / E_θ[P(m)]`, with
      P(m) = Φ(β) - Φ(α) the probability of staying inside and t the shift of
      :func:`truncated_mean_shift`; it is not the average of t.

    Held against Monte Carlo over samples and against nested adaptive quadrature in the tests.

    Examples
    --------
    0.7 g rms random plus a 1 g-peak tone on a 1 g field against ±2 g rails:

    >>> from vrelab.models.clipping import sine_on_random_mean_shift
    >>> print(f"{sine_on_random_mean_shift(1.0, 0.7, [1.0], -2.0, 2.0) * 1e3:.1f} mg")
    -80.6 mg
    """
    from vrelab.models.tones import phase_grid

    _validate.one_of("kind", kind, KINDS)
    mu = _validate.finite_scalar("mean_g", mean_g)
    sigma = _validate.positive_scalar("sigma_g", sigma_g)
    low = float(_validate.as_float_array("rail_low_g", rail_low_g))
    high = float(_validate.as_float_array("rail_high_g", rail_high_g))
    _check_rails(np.asarray(low), np.asarray(high))
    peaks = np.atleast_1d(_validate.non_negative("peaks_g", np.asarray(peaks_g, dtype=np.float64)))
    grid = phase_grid(list(peaks), sigma)
    s = grid.sum_of(peaks)
    m = mu + s
    if kind == "censored":
        return float(np.mean(censored_mean_shift(m, sigma, low, high)))
    inside = _inside_probability(m, sigma, low, high)
    with np.errstate(invalid="ignore"):
        kept = np.where(inside > 0, inside * (s + np.asarray(truncated_mean_shift(m, sigma, low, high))), 0.0)
    total = float(np.mean(inside))
    return float(np.mean(kept)) / total if total > 0 else float("nan")


def mean_shift(
    mean_g: ArrayLike,
    rms_g: ArrayLike,
    rail_low_g: ArrayLike,
    rail_high_g: ArrayLike,
    shape: Shape = "gaussian",
    kind: Kind = DEFAULT_CLIP_KIND,
) -> NDArray[np.float64] | float:
    """VRE of clipping for a vibration given by its rms: Gaussian (σ = rms) or sine (A = rms·√2).

    Dispatches to :func:`censored_mean_shift`, :func:`truncated_mean_shift` or
    :func:`sine_clip_mean_shift`; see those for the equations. Units: g in, g out. Measured
    from μ; :func:`vrelab.models.design.clip_vre` is the same referred to the vibration-off reading (physics §1.5).

    Examples
    --------
    The same 1 g rms on a 1 g field against ±2 g rails, Gaussian and sine:

    >>> from vrelab.models.clipping import mean_shift
    >>> print(f"{mean_shift(1.0, 1.0, -2.0, 2.0) * 1e3:.1f} mg")
    -82.9 mg
    >>> print(f"{mean_shift(1.0, 1.0, -2.0, 2.0, shape='sine') * 1e3:.1f} mg")
    -68.3 mg
    """
    _validate.one_of("shape", shape, SHAPES)
    _validate.one_of("kind", kind, KINDS)
    rms = _validate.non_negative("rms_g", rms_g)
    if shape == "sine":
        return sine_clip_mean_shift(mean_g, rms * np.sqrt(2.0), rail_low_g, rail_high_g, kind=kind)
    if kind == "censored":
        return censored_mean_shift(mean_g, rms, rail_low_g, rail_high_g)
    return truncated_mean_shift(mean_g, rms, rail_low_g, rail_high_g)
