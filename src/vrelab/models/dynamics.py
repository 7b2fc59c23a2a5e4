"""Frequency dependence of VRE (physics §1.3): proof-mass resonance, filters, crossing rates.

The nonlinearity and any rail act on the signal *where they sit* in the chain: the proof mass
(after the mechanical resonance) or the output (after the anti-alias and digital filters).
These functions give the vibration level at such a point, for a sine or for a random PSD, and
the rate at which Gaussian motion crosses a level (Rice), which drives over-range protection.
"""

from __future__ import annotations

import math
from typing import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vrelab import _validate

_MAX_CORNER_SPLITS = 64
_GL_X, _GL_W = np.polynomial.legendre.leggauss(10)
_EPSREL = 1e-10  # the spectral integrals' relative tolerance (QUADPACK's global test, as quad's was)
_MAX_INTERVALS = 20000  # quad allowed 400 per piece; a jump inside a piece needs ~45 halvings, 2 intervals each

# QUADPACK's 21-point Gauss-Kronrod rule (R. Piessens et al., QUADPACK, Springer 1983, qk21.f; the
# same constants as scipy.integrate._quad_vec): Kronrod nodes, Gauss-Kronrod weights, and the
# 10-point Gauss weights of the odd-indexed nodes.
_GK_X = np.array([0.995657163025808080735527280689003, 0.973906528517171720077964012084452,
                  0.930157491355708226001207180059508, 0.865063366688984510732096688423493,
                  0.780817726586416897063717578345042, 0.679409568299024406234327365114874,
                  0.562757134668604683339000099272694, 0.433395394129247190799265943165784,
                  0.294392862701460198131126603103866, 0.148874338981631210884826001129720, 0.0])
_GK_X = np.concatenate([_GK_X, -_GK_X[-2::-1]])
_GK_WK = np.array([0.011694638867371874278064396062192, 0.032558162307964727478818972459390,
                   0.054755896574351996031381300244580, 0.075039674810919952767043140916190,
                   0.093125454583697605535065465083366, 0.109387158802297641899210590325805,
                   0.123491976262065851077958109831074, 0.134709217311473325928054001771707,
                   0.142775938577060080797094273138717, 0.147739104901338491374841515972068,
                   0.149445554002916905664936468389821])
_GK_WK = np.concatenate([_GK_WK, _GK_WK[-2::-1]])
_GK_WG = np.zeros(21)
_GK_WG[1::2] = [0.066671344308688137593568809893332, 0.149451349150580593145776339657697,
                0.219086362515982043995534934228163, 0.269266719309996355091226921569469,
                0.295524224714752870173892994651338, 0.295524224714752870173892994651338,
                0.269266719309996355091226921569469, 0.219086362515982043995534934228163,
                0.149451349150580593145776339657697, 0.066671344308688137593568809893332]

Response = Callable[[NDArray[np.float64]], ArrayLike]
"""A frequency response: f [Hz] -> H(f) (complex) or |H(f)|; only the magnitude is used."""

Psd = Callable[[NDArray[np.float64]], ArrayLike] | tuple[ArrayLike, ArrayLike]
"""A PSD: a callable f [Hz] -> S(f) [g²/Hz] (e.g. ``RandomProfile.psd``), or a table
``(f_hz, psd_g2_per_hz)`` interpolated log-log between its points (physics §3) and zero outside."""


def second_order_response(f_hz: ArrayLike, fn_hz: ArrayLike, q: ArrayLike) -> NDArray[np.complex128] | complex:
    r"""Frequency response of the proof mass: a second-order low-pass with unity DC gain.

    Parameters
    ----------
    f_hz : array_like
        Frequency >= 0 [Hz].
    fn_hz : array_like
        Natural frequency > 0 [Hz].
    q : array_like
        Quality factor > 0.

    Returns
    -------
    numpy.ndarray or complex
        :math:`H(f) = 1/(1 - r^2 + j\,r/Q)`, r = f/fn (physics §1.3). |H(fn)| = Q.

    References
    ----------
    .. [1] Analog Devices, "Vibration rectification error in MEMS accelerometers" (seed
       article), frequency dependence; physics §1.3.

    Examples
    --------
    At resonance the response is -j·Q; well below it, 1:

    >>> from vrelab.models.dynamics import second_order_response
    >>> h = second_order_response(2400.0, 2400.0, 10.0)
    >>> print(f"{abs(h):.2f}")
    10.00
    >>> print(f"{abs(second_order_response(10.0, 2400.0, 10.0)):.4f}")
    1.0000
    """
    f = _validate.non_negative("f_hz", f_hz)
    fn = _validate.positive("fn_hz", fn_hz)
    qq = _validate.positive("q", q)
    r = f / fn
    h = np.asarray(1.0 / ((1.0 - r * r) + 1j * r / qq), dtype=np.complex128)  # numpy's stubs: float64
    return h[()] if h.ndim == 0 else h


