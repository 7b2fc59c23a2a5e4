"""The IEEE 1293 cross terms through the stages after the nonlinearity: the axis read as its stages, the rails' and holds' first-order pass (physics §1.6)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab.models.clipping import Kind as ClipKind
from vrelab.prediction._projection import resonances
from vrelab.prediction.results import LevelPrediction
from vrelab.sensor.meanshift import Response
from vrelab.triaxial.chain import CROSS_TERMS
from vrelab.triaxial.profile import TriaxialProfile

if TYPE_CHECKING:
    from vrelab.sensor import Sensor


# The model equation's cross terms (:data:`vrelab.triaxial.chain.CROSS_TERMS`, their one list),
# each with its share key: (share key, Sensor attribute, the two triad positions).
CROSS_SHARES: tuple[tuple[str, str, int, int], ...] = tuple(
    (f"cross_{attr.removesuffix('_per_g')}_g", attr, a, b) for attr, a, b in CROSS_TERMS)
# The projected PSD is taken as exact on the profile's own breakpoints where log-log
# interpolation reproduces it to this (relative) inside every segment.

# --- the axis, read as its stages ---------------------------------------------------------------


@dataclass(frozen=True)
class After:
    """A site after the nonlinearity that the cross terms' mean must pass."""

    kind: Literal["clip", "overrange"]
    stage: Any
    filtered: bool  # linear stages between the nonlinearity and it
    responses: tuple[Response, ...]  # those stages' responses
    offset_g: float  # offsets between the nonlinearity and it


def read_axis(stages: Sequence[Any]) -> tuple[list[Response], list[After]]:
    """The front end (the linear stages before the Polynomial; without one, the leading
    resonances: where the model equation's nonlinearity sits) and the sites after it."""
    from vrelab.sensor.overrange import OverRange
    from vrelab.sensor.stages import Clip, Polynomial, Resonator

    # what each stage is, asked as vrelab.predict asks it (vrelab.sensor.meanshift): a linear
    # stage has a response, an offset a static_shift_g, the rails and the holds are the sites
    poly = [k for k, s in enumerate(stages) if isinstance(s, Polynomial)]
    if len(poly) > 1:
        raise ValueError("a triaxial axis has at most one Polynomial stage")
    if poly:
        n, rest = poly[0], poly[0] + 1
    else:
        n = 0
        while n < len(stages) and isinstance(stages[n], Resonator):
            n += 1
        rest = n
    front = list(stages[:n])
    if any(not hasattr(s, "response") for s in front):
        raise ValueError("the stages before the nonlinearity must be linear (the front end): "
                         + ", ".join(type(s).__name__ for s in front))
    after: list[After] = []
    filtered, offset = False, 0.0
    between: list[Response] = []
    for s in stages[rest:]:
        if hasattr(s, "response"):
            filtered = True
            between.append(s.response)
        elif getattr(s, "static_shift_g", None) is not None:
            offset += float(s.static_shift_g)
        elif isinstance(s, (Clip, OverRange)):
            after.append(After("clip" if isinstance(s, Clip) else "overrange", s, filtered, tuple(between), offset))
    return [s.response for s in front], after


def k_matrix(sensor: Sensor) -> NDArray[np.float64]:
    """The symmetric K over x, y, z with ``bᵀ K b`` the cross terms [1/g]."""
    triad = sensor.triad
    k = np.zeros((3, 3))
    for _, attr, a, b in CROSS_SHARES:
        v = float(getattr(sensor, attr))
        j, m = triad[a], triad[b]
        k[j, m] += v / 2.0
        k[m, j] += v / 2.0
    return k



# --- the cross terms through what follows the nonlinearity ------------------------------------------


def _phi(z: float) -> float:
    return math.exp(-0.5 * z * z) / math.sqrt(2.0 * math.pi)


@dataclass(frozen=True)
class CrossMean:
    """The cross terms at one level as the rails after the nonlinearity see them: their
    rectified mean ``mean_g`` [g], the rms of their zero-mean part ``r_fluct`` and (sine) its peak
    ``q_peak``, the static cross terms ``gᵀKg`` and the sum of their He2 coefficients ``c2_total``;
    and the polynomial's move :func:`poly_move` (``poly``: its mean, rms and peak of its zero-mean
    part), which the rails see as one more small term added to their input."""

    mean_g: float
    r_fluct: float
    q_peak: float
    static_cross: float
    c2_total: float = 0.0
    poly: tuple[float, float, float] = (0.0, 0.0, 0.0)


