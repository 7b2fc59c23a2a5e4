"""Rectification by scale-factor nonlinearity (physics §1.2): the polynomial model and VRC units.

Output normalised to g: ``y = b0 + a + k2·a² + k3·a³ + k4·a⁴ + …`` with ``a = g0 + x`` the total
input (static field plus zero-mean vibration) and ``k_n = K_n/K1`` in g^(1-n). The vibration
moves the mean output by

    VRE = Σ_n k_n·(E[(g0+x)^n] - g0^n) = Σ_n k_n·Σ_{j>=2} C(n,j)·g0^(n-j)·E[x^j],

which needs only the moments of x: :func:`gaussian_moments`, :func:`sine_moments` or
:func:`sample_moments` supply them, :func:`polynomial_vre` combines them. The VRC (vibration
rectification coefficient) is k2, quoted in µg/g² (= ppm/g); helpers convert the usual ways a
datasheet states it.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Literal, Mapping, Sequence, cast, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vrelab import _validate
from vrelab.units import from_ug, to_ug

if TYPE_CHECKING:  # imported by separate_k2_k3: the closed forms (vrelab model) need no results
    from vrelab.results import Estimate

Shape = Literal["gaussian", "sine"]


def _is_estimate(x: object) -> bool:
    return all(hasattr(x, k) for k in ("value", "u", "unit"))



# --- moments of the zero-mean vibration ----------------------------------------------------------


def _order(order: int) -> int:
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or order < 0:
        raise ValueError(f"order must be an integer >= 0, got {order!r}")
    return int(order)


def gaussian_moments(sigma_g: ArrayLike, order: int) -> NDArray[np.float64]:
    """Raw moments E[x^j], j = 0..order, of zero-mean Gaussian vibration.

    Parameters
    ----------
    sigma_g : array_like
        rms σ >= 0 [g].
    order : int
        Highest moment.

    Returns
    -------
    numpy.ndarray
        Shape ``(order + 1,) + shape(sigma_g)``; row j in g^j.

    Notes
    -----
    E[x^j] = 0 for odd j, (j-1)!!·σ^j for even j (E[x²] = σ², E[x⁴] = 3σ⁴, E[x⁶] = 15σ⁶).

    Examples
    --------
    E[x^j] of 2 g rms Gaussian vibration: 1, 0, σ², 0, 3σ⁴.

    >>> from vrelab.models.nonlinearity import gaussian_moments
    >>> print(gaussian_moments(2.0, 4))
    [ 1.  0.  4.  0. 48.]
    """
    n = _order(order)
    s = _validate.non_negative("sigma_g", sigma_g)
    out = np.zeros((n + 1,) + s.shape)
    for j in range(0, n + 1, 2):
        out[j] = _double_factorial(j - 1) * s**j
    return out


def sine_moments(rms_g: ArrayLike, order: int) -> NDArray[np.float64]:
    """Raw moments E[x^j], j = 0..order, of a sine x = A·cos θ with A = rms·√2.

    Parameters
    ----------
    rms_g : array_like
        rms of the sine >= 0 [g] (amplitude rms·√2).
    order : int
        Highest moment.

    Returns
    -------
    numpy.ndarray
        Shape ``(order + 1,) + shape(rms_g)``.

    Notes
    -----
    The period average of cos^j θ is 0 for odd j and C(j, j/2)/2^j for even j: 1/2, 3/8, 5/16, …
    So E[x²] = A²/2 = rms², E[x⁴] = 3A⁴/8 = 1.5·rms⁴ (physics §1.2).

    Examples
    --------
    E[x^j] of a 1 g rms sine (amplitude √2 g): 1, 0, rms², 0, 1.5·rms⁴.

    >>> from vrelab.models.nonlinearity import sine_moments
    >>> print(sine_moments(1.0, 4).round(12))
    [1.  0.  1.  0.  1.5]
    """
    n = _order(order)
    amp = np.sqrt(2.0) * _validate.non_negative("rms_g", rms_g)
    out = np.zeros((n + 1,) + amp.shape)
    for j in range(0, n + 1, 2):
        out[j] = math.comb(j, j // 2) / 2.0**j * amp**j
    return out


def sum_moments(moments_a: ArrayLike, moments_b: ArrayLike) -> NDArray[np.float64]:
    """Raw moments of a + b for independent a and b, from theirs (rows j = 0..order).

    ``E[(a+b)^j] = Σ_k C(j,k)·E[a^k]·E[b^(j-k)]`` (binomial theorem; independence factors
    each expectation). Both inputs need the same number of rows; the trailing dimensions broadcast.

    Examples
    --------
    Moments of a 1 g rms Gaussian plus an independent 1 g rms sine: the variances add.

    >>> from vrelab.models.nonlinearity import gaussian_moments, sine_moments, sum_moments
    >>> print(sum_moments(gaussian_moments(1.0, 2), sine_moments(1.0, 2)).round(12))
    [1. 0. 2.]
    """
    a = np.asarray(moments_a, dtype=np.float64)
    b = np.asarray(moments_b, dtype=np.float64)
    if a.shape[0] != b.shape[0]:
        raise ValueError(f"sum_moments: both need the same orders, got {a.shape[0]} and {b.shape[0]} rows")
    out = np.zeros(np.broadcast_shapes(a.shape, b.shape))
    for j in range(a.shape[0]):
        out[j] = sum(math.comb(j, k) * a[k] * b[j - k] for k in range(j + 1))
    return out


def sine_on_random_moments(sigma_g: ArrayLike, peaks_g: Sequence[float], order: int) -> NDArray[np.float64]:
    """Raw moments E[x^j], j = 0..order, of Gaussian vibration plus sine tones.

    Parameters
    ----------
    sigma_g : array_like
        rms σ >= 0 of the Gaussian part [g].
    peaks_g : sequence of float
        Tone amplitudes A_i >= 0 [g peak], each tone A_i·cos θ_i with its own phase θ_i uniform
        on [0, 2π), independent of the other tones and of the Gaussian part.
    order : int
        Highest moment.

    Returns
    -------
    numpy.ndarray
        Shape ``(order + 1,) + shape(sigma_g)``.

    Notes
    -----
    x = G + Σ A_i cos θ_i is a sum of independent terms, so its moments are the binomial
    convolution (:func:`sum_moments`) of :func:`gaussian_moments` and each tone's
    :func:`sine_moments` (E[cos^2m θ] = C(2m, m)/4^m). Odd moments vanish. The first two even ones::

        E[x²] = σ² + Σ A_i²/2,
        E[x⁴] = 3σ⁴ + 6σ²·Σ A_i²/2 + (3/8)·Σ A_i⁴ + (3/2)·Σ_{i<j} A_i²A_j²
              = 3·(E[x²])² - (3/8)·Σ A_i⁴.

    Random phases are an ensemble average. A machine's tones at harmonically related
    frequencies (f and 2f) keep a fixed relative phase, and then the time average of odd powers
    need not vanish (cos²(ωt)·cos(2ωt + φ) averages to cos(φ)/4): these moments are the
    average over that phase.

    Examples
    --------
    1 g rms Gaussian plus a tone of 1 g peak (0.5 g² of variance):

    >>> from vrelab.models.nonlinearity import sine_on_random_moments
    >>> print(sine_on_random_moments(1.0, [1.0], 2).round(12))
    [1.  0.  1.5]
    """
    n = _order(order)
    out = gaussian_moments(sigma_g, n)
    for a in _validate.non_negative("peaks_g", np.atleast_1d(np.asarray(peaks_g, dtype=np.float64))):
        out = sum_moments(out, sine_moments(a / math.sqrt(2.0), n))
    return out


def sample_moments(x_g: ArrayLike, order: int, axis: int = -1) -> NDArray[np.float64]:
    """Central moments E[(x - x̄)^j], j = 0..order, of vibration samples along ``axis``.

    The mean is removed because in the model the static part is ``g0`` and x is the zero-mean
    vibration; the j = 1 row is therefore 0.

    Returns
    -------
    numpy.ndarray
        Shape ``(order + 1,)`` + the shape of ``x_g`` without ``axis``.

    Examples
    --------
    Central moments of seeded samples of 1 g rms Gaussian vibration about 0.3 g (close to
    1, 0, 1, 0, 3; ``+ 0.0`` prints a rounded -0 as 0):

    >>> import numpy as np
    >>> from vrelab.models.nonlinearity import sample_moments
    >>> x = np.random.default_rng(0).normal(0.3, 1.0, 200_000)
    >>> print(sample_moments(x, 4).round(1) + 0.0)
    [1. 0. 1. 0. 3.]
    """
    n = _order(order)
    x = _validate.finite("x_g", x_g)
    if x.ndim == 0 or x.shape[axis] == 0:
        raise ValueError(f"x_g must hold at least one sample along axis {axis}, got shape {x.shape}")
    d = x - x.mean(axis=axis, keepdims=True)
    out = np.stack([np.mean(d**j, axis=axis) for j in range(n + 1)])
    out[1] = 0.0
    return out


def _double_factorial(m: int) -> float:
    return float(math.prod(range(m, 0, -2))) if m > 0 else 1.0


# --- the polynomial model -----------------------------------------------------------------------


def _coefficients(coeffs_k: Mapping[int, ArrayLike] | Sequence[ArrayLike]) -> dict[int, NDArray[np.float64]]:
    if isinstance(coeffs_k, Mapping):
        items = dict(coeffs_k)
    else:
        items = {n: c for n, c in enumerate(coeffs_k, start=2)}
    out = {}
    for n, c in items.items():
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 2:
            raise ValueError(f"coeffs_k: powers must be integers >= 2, got {n!r}")
        out[int(n)] = _validate.finite(f"k{n}", c)
    return out


def polynomial_vre(
    coeffs_k: Mapping[int, ArrayLike] | Sequence[ArrayLike],
    static_g: ArrayLike,
    moments: ArrayLike,
) -> NDArray[np.float64] | float:
    r"""VRE of the normalised polynomial y = b0 + a + Σ k_n·a^n, a = g0 + x.

    Parameters
    ----------
    coeffs_k : sequence or mapping
        ``(k2, k3, k4, …)`` in g^(1-n) (k2 in 1/g, k3 in 1/g², …), or a mapping ``{n: k_n}``.
    static_g : array_like
        Static acceleration along the axis g0 [g] (+1 axis up in 1 g, -1 down, 0 horizontal).
    moments : array_like
        Raw moments of the zero-mean vibration, ``moments[j] = E[x^j]`` [g^j], j = 0..order with
        order >= the highest power; the trailing dimensions broadcast with ``static_g`` and the
        coefficients (e.g. one column per vibration level).

    Returns
    -------
    numpy.ndarray or float
        VRE [g].

    Notes
    -----
    physics §1.2:

    .. math:: \mathrm{VRE} = \sum_n k_n \sum_{j=2}^{n} \binom{n}{j} g_0^{n-j} E[x^j]

    (j = 1 drops out because E[x] = 0). Leading terms:
    VRE ≈ (k2 + 3·k3·g0)·σ² + k4·(6·g0²·σ² + E[x⁴]).

    **Seed erratum**: the article writes ``VRE = 0 - ā0 - K0 ≈ K2·Grms²``; the rectified shift is
    ``ā0 - K0 = K2·Grms²`` in LSB, i.e. k2·Grms² in g, and the article omits the g0 terms: in a
    1 g field the cubic term rectifies too (3·k3·g0·σ²).

    References
    ----------
    .. [1] Analog Devices, "Vibration rectification error in MEMS accelerometers" (seed
       article), with the corrections of physics §1.2.
    .. [2] IEEE Std 1293-1998, IEEE Standard Specification Format Guide and Test Procedure for
       Linear, Single-Axis, Nongyroscopic Accelerometers (VRC definition and sine method).

    Examples
    --------
    VRE of k2 = 100 µg/g² (1e-4 /g) at 2 g rms of Gaussian vibration, on no static field: k2·σ².

    >>> from vrelab.models.nonlinearity import gaussian_moments, polynomial_vre
    >>> vre_g = polynomial_vre({2: 1e-4}, 0.0, gaussian_moments(2.0, 2))
    >>> print(f"{vre_g * 1e3:.2f} mg")
    0.40 mg
    """
    k = _coefficients(coeffs_k)
    g0 = _validate.finite("static_g", static_g)
    m = _validate.finite("moments", moments)
    if m.ndim == 0:
        raise ValueError("moments must be an array of E[x^j], j = 0..order")
    top = max(k, default=2)
    if m.shape[0] <= top:
        raise ValueError(f"moments: need E[x^j] up to j = {top}, got up to j = {m.shape[0] - 1}")
    total: NDArray[np.float64] | float = 0.0
    for n, kn in k.items():
        inner = sum(math.comb(n, j) * g0 ** (n - j) * m[j] for j in range(2, n + 1))
        total = total + kn * inner
    out = np.asarray(total, dtype=np.float64)
    return out[()] if out.ndim == 0 else out


def vre_poly(
    rms_g: ArrayLike,
    k2_per_g: ArrayLike,
    k3_per_g2: ArrayLike = 0.0,
    k4_per_g3: ArrayLike = 0.0,
    static_g: ArrayLike = 0.0,
    shape: Shape = "gaussian",
    tone_peaks_g: Sequence[float] = (),
) -> NDArray[np.float64] | float:
    """VRE of the polynomial nonlinearity up to k4 for Gaussian or sine vibration of rms ``rms_g``.

    Parameters
    ----------
    rms_g : array_like
        Vibration rms [g] (for a sine, amplitude = rms·√2); with ``tone_peaks_g``, the rms of
        the Gaussian part alone.
    k2_per_g, k3_per_g2, k4_per_g3 : array_like
        Normalised coefficients [1/g, 1/g², 1/g³]; k2 is the VRC (1 µg/g² = 1e-6 /g).
    static_g : array_like
        Static field along the axis g0 [g].
    shape : {"gaussian", "sine"}
    tone_peaks_g : sequence of float
        Sine tones on the Gaussian vibration (sine-on-random), amplitudes [g peak]; shape must
        then be "gaussian". Their moments: :func:`sine_on_random_moments`.

    Returns
    -------
    numpy.ndarray or float
        VRE [g] = (k2 + 3·k3·g0)·E[x²] + k4·(6·g0²·E[x²] + E[x⁴]) with E[x⁴] = 3·rms⁴
        (Gaussian), 1.5·rms⁴ (sine) or that of :func:`sine_on_random_moments`; see
        :func:`polynomial_vre`. Exact for this polynomial: no other moment enters.

    Examples
    --------
    k2 = 100 µg/g² and k3 = 20 µg/g³ on a 1 g field at 2 g rms: k2·σ² plus k3's 3·g0·σ².

    >>> from vrelab.models.nonlinearity import vre_poly
    >>> print(f"{vre_poly(2.0, 1e-4, 2e-5, static_g=1.0) * 1e3:.3f} mg")
    0.640 mg
    """
    _validate.one_of("shape", shape, ("gaussian", "sine"))
    rms = _validate.non_negative("rms_g", rms_g)
    if len(tone_peaks_g):
        if shape != "gaussian":
            raise ValueError(f"tone_peaks_g ride on Gaussian vibration: shape must be 'gaussian', got {shape!r}")
        moments = sine_on_random_moments(rms, tone_peaks_g, 4)
    else:
        moments = (gaussian_moments if shape == "gaussian" else sine_moments)(rms, 4)
    return polynomial_vre((k2_per_g, k3_per_g2, k4_per_g3), static_g, moments)


# --- VRC units ----------------------------------------------------------------------------------


def ug_per_g2_to_per_g(vrc_ug_per_g2: ArrayLike) -> NDArray[np.float64] | float:
    """VRC in µg/g² (= ppm/g) to the normalised k2 in 1/g (:func:`vrelab.units.from_ug`).

    Examples
    --------
    >>> from vrelab.models.nonlinearity import ug_per_g2_to_per_g
    >>> print(ug_per_g2_to_per_g(100.0))
    0.0001
    """
    return _out(from_ug(_validate.finite("vrc_ug_per_g2", vrc_ug_per_g2)))


def per_g_to_ug_per_g2(k2_per_g: ArrayLike) -> NDArray[np.float64] | float:
    """Normalised k2 in 1/g to the VRC in µg/g² (= ppm/g) (:func:`vrelab.units.to_ug`).

    Examples
    --------
    >>> from vrelab.models.nonlinearity import per_g_to_ug_per_g2
    >>> print(f"{per_g_to_ug_per_g2(1e-4):.1f} µg/g²")
    100.0 µg/g²
    """
    return _out(to_ug(_validate.finite("k2_per_g", k2_per_g)))


def ppm_per_g_to_ug_per_g2(vrc_ppm_per_g: ArrayLike) -> NDArray[np.float64] | float:
    """ppm/g and µg/g² are the same unit (1 ppm of 1 g per g of vibration² = 1 µg/g²).

    Examples
    --------
    >>> from vrelab.models.nonlinearity import ppm_per_g_to_ug_per_g2
    >>> print(ppm_per_g_to_ug_per_g2(40.0))
    40.0
    """
    return _out(_validate.finite("vrc_ppm_per_g", vrc_ppm_per_g))


def ug_per_g2_from_ppm_fs(nonlinearity_ppm_fs: ArrayLike, full_scale_g: ArrayLike) -> NDArray[np.float64] | float:
    """k2 in µg/g² from a quadratic nonlinearity quoted in ppm of full scale: divide by full scale.

    Parameters
    ----------
    nonlinearity_ppm_fs : array_like
        The deviation at full-scale input, k2·FS², expressed in ppm of FS [ppm FS].
    full_scale_g : array_like
        Full scale FS > 0 [g].

    Returns
    -------
    numpy.ndarray or float
        k2 [µg/g²] = ppm_FS / FS: k2·FS² = ppm·1e-6·FS, so k2 = ppm·1e-6/FS per g.

    Notes
    -----
    physics §1.2: a "ppm of full scale" figure must first be divided by the full scale. This assumes
    the whole nonlinearity is quadratic and quoted as the end-point deviation at full scale; a
    figure against a best-fit line, or one that includes a cubic term, bounds k2 only roughly.
    Example: 0.1 % FS (1000 ppm FS) on ±2 g gives at most 500 µg/g².

    Examples
    --------
    A quadratic nonlinearity of 100 ppm of a 2 g full scale:

    >>> from vrelab.models.nonlinearity import ug_per_g2_from_ppm_fs
    >>> print(ug_per_g2_from_ppm_fs(100.0, 2.0))
    50.0
    """
    fs = _validate.positive("full_scale_g", full_scale_g)
    return _out(_validate.finite("nonlinearity_ppm_fs", nonlinearity_ppm_fs) / fs)


def vrc_ug_per_g2_from_vre(vre_g: ArrayLike, rms_g: ArrayLike) -> NDArray[np.float64] | float:
    """VRC [µg/g²] from a quoted "VRE at a vibration level": VRC = VRE/rms², VRE in g.

    "X mg at Y g rms" → ``vrc_ug_per_g2_from_vre(X·1e-3, Y)`` = 1e3·X/Y² µg/g². Only meaningful
    below clipping, where VRE grows as rms² (physics §1.2).

    Examples
    --------
    A datasheet's "VRE of 2 mg at 5 g rms":

    >>> from vrelab.models.nonlinearity import vrc_ug_per_g2_from_vre
    >>> print(f"{vrc_ug_per_g2_from_vre(2e-3, 5.0):.1f} µg/g²")
    80.0 µg/g²
    """
    rms = _validate.positive("rms_g", rms_g)
    return _out(to_ug(_validate.finite("vre_g", vre_g) / rms**2))


@overload
def separate_k2_k3(vrc_plus: Estimate, vrc_minus: Estimate, static_g: float = 1.0,
                   static_minus_g: float | None = None) -> tuple[Estimate, Estimate]: ...
@overload
def separate_k2_k3(vrc_plus: ArrayLike, vrc_minus: ArrayLike, static_g: float = 1.0,
                   static_minus_g: float | None = None) -> tuple[NDArray[np.float64] | float, NDArray[np.float64] | float]: ...
def separate_k2_k3(vrc_plus: Estimate | ArrayLike, vrc_minus: Estimate | ArrayLike, static_g: float = 1.0,
                   static_minus_g: float | None = None) -> Any:
    """Separate k2 and k3 from VRCs measured at two orientations (physics §1.2).

    Parameters
    ----------
    vrc_plus, vrc_minus : Estimate or array_like
        Apparent VRC (VRE/rms²) with the axis at ``static_g`` and at ``static_minus_g``, any
        unit U (e.g. µg/g²). Estimates carry a standard uncertainty; the two are taken as
        independent.
    static_g : float
        g₊ [g]: 1 for the usual up/down test (> 0 when ``static_minus_g`` is not given).
    static_minus_g : float, optional
        g₋ [g], < g₊; default ``-static_g``.

    Returns
    -------
    (k2, k3)
        ``k3 = (VRC₊ - VRC₋)/(3·(g₊ - g₋))`` in U/g (µg/g³ for µg/g² input) and
        ``k2 = VRC₊ - 3·k3·g₊ = VRC₊·(1 - c) + VRC₋·c``, ``c = g₊/(g₊ - g₋)``, in U; at ±g0
        these are k2 = (VRC₊ + VRC₋)/2 and k3 = (VRC₊ - VRC₋)/(6·g0). For Estimates the
        uncertainties propagate through these linear maps: u(k2) = √((1-c)²u₊² + c²u₋²),
        u(k3) = √(u₊² + u₋²)/(3·(g₊ - g₋)) (:func:`k2_k3_covariance` gives their covariance).

    Notes
    -----
    VRC(g0) = k2 + 3·k3·g0 (the g0 term of :func:`polynomial_vre` for n = 3), so two
    orientations determine both. A k4 term adds 6·k4·g0² + 3·k4·σ² to both orientations
    alike (at ±g0) and ends up in k2.

    Examples
    --------
    VRCs of 130 µg/g² axis up and 70 µg/g² axis down (±1 g) give k2 = 100 µg/g² and
    k3 = 10 µg/g³ (VRC = k2 ± 3·k3):

    >>> from vrelab.models.nonlinearity import separate_k2_k3
    >>> k2, k3 = separate_k2_k3(130.0, 70.0)
    >>> print(f"{float(k2):.1f} {float(k3):.1f}")
    100.0 10.0
    """
    if static_minus_g is None:
        gp = _validate.positive_scalar("static_g", static_g)
        gm = -gp
    else:
        gp = _validate.finite_scalar("static_g", static_g)
        gm = _validate.finite_scalar("static_minus_g", static_minus_g)
    if not gm < gp:
        raise ValueError(f"static_minus_g must be below static_g, got {gm!r} and {gp!r}")
    d = 3.0 * (gp - gm)
    c = gp / (gp - gm)
    # an Estimate is read by its fields (value, u, unit) and the result built by its own type:
    # the closed forms import nothing from vrelab.results, which builds on them
    if _is_estimate(vrc_plus) or _is_estimate(vrc_minus):
        if not (_is_estimate(vrc_plus) and _is_estimate(vrc_minus)):
            raise ValueError("separate_k2_k3: give both VRCs as Estimate, or both as numbers")
        a, b = cast("Estimate", vrc_plus), cast("Estimate", vrc_minus)
        if a.unit != b.unit:
            raise ValueError(f"separate_k2_k3: units differ, {a.unit!r} vs {b.unit!r}")
        est = type(a)
        k2 = est(a.value * (1 - c) + b.value * c, math.hypot(a.u * (1 - c), b.u * c), a.unit)
        k3 = est((a.value - b.value) / d, math.hypot(a.u, b.u) / d, f"{a.unit}/g")
        return k2, k3
    p = _validate.finite("vrc_plus", cast(ArrayLike, vrc_plus))
    m = _validate.finite("vrc_minus", cast(ArrayLike, vrc_minus))
    return _out(p * (1 - c) + m * c), _out((p - m) / d)


def k2_k3_covariance(u_plus: float, u_minus: float, static_g: float = 1.0, static_minus_g: float | None = None) -> float:
    """cov(k2, k3) of :func:`separate_k2_k3` from independent VRC uncertainties [U²/g].

    ``k2 = (1-c)·VRC₊ + c·VRC₋`` and ``k3 = (VRC₊ - VRC₋)/d`` share both inputs:
    ``cov = ((1-c)·u₊² - c·u₋²)/d`` (0 at ±g0 with equal uncertainties).

    Examples
    --------
    Two VRCs each known to 5 µg/g² at ±1 g: k2 = (p + m)/2 and k3 = (p - m)/6 are uncorrelated
    when the two are equally certain, and correlated when not:

    >>> from vrelab.models.nonlinearity import k2_k3_covariance
    >>> print(f"{k2_k3_covariance(5.0, 5.0):.2f}")
    0.00
    >>> print(f"{k2_k3_covariance(5.0, 2.0):.2f}")
    1.75
    """
    gp = float(static_g)
    gm = -gp if static_minus_g is None else float(static_minus_g)
    d = 3.0 * (gp - gm)
    c = gp / (gp - gm)
    return ((1 - c) * u_plus**2 - c * u_minus**2) / d


def _out(x: NDArray[np.float64]) -> NDArray[np.float64] | float:
    x = np.asarray(x, dtype=np.float64)
    return x[()] if x.ndim == 0 else x