def resonator(fn_hz: float, q: float) -> Response:
    """:func:`second_order_response` as a one-argument response for :func:`effective_rms`.

    Examples
    --------
    >>> from vrelab.models.dynamics import resonator
    >>> h = resonator(2400.0, 10.0)
    >>> print(f"{abs(h(2400.0)):.2f}")
    10.00
    """
    fn = _validate.positive_scalar("fn_hz", fn_hz)
    qq = _validate.positive_scalar("q", q)

    def h(f_hz: ArrayLike) -> NDArray[np.complex128] | complex:
        return second_order_response(f_hz, fn, qq)

    h.fn_hz = fn  # type: ignore[attr-defined]  # lets effective_rms split its integral at the peak
    return h


def vrc_at_frequency(vrc: ArrayLike, f_hz: ArrayLike, fn_hz: ArrayLike, q: ArrayLike) -> NDArray[np.float64] | float:
    """Apparent VRC of a sine at ``f_hz``: VRC·|H(f)|² (the nonlinearity sees the proof mass).

    Units follow ``vrc`` (e.g. µg/g²). At f = fn this is VRC·Q² (physics §1.3).

    Examples
    --------
    A VRC of 100 µg/g² seen through a 2.4 kHz, Q = 10 proof mass: 0.3 % more at 100 Hz, Q² times
    at resonance.

    >>> from vrelab.models.dynamics import vrc_at_frequency
    >>> print(f"{vrc_at_frequency(100.0, 100.0, 2400.0, 10.0):.1f}")
    100.3
    >>> print(f"{vrc_at_frequency(100.0, 2400.0, 2400.0, 10.0):.0f}")
    10000
    """
    h2: NDArray[np.float64] = np.abs(np.asarray(second_order_response(f_hz, fn_hz, q))) ** 2  # an array, even at one f
    out = _validate.finite("vrc", vrc) * h2
    return out[()] if np.ndim(out) == 0 else out


def _magnitude2(responses: Sequence[Response], f: NDArray[np.float64]) -> NDArray[np.float64]:
    g = np.ones_like(f)
    for h in responses:
        g = g * np.abs(np.asarray(h(f))) ** 2
    return g


def _psd_callable(psd: Psd) -> tuple[Callable[[NDArray[np.float64]], NDArray[np.float64]], list[float]]:
    """The PSD as a vectorised callable, and the frequencies where it has corners."""
    if callable(psd):
        return (lambda f: np.asarray(psd(f), dtype=np.float64)), []
    try:
        f_tab, s_tab = psd
    except (TypeError, ValueError):
        raise ValueError("psd must be a callable or a (f_hz, psd_g2_per_hz) pair") from None
    f_tab = _validate.positive("psd f_hz", f_tab).ravel()
    s_tab = _validate.non_negative("psd_g2_per_hz", s_tab).ravel()
    if f_tab.size != s_tab.size or f_tab.size < 2:
        raise ValueError(f"psd table needs >= 2 matching points, got {f_tab.size} frequencies and {s_tab.size} values")
    if (np.diff(f_tab) <= 0).any():
        raise ValueError("psd f_hz must be strictly increasing")
    log_f = np.log(f_tab)
    with np.errstate(divide="ignore"):
        log_s = np.log(s_tab)

    def s(f: NDArray[np.float64]) -> NDArray[np.float64]:
        f = np.asarray(f, dtype=np.float64)
        with np.errstate(divide="ignore"):
            v = np.exp(np.interp(np.log(f), log_f, log_s))  # straight lines on log-log axes
        return np.where((f < f_tab[0]) | (f > f_tab[-1]), 0.0, v)

    return s, f_tab.tolist()