# Gauss-Hermite nodes per dimension for poly_move: Δ² is a polynomial of degree at most 8 in two
# standard normals, which n nodes integrate exactly for 2n - 1 >= 8; the phase grid of a sine
# integrates a trigonometric polynomial of degree 8 exactly with more than 16 points.
_HERMITE_NODES = 8
_PHASES = 64


def poly_move(k: tuple[float, float, float], u0: float, moments: NDArray[np.float64],
              shape: Literal["gaussian", "sine"]) -> tuple[float, float, float]:
    r"""(mean, rms, peak) of ``Δ = R(u0 + u + L) - R(u0 + u)``, ``R(y) = k2·y² + k3·y³ + k4·y⁴``:
    what the polynomial makes of the static vector's linear cross part ``L = 2gᵀK·x``, were it fed
    through the polynomial with the sensed vibration ``u = w·x`` (as the single-axis prediction of
    ``w_eff·x``, ``w_eff = w + 2Kg``, feeds it), against the model equation, which adds it after.

    IEEE 1293's equation on ``b = g + x`` (proof mass): ``y = P(w·b) + bᵀKb = P(u0 + u) + gᵀKg
    + L + xᵀKx``; the polynomial's input is ``u0 + u`` alone. ``moments`` is the 2×2 ``E`` of
    ``(u, L)`` (Gaussian: their covariance; sine: the mean squares of two in-phase cosines, whose
    amplitudes are ``√2·sqrt(M_00)`` and ``√2·M_01/sqrt(M_00)``). Exact: Gauss-Hermite quadrature in
    two standard normals (Gaussian), a uniform phase grid (sine), both exact for these degrees.
    ``peak`` (sine: ``max|Δ - mean|``; Gaussian: 0, unbounded).
    """
    from numpy.polynomial import hermite_e

    if not any(k) or not moments[1, 1] > 0:
        return 0.0, 0.0, 0.0

    def rest(y: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.asarray(((k[2] * y + k[1]) * y + k[0]) * y * y, dtype=np.float64)

    if shape == "gaussian":
        lam, vec = np.linalg.eigh(moments)
        z, wt = hermite_e.hermegauss(_HERMITE_NODES)
        wt = wt / math.sqrt(2.0 * math.pi)
        z1, z2 = np.meshgrid(z, z, indexing="ij")
        root = vec * np.sqrt(np.maximum(lam, 0.0))  # (u, L) = root @ (z1, z2)
        u = root[0, 0] * z1 + root[0, 1] * z2
        lin = root[1, 0] * z1 + root[1, 1] * z2
        weight = np.outer(wt, wt)
        delta = rest(u0 + u + lin) - rest(u0 + u)
        mean = float(np.sum(weight * delta))
        return mean, math.sqrt(max(float(np.sum(weight * (delta - mean) ** 2)), 0.0)), 0.0
    cos = np.cos((np.arange(_PHASES) + 0.5) * 2.0 * math.pi / _PHASES)
    a_u = math.sqrt(2.0 * max(float(moments[0, 0]), 0.0))
    a_l = (2.0 * float(moments[0, 1]) / a_u if a_u > 0 else math.sqrt(2.0 * float(moments[1, 1])))
    delta = rest(u0 + (a_u + a_l) * cos) - rest(u0 + a_u * cos)
    mean = float(delta.mean())
    return mean, float(np.sqrt(np.mean((delta - mean) ** 2))), float(np.max(np.abs(delta - mean)))


def _poly_bound(poly: tuple[float, float, float], gmax: float, p_out: float, kind: ClipKind,
                rails_z: tuple[float, float] | None) -> float:
    """What the rails may do with the polynomial's move (:func:`poly_move`) beyond passing its mean
    as a static shift: its zero-mean part ``Δ'`` (rms ``ρ``, at most ``gmax·ρ`` through the filters
    between) moves the mean by ``-E[1_in·Δ']`` (censored), at most ``sqrt(p_in·p_out)·gmax·ρ``
    (Cauchy-Schwarz: ``|Cov(1_in, Δ')|``); truncated rails divide that by ``p_in`` and, Gaussian
    (``rails_z`` the rails in the Gaussian input's z), add each rail's boundary term
    ``|z_r - z̄|·φ(z_r)·|E[Δ'|z_r]|/p_in``, ``z̄ = E[Z | inside]`` and ``|E[Δ'|z]|`` at most
    ``ρ·sqrt(Σ_{n≤4} He_n(z)²/n!)`` (``Δ'`` is a polynomial of degree 4 in Gaussians: its
    projection on ``Z`` has Hermite degree at most 4). A sine's crossings: the peak, in the
    caller's bound of the terms' shift across a rail."""
    rho = gmax * poly[1]
    if not rho > 0:
        return 0.0
    p_in = max(1.0 - p_out, 1e-300)
    inner = math.sqrt(max(p_in * p_out, 0.0)) * rho
    if kind == "censored":
        return inner
    if rails_z is None:
        return inner / p_in
    a, b = rails_z
    zbar = (_phi(a) - _phi(b)) / p_in

    def h4(z: float) -> float:
        he = (z, z * z - 1.0, z**3 - 3.0 * z, z**4 - 6.0 * z * z + 3.0)
        return math.sqrt(sum(h * h / math.factorial(n + 1) for n, h in enumerate(he)))

    edges = sum(abs(z - zbar) * _phi(z) * rho * h4(z) for z in (a, b) if math.isfinite(z))
    return (inner + edges) / p_in


def rails_pass(lv: LevelPrediction | None, site: After, sensor: Sensor, u0: float, shape: Literal["gaussian", "sine"],
                kind: ClipKind, cross: CrossMean, sine_hz: float | None = None) -> tuple[float, float, float, float]:
    """(dc, factor, he2, bound): what the rails make of the cross terms, to first order in them.

    A term ``K·b_j·b_k`` reaches the rails as its mean ``C`` and a zero-mean rest. ``factor``:
    the rails' response ``∂E[out]/∂s`` to a shift ``s`` of their input, of the model
    :func:`vrelab.prediction.single.predict` takes for them (the exact memoryless map where no filter sits
    between the nonlinearity and the rails; else a Gaussian or sine of the polynomial's mean and
    its linear part through the filters). Memoryless censored rails, Gaussian: the rest's part
    that the rails see is its second Hermite component in ``Z = u/σ_u``,
    ``E[b_j b_k | u] = C + c2·He2(Z)``, ``c2 = K·v_j·v_k/σ_u²`` (``v = Cov(b, u)``), and
    ``E[1_in·He2(Z)] = α·φ(α) - β·φ(β)`` (``he2``): the term passes as ``C·factor + c2·he2``
    (with filters between, ``c2`` is :func:`filtered_he2`'s). Sine, censored: the term is
    ``C·(1 + cos 2θ)``, ``cos 2θ`` through the filters between as ``|H(2f)|·cos(2ψ + Δ)`` in the
    rails' own phase ψ (``Δ = arg H(2f) - 2·arg H(f)``), and ``E[1_in] = 1 - Σ θ_r/π``,
    ``E[1_in·cos 2ψ] = -Σ sin 2θ_r/(2π)`` over the arcs ``θ_r`` beyond each rail give
    ``factor``. Truncated rails: the rest's correlation with them is bounded, not taken. The
    bound also holds the second-order effect across a rail and the static cross terms' move of
    the rails' working point: the static cross terms ``gᵀKg`` move the reading with vibration by
    ``dc`` times them (the rails' response to a static shift) and the vibration-off reading by
    them, so they add ``gᵀKg·(dc - 1)``. The polynomial's move ``Δ`` (``cross.poly``,
    :func:`poly_move`), which the single-axis prediction of ``w_eff·x`` put into the rails'
    input, leaves it as a static shift: the caller takes ``mean·dc`` off; what its zero-mean
    part may add is bounded (:func:`_poly_bound`, and across a rail with the terms above).
    """
    from vrelab.models import memoryless
    from vrelab.sensor.meanshift import gain_max  # one rule for sup|H| of the filters between

    cross_mean, r_fluct, q_peak = cross.mean_g, cross.r_fluct, cross.q_peak
    static_cross, c2_total = cross.static_cross, cross.c2_total
    p_mean, p_rms, p_peak = cross.poly
    low, high = float(site.stage.low_g), float(site.stage.high_g)
    k = (sensor.k2_per_g, sensor.k3_per_g2, sensor.k4_per_g3)
    c0 = float(memoryless.polynomial(*k)(u0)) + site.offset_g
    if lv is None or not lv.sigma_at_clip_g > 0:
        inside = low < c0 < high
        near = min(abs(c0 - low), abs(c0 - high))
        reach = abs(cross_mean) + q_peak + abs(static_cross) + abs(p_mean) + p_peak + 4.0 * p_rms
        return (1.0 if inside else 0.0), (1.0 if inside else 0.0), 0.0, (reach if near <= reach else 0.0)
    nonlin = float(lv.shares.get("nonlinearity_g", 0.0))
    gain, rest = memoryless.linear_part(u0, lv.sigma_proof_mass_g, *k, shape=shape)
    if site.filtered:
        # the rails see a Gaussian (sine) of the polynomial's mean and its linear part through the filters
        static, sigma, kk, offset = c0 + nonlin, abs(gain) * lv.sigma_at_clip_g, (0.0, 0.0, 0.0), 0.0
    else:
        static, sigma, kk, offset = u0, lv.sigma_at_clip_g, k, site.offset_g

    def mean_out(s: float) -> float:
        vre = float(memoryless.poly_clip_vre(static, sigma, *kk, offset_g=offset + s, rail_low_g=low,
                                             rail_high_g=high, shape=shape, kind=kind))
        ref = float(memoryless.vibration_off_reading(static, *kk, offset_g=offset + s, rail_low_g=low,
                                                     rail_high_g=high))
        return vre + ref

    h = 1e-6 * max(sigma, 1e-3)
    factor = dc = (mean_out(h) - mean_out(-h)) / (2 * h)
    exact_rest = kind == "censored"
    # the rails' input, linearised: mean c0 + nonlinearity, rms s (Gaussian) or peak √2·s (sine)
    m, s = c0 + nonlin, abs(gain) * lv.sigma_at_clip_g
    a, b = (low - m) / s, (high - m) / s
    bound = 0.0
    he2 = 0.0
    # the cross terms' means, static and rectified, and the polynomial's move (poly_move)
    shift = abs(cross_mean) + abs(static_cross) + abs(p_mean)
    gmax = gain_max(site.responses)
    if shape == "gaussian":
        chaos = a * _phi(a) - b * _phi(b)
        if exact_rest:
            he2 = chaos
            # the indicator read through the linearised polynomial: its rest (rms ``rest``) moves the
            # rails' crossings by about rest/s standard deviations
            bound += r_fluct * (abs(a) + abs(b) + 2.0) * (_phi(a) + _phi(b)) * rest / s
        else:
            # the rest is in the second chaos: only the indicator's second Hermite component, of
            # norm |α·φ(α) - β·φ(β)|/√2, correlates with it (Cauchy-Schwarz within the chaos, as
            # vrelab.predict bounds the polynomial's rest); filters between pass it at most gmax times
            bound += gain_max(site.responses) * r_fluct * abs(chaos) / math.sqrt(2.0)
        # second order across a rail: ½·E[Q²|Z = z_r]·pdf(z_r)/s at each rail, with E[Q²|Z] at most
        # (|means| + |c2|·|He2(z)|)² + Var(rest); taken twice
        bound += sum(((shift + abs(c2_total) * abs(z * z - 1.0)) ** 2 + (gmax * (r_fluct + p_rms)) ** 2) * _phi(z) / s
                     for z in (a, b))
        p_out = 0.5 * math.erfc(-a / math.sqrt(2.0)) + 0.5 * math.erfc(b / math.sqrt(2.0))
        bound += _poly_bound(cross.poly, gmax, min(p_out, 1.0), kind, (a, b))
    else:
        amp = math.sqrt(2.0) * s

        def arc(x: float) -> float:  # half-arc θ of the phase beyond a rail x away from the mean
            return math.acos(max(-1.0, min(1.0, x / amp)))

        tu, tl = arc(high - m), arc(m - low)
        p_out = (tu + tl) / math.pi
        if exact_rest:
            h1 = h2f = complex(1.0)
            for r in site.responses:
                h1 *= complex(np.asarray(r(np.array([sine_hz or 0.0])))[0])
                h2f *= complex(np.asarray(r(np.array([2.0 * (sine_hz or 0.0)])))[0])
            delta = np.angle(h2f) - 2.0 * np.angle(h1)
            factor = 1.0 - p_out - abs(h2f) * math.cos(delta) * sum(math.sin(2 * t) for t in (tu, tl)) / (2 * math.pi)
        else:
            bound += r_fluct * math.sqrt(max(p_out * (1.0 - p_out), 0.0))
        bound += _poly_bound(cross.poly, gmax, p_out, kind, None)
        q = shift + q_peak + gmax * p_peak
        near = sum(abs(arc(r - q) - arc(r + q)) / math.pi for r in (high - m, m - low))
        bound += q * near
    return dc, factor, he2, bound


def he2_step(profile: TriaxialProfile, responses: Sequence[Response]) -> float:
    """The grid step of :func:`filtered_he2` [Hz]: an eighth of the band's lowest frequency and of
    every resonance's half-power width fn/Q."""
    return min([profile.band[0], *(fn / q for fn, q in resonances(responses))]) / 8.0


def filtered_he2(profile: TriaxialProfile, w: NDArray[np.float64], front: Sequence[Response],
                  between: Sequence[Response], df_hz: float | None = None) -> NDArray[np.float64]:
    r"""``G`` (3×3, per unit total mean square) with ``c2 = K_jk·G_jk``: the second Hermite
    coefficient, in ``Z`` (the rails' Gaussian input, unit variance), of the cross terms after
    the filters between the nonlinearity and the rails.

    ``Z(t) = (h_F * u)(t)/s``; the term ``b_j·b_k`` reaches the rails as ``(h_F * b_j b_k)(t)``,
    and by Isserlis ``E[(Z² - 1)·b_j(t-τ) b_k(t-τ)] = 2·c_j(τ)·c_k(τ)``, ``c_j(τ) = Cov(b_j(t-τ),
    Z(t)) = Re ∫ |H|²·(S w)_j·H_F*·e^{-i2πfτ} df / s``, so ``G_jk = ∫ h_F(τ)·c_j(τ)·c_k(τ) dτ``.
    With no filter (``h_F = δ``) this is ``v_j v_k/σ_u²``. Computed on a uniform frequency grid
    (FFT): ``c`` by an inverse FFT, ``h_F`` by one of ``H_F``'s exact samples, so the discrete sum
    is Parseval's of the grid (``c_j c_k`` reaches 2·f_max < the grid's top: no aliasing);
    ``df`` resolves the band's lowest breakpoint and every resonance's width fn/Q.
    """
    lo, hi = profile.band
    df = df_hz or he2_step(profile, [*front, *between])
    n_half = int(math.ceil(2.5 * hi / df))
    n_half += n_half % 2
    f = np.arange(n_half + 1) * df
    s_f = profile.csd(f) / profile.mean_square_g2
    s_f[(f < lo) | (f > hi)] = 0.0
    hf = np.ones(f.size, dtype=complex)
    for r in front:
        hf = hf * np.asarray(r(f.astype(np.float64)))
    hb = np.ones(f.size, dtype=complex)
    for r in between:
        hb = hb * np.asarray(r(f.astype(np.float64)))
    sw = np.abs(hf)[:, None] ** 2 * (s_f @ w)  # S_{b_j u}(f)
    var = float(np.sum(np.abs(hb) ** 2 * (sw @ w).real) * df)  # s² of h_F * u
    if not var > 0:
        return np.zeros((3, 3))
    n = 2 * n_half
    # c_j[n] = Re Σ_k A_j(f_k) e^{-i2πf_kτ_n} df = (N/2)·irfft(conj(A_j)·df) (A is 0 at DC and the top)
    a = sw * np.conj(hb)[:, None] / math.sqrt(var)
    c = 0.5 * n * np.fft.irfft(np.conj(a) * df, n=n, axis=0)  # (n, 3)
    h = n * np.fft.irfft(hb * df, n=n)  # h_F(τ_n): two-sided ∫H e^{i2πfτ} df on the grid
    dt = 1.0 / (n * df)
    return np.asarray(np.einsum("n,nj,nk->jk", h, c, c) * dt, dtype=np.float64)


def overrange_pass(lv: LevelPrediction | None, site: After, u0: float, cross_mean: float,
                    r_fluct: float) -> tuple[float, float]:
    """(factor, bound) of the over-range holds: the cross terms' mean is lost while held
    (``1 - rate·hold``); bounded: that share again, and the change of Rice's rate a shift of the
    motion's mean by the cross terms makes (∂ ln rate/∂μ = (threshold - μ)/σ²)."""
    if lv is None or not lv.sigma_proof_mass_g > 0:
        return 1.0, 0.0
    duty = min(1.0, lv.overrange_rate_hz * float(site.stage.hold_s))
    thr = float(site.stage.threshold_g)
    over = abs(float(lv.shares.get("overrange_g", 0.0)))
    bound = abs(cross_mean) * duty + over * (abs(cross_mean) + 2 * r_fluct) * (thr + abs(u0)) / lv.sigma_proof_mass_g**2
    return 1.0 - duty, bound