def _spectral_moment(
    psd: Psd,
    responses: Sequence[Response],
    f_lo_hz: float,
    f_hi_hz: float,
    power: int,
    points_hz: Sequence[float],
) -> float:
    """∫ f^power·S(f)·Π|H(f)|² df over [f_lo, f_hi], in ln f.

    The integrand is split at the PSD's corners and at each response's resonance (``fn_hz``
    attribute, or ``points_hz``): a Q = 1000 peak is 0.1 % wide, and no rule may step over it.
    Few pieces: adaptive Gauss-Kronrod (:func:`_adaptive_gk21`) over all of them at once. A dense table (a measured PSD, hundreds of kinks):
    10-point Gauss-Legendre on each table interval, vectorised, with the intervals around a
    resonance cut geometrically finer towards the peak (widths 1e-4..1.6 in ln f).
    """
    lo = _validate.positive_scalar("f_lo_hz", f_lo_hz)
    hi = _validate.positive_scalar("f_hi_hz", f_hi_hz)
    if hi <= lo:
        raise ValueError(f"f_hi_hz must be > f_lo_hz, got f_lo_hz={f_lo_hz!r}, f_hi_hz={f_hi_hz!r}")
    s, corners = _psd_callable(psd)
    peaks = [float(h.fn_hz) for h in responses if hasattr(h, "fn_hz")]
    peaks += [float(p) for p in points_hz]

    def integrand(f: NDArray[np.float64]) -> NDArray[np.float64]:
        return f ** (power + 1) * s(f) * _magnitude2(responses, f)

    if len(corners) <= _MAX_CORNER_SPLITS:
        cuts = sorted({lo, hi, *(p for p in [*corners, *peaks] if lo < p < hi)})
        return _adaptive_gk21(lambda u: integrand(np.exp(u)), np.log(cuts), _EPSREL)  # f·df = f^(power+1) du

    offsets = 1e-4 * 2.0 ** np.arange(15)
    near_peaks = [p * np.exp(sign * offsets) for p in peaks for sign in (-1.0, 1.0)]
    cuts_f = np.concatenate([[lo, hi], corners, peaks, *near_peaks])
    u = np.unique(np.log(cuts_f[(cuts_f >= lo) & (cuts_f <= hi)]))
    mid, half = 0.5 * (u[1:] + u[:-1]), 0.5 * (u[1:] - u[:-1])
    nodes = mid[:, None] + half[:, None] * _GL_X
    vals = integrand(np.exp(nodes).ravel()).reshape(nodes.shape)
    return float(np.sum(half * (vals @ _GL_W)))


def _gk21(g: Callable[[NDArray[np.float64]], NDArray[np.float64]], a: NDArray[np.float64],
          b: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """QUADPACK's qk21 on each interval [a_i, b_i], all in one call of ``g``: (integrals, error estimates)."""
    c, h = 0.5 * (a + b), 0.5 * (b - a)
    fv = g((c[:, None] + h[:, None] * _GK_X).ravel()).reshape(a.size, _GK_X.size)
    res_k, res_g = fv @ _GK_WK, fv @ _GK_WG
    dev = np.abs(fv - 0.5 * res_k[:, None]) @ _GK_WK * np.abs(h)  # QUADPACK's resasc
    err = np.abs((res_k - res_g) * h)
    with np.errstate(divide="ignore", invalid="ignore"):
        err = np.where((dev != 0) & (err != 0), dev * np.minimum(1.0, (200.0 * err / dev) ** 1.5), err)
    round_off = 50.0 * np.finfo(float).eps * np.abs(h) * (np.abs(fv) @ _GK_WK)
    return h * res_k, np.maximum(err, round_off)


def _adaptive_gk21(g: Callable[[NDArray[np.float64]], NDArray[np.float64]], cuts: NDArray[np.float64],
                   epsrel: float) -> float:
    """∫g over [cuts[0], cuts[-1]], split at ``cuts``, to QUADPACK's test Σ err_i <= epsrel·|I|.

    Written here because scipy offers no adaptive rule that evaluates its integrand at many
    abscissae at once: ``quad`` calls it one point at a time (80,000 Python calls in one
    README prediction), ``quad_vec`` vectorises over the integrand's outputs, not its nodes, and
    ``fixed_quad`` has no error estimate. Each round bisects, in one vectorised call, every
    interval whose error estimate exceeds its share of the tolerance (epsrel·|I| times its
    fraction of the width: while the sum is over the tolerance, one such interval exists), so
    the result meets the same bound as ``quad`` with ``epsabs=0, epsrel`` on each piece
    (Σ err_i <= epsrel·Σ|I_i| = epsrel·|I| for the non-negative spectral integrands).
    An interval stops halving at a width of a few ulps (a jump in the PSD inside a piece).
    """
    a, b = cuts[:-1], cuts[1:]
    val, err = _gk21(g, a, b)
    width = cuts[-1] - cuts[0]
    floor = 64.0 * np.finfo(float).eps * max(abs(cuts[0]), abs(cuts[-1]), 1.0)
    while True:
        tol = epsrel * abs(float(np.sum(val)))
        if float(np.sum(err)) <= tol or a.size >= _MAX_INTERVALS:
            return float(np.sum(val))
        split = (err > tol * (b - a) / width) & (b - a > floor)
        if not split.any():
            return float(np.sum(val))
        m = 0.5 * (a[split] + b[split])
        na, nb = np.concatenate([a[split], m]), np.concatenate([m, b[split]])
        nv, ne = _gk21(g, na, nb)
        keep = ~split
        a, b = np.concatenate([a[keep], na]), np.concatenate([b[keep], nb])
        val, err = np.concatenate([val[keep], nv]), np.concatenate([err[keep], ne])


def effective_rms(
    psd: Psd,
    responses: Sequence[Response] = (),
    f_lo_hz: float = 1.0,
    f_hi_hz: float = 1e5,
    points_hz: Sequence[float] = (),
) -> float:
    r"""rms of random vibration after linear stages: :math:`σ = \sqrt{\int S(f)\prod|H_i(f)|^2 df}`.

    Parameters
    ----------
    psd : callable or (f_hz, psd_g2_per_hz)
        Input PSD [g²/Hz] (see :data:`Psd`).
    responses : sequence of callables
        Frequency responses between the input and the point of interest, e.g.
        ``[resonator(2400, 7.4), anti_alias, low_pass]`` for a rail at the output (physics §1.3).
    f_lo_hz, f_hi_hz : float
        Integration band [Hz].
    points_hz : sequence of float
        Extra frequencies where the integrand has a narrow feature (responses made by
        :func:`resonator` announce theirs).

    Returns
    -------
    float
        σ [g rms].

    Notes
    -----
    Adaptive Gauss-Kronrod quadrature (QUADPACK's 21-point rule and error test, vectorised) in ln f, split at the PSD's corners and the
    resonances, to 1e-10 relative. Check: white noise S0 through :func:`second_order_response`
    gives :math:`\int_0^\infty |H|^2 df = π f_n Q/2`, so σ² = S0·π·fn·Q/2 (Miles' equation).

    References
    ----------
    .. [1] J. W. Miles, "On structural fatigue under random loading", J. Aeronautical Sciences
       21 (11), 753-762, 1954.

    Examples
    --------
    A flat PSD of 0.002 g²/Hz over 50-2000 Hz is 1.975 g rms; a 1 kHz, Q = 0.7 resonator passes less:

    >>> from vrelab.models.dynamics import effective_rms, resonator
    >>> def psd(f):
    ...     return 0.002 * ((f >= 50.0) & (f <= 2000.0))
    >>> print(f"{effective_rms(psd, (), 50.0, 2000.0):.3f} g")
    1.975 g
    >>> print(f"{effective_rms(psd, [resonator(1000.0, 0.7)], 50.0, 2000.0):.3f} g")
    1.421 g
    """
    return math.sqrt(_spectral_moment(psd, responses, f_lo_hz, f_hi_hz, 0, points_hz))


def zero_crossing_rate_hz(
    psd: Psd,
    responses: Sequence[Response] = (),
    f_lo_hz: float = 1.0,
    f_hi_hz: float = 1e5,
    points_hz: Sequence[float] = (),
) -> float:
    r"""Rate of up-crossings of the mean by Gaussian motion with this spectrum: ν0 = √(m2/m0).

    m_k = ∫ f^k·S(f)·Π|H|² df with f in Hz (so ν0 is in Hz). Arguments as in
    :func:`effective_rms`.

    References
    ----------
    .. [1] S. O. Rice, "Mathematical analysis of random noise", Bell System Technical Journal
       24, 46-156, 1945, section 3.3.

    Examples
    --------
    A flat band 50-2000 Hz crosses its mean at √((f2³ - f1³)/(3(f2 - f1))), about 1.17 kHz:

    >>> from vrelab.models.dynamics import zero_crossing_rate_hz
    >>> def psd(f):
    ...     return 0.002 * ((f >= 50.0) & (f <= 2000.0))
    >>> print(f"{zero_crossing_rate_hz(psd, (), 50.0, 2000.0):.0f} Hz")
    1169 Hz
    """
    m0 = _spectral_moment(psd, responses, f_lo_hz, f_hi_hz, 0, points_hz)
    m2 = _spectral_moment(psd, responses, f_lo_hz, f_hi_hz, 2, points_hz)
    if m0 <= 0:
        raise ValueError("psd has no power in the band: the crossing rate is undefined")
    return math.sqrt(m2 / m0)


def rms_through(freq_hz: ArrayLike, rms_g: ArrayLike, responses: Sequence[Response]) -> NDArray[np.float64] | float:
    """rms of a sine at ``freq_hz`` after linear stages: rms·Π|H_i(f)| [g].

    Examples
    --------
    A 1 g rms sine at 2.4 kHz through a 2.4 kHz, Q = 10 resonator:

    >>> from vrelab.models.dynamics import resonator, rms_through
    >>> print(f"{rms_through(2400.0, 1.0, [resonator(2400.0, 10.0)]):.2f} g")
    10.00 g
    """
    # a float passes its check without an array (a prediction asks once per site and frequency)
    f = (_validate.non_negative_scalar("freq_hz", freq_hz) if isinstance(freq_hz, float)
         else _validate.non_negative("freq_hz", freq_hz))
    rms = _validate.non_negative_scalar("rms_g", rms_g) if isinstance(rms_g, float) else _validate.non_negative("rms_g", rms_g)
    out = rms * np.sqrt(_magnitude2(responses, np.broadcast_to(f, np.broadcast(f).shape).astype(float)))
    return out[()] if np.ndim(out) == 0 else out


def rice_upcrossing_rate(
    level_g: ArrayLike, mean_g: ArrayLike, sigma_g: ArrayLike, nu0_hz: ArrayLike
) -> NDArray[np.float64] | float:
    r"""Rice's rate of up-crossings of ``level_g`` by stationary Gaussian motion [1/s].

    .. math:: ν^+(a) = ν_0 \exp\!\left(-\frac{(a-μ)^2}{2σ^2}\right)

    with ν0 the rate of up-crossings of the mean (:func:`zero_crossing_rate_hz`). By symmetry,
    the rate of down-crossings of a level below the mean is the same function of that level.
    σ = 0 gives 0 (no crossings).

    References
    ----------
    .. [1] S. O. Rice, "Mathematical analysis of random noise", Bell System Technical Journal
       23-24, 1944-1945, eq. (3.3-11).

    Examples
    --------
    Gaussian motion of 1 g rms on a 1 g field, crossing its mean 1000 times a second, passes a 3 g
    threshold exp(-2) times as often:

    >>> from vrelab.models.dynamics import rice_upcrossing_rate
    >>> print(f"{rice_upcrossing_rate(3.0, 1.0, 1.0, 1000.0):.1f} /s")
    135.3 /s
    """
    a = _validate.finite("level_g", level_g)
    mu = _validate.finite("mean_g", mean_g)
    s = _validate.non_negative("sigma_g", sigma_g)
    nu0 = _validate.non_negative("nu0_hz", nu0_hz)
    with np.errstate(divide="ignore", invalid="ignore", under="ignore"):
        z = (a - mu) / s
        out = nu0 * np.exp(-0.5 * z * z)
    out = np.where(s == 0, 0.0, out)
    return out[()] if out.ndim == 0 else out
