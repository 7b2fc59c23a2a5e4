"""The standard uncertainty of a predicted VRE from the sensor's parameter uncertainties (physics §6.1, GUM and its Supplement 1)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab.models.clipping import Kind as ClipKind
from vrelab.models.kinds import DEFAULT_CLIP_KIND
from vrelab.prediction.checks import TOLERANCE_ABS_G, TOLERANCE_REL
from vrelab.prediction.results import LevelPrediction, Prediction
from vrelab.profiles import RandomProfile, SineOnRandom

if TYPE_CHECKING:
    from vrelab.sensor import Sensor


@dataclass(frozen=True)
class Propagation:
    """The standard uncertainty of each predicted VRE from the sensor's parameter uncertainties,
    by source (see :func:`propagation`).

    Examples
    --------
    What :func:`propagation` returns: each level's u and each source's share of it.

    >>> import vrelab
    >>> from vrelab.prediction.propagation import propagation
    >>> from vrelab.prediction.single import predict
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> result = propagation(sensor, 100.0, [2.0], 1.0, predictor=predict)
    >>> largest = max(result.sources_g, key=lambda name: result.sources_g[name][0])
    >>> print(f"u {result.u_g[0] * 1e3:.1f} mg, largest share: {largest}")
    u 1.9 mg, largest share: anti_alias_order
    """

    u_g: NDArray[np.float64]  # per level, every source combined
    sources_g: Mapping[str, NDArray[np.float64]]  # per source, its u per level (in quadrature: u_g)
    level_notes: tuple[tuple[str, ...], ...]  # per level: why the u is not a claim (empty: it is)
    notes: tuple[str, ...]  # which sources dominate

    def applied(self, levels: Sequence[LevelPrediction]) -> list[LevelPrediction]:
        """The levels with their u, u by source, and validity and notes where the u is no claim."""
        return [dataclasses.replace(lv, u_vre_g=float(self.u_g[i]),
                                    u_sources_g={k: float(v[i]) for k, v in self.sources_g.items()},
                                    valid=lv.valid and not self.level_notes[i],
                                    notes=lv.notes + self.level_notes[i]) for i, lv in enumerate(levels)]


# The propagation is linear where the VRE moved by ±u of a parameter departs from the tangent by
# less than this fraction of the tangent's step; beyond, u_vre_g is not a claim (valid False).
_LINEAR = 0.3
# A source is named as dominant in the notes above this share of u².
_DOMINANT = 0.25
IDENTIFIED = "identified (covariance)"


def propagation(sensor: Sensor, excitation: RandomProfile | SineOnRandom | float | Sequence[float],
                levels: Sequence[float] | NDArray[np.float64], static_g: float,
                kind: ClipKind = DEFAULT_CLIP_KIND, vre_g: NDArray[np.float64] | None = None, *,
                predictor: Callable[..., Prediction]) -> Propagation:
    r"""Standard uncertainty [g] of each predicted VRE from the sensor's parameter uncertainties.

    Two sources (physics §6.1): the identified parameters' covariance ``Σ`` (``sensor.covariance``)
    and the assumed standard uncertainties of parameters no campaign measured
    (``sensor.uncertainty``: a datasheet tolerance, a base sensor's filter corner), independent
    of each other and of ``Σ``. Linear propagation (GUM 5.1.2): ``u² = J·Σ·Jᵀ + Σ_a (J_a·u_a)²``
    with ``J[i, j] = ∂VRE_i/∂θ_j`` by central differences of :func:`predict` itself, each step a
    tenth of the parameter's standard uncertainty. The tests hold it against a Monte Carlo over
    ``Σ`` and one over a preset's assumptions (GUM Supplement 1).

    A filter order (a whole number: the filter's shape, which a datasheet rarely gives) has a
    span of orders as its u: its share is the larger move of the VRE to an end of the span.

    Linearity is checked, not assumed: the VRE is also evaluated at ``θ_j ± u_j``; where it
    departs from the tangent by more than ``_LINEAR`` of the tangent's step, or where ``θ ± u``
    leaves the parameter's domain (a Q whose u exceeds it), an assumed parameter's share is
    taken as the larger move (``max |VRE(θ ± u) − VRE(θ)|``, GUM 5.1.3's note), and the
    identified block is propagated by a Monte Carlo over ``Σ`` instead (GUM Supplement 1,
    :func:`_monte_carlo`); where more than ``_MC_OUTSIDE`` of its draws leave the parameters'
    domain (a Q whose u exceeds it: the campaign does not bound it) the level's u is no claim:
    ``valid`` False with a note. The assumed parameters in which the VRE is curved (a rail or a
    threshold at the edge of clipping) are cross-checked the same way, by a Monte Carlo over them
    (:func:`_assumed_monte_carlo`): where their spread exceeds the shares, the excess enters as
    its own source with a note.

    ``sources_g``: ``"identified (covariance)"`` (the covariance block, correlations in it) and
    one entry per assumed parameter; their quadrature sum is ``u_g``. ``vre_g``: the VRE already
    predicted at the parameters' values, one per predicted level (saves predicting it again).
    ``predictor``: what is propagated, called as the single-axis
    :func:`vrelab.prediction.single.predict` is (which passes itself; the triaxial prediction
    passes its own, so one rule carries both: given, not imported, as the predictions import this
    module).

    Examples
    --------
    The ADXL355 at ±2 g under a 2 g rms sine at 100 Hz on a 1 g field: u of the VRE from the
    preset's stated ranges, source by source.

    >>> import vrelab
    >>> from vrelab.prediction.propagation import propagation
    >>> from vrelab.prediction.single import predict
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> result = propagation(sensor, 100.0, [2.0], 1.0, predictor=predict)
    >>> for name, u in sorted(result.sources_g.items(), key=lambda item: -item[1][0])[:2]:
    ...     print(f"{name}: {u[0] * 1e3:.2f} mg")
    anti_alias_order: 1.85 mg
    k3_ug_per_g3: 0.27 mg
    """
    from vrelab.sensor.parameters import parameter, with_parameters

    cov = getattr(sensor, "covariance", None)
    assumed = dict(getattr(sensor, "uncertainty", None) or {})
    if not cov and not assumed:
        raise ValueError(f"sensor {sensor.name} carries no parameter uncertainty (an identified sensor file's "
                         "covariance, or a file's [uncertainty] table)")
    lv = np.atleast_1d(np.asarray(levels, dtype=np.float64))

    def vre_at(values: Mapping[str, float]) -> NDArray[np.float64] | None:
        try:
            p = predictor(with_parameters(sensor, values), excitation, lv, static_g, kind)
        except ValueError:  # outside the parameter's domain (rails crossing the static level, Q <= 0)
            return None
        return np.array([x.vre_g for x in p.levels])

    # the VRE at the parameters' values: the caller's prediction when it has one (predict), else computed
    f0 = vre_at({}) if vre_g is None else np.asarray(vre_g, dtype=np.float64)
    assert f0 is not None
    # one VRE per predicted level: a sine at several frequencies predicts each level at each of them
    n_out = f0.size
    names = list(cov["params"]) if cov else []
    sigma = np.asarray(cov["matrix"], dtype=np.float64) if cov else np.zeros((0, 0))
    everything = [(n, math.sqrt(sigma[j, j]), True) for j, n in enumerate(names)] + [(n, u, False) for n, u in assumed.items()]
    jac = np.zeros((n_out, len(names)))
    sources: dict[str, NDArray[np.float64]] = {}
    level_notes: list[list[str]] = [[] for _ in range(n_out)]
    nonlinear = np.zeros(n_out, dtype=bool)
    bent_why: list[str] = []
    # assumed parameters whose VRE is not linear over their u: their shares are cross-checked by a
    # Monte Carlo over them (_assumed_monte_carlo)
    curved: dict[str, float] = {}
    for j, (name, u, identified) in enumerate(everything):
        x = parameter(sensor, name)
        if x is None or not u > 0:
            continue
        if _whole_valued(name):  # a filter order (its shape): the VRE at the span's ends, no tangent
            span = max(1, round(u))
            ends_k = [vre_at({name: k}) for k in _orders(x, span, name)]
            if any(e is None for e in ends_k) or not ends_k:
                for i in range(n_out):
                    level_notes[i].append(f"the VRE cannot be evaluated over {name} {x:g} ± {span}: u_vre_g is not a claim")
                continue
            # the larger move to an end: for a VRE monotone in the order, at least the spread of the
            # orders drawn uniformly over the span (what the tests' Monte Carlo draws)
            sources[name] = np.max([np.abs(e - f0) for e in ends_k if e is not None], axis=0)
            continue
        ends = [vre_at({name: x + s}) for s in (0.1 * u, -0.1 * u)]
        if ends[0] is None or ends[1] is None:
            d = np.zeros(n_out)
            for i in range(n_out):
                level_notes[i].append(f"the VRE cannot be evaluated at {name} ± 0.1·u: u_vre_g is not a claim")
        else:
            d = (ends[0] - ends[1]) / (0.2 * u)
        wide = [vre_at({name: x + s}) for s in (u, -u)]
        step = np.abs(d) * u
        if wide[0] is None or wide[1] is None:
            bent = np.ones(n_out, dtype=bool)
            move = step
            why = f"{name} ± u ({x:.4g} ± {u:.2g}) leaves the parameter's domain"
            if not identified:  # an assumption that wide says the element is barely known: no u to claim
                for i in range(n_out):
                    level_notes[i].append(f"{why}: the VRE over that range is not known — u_vre_g is not a claim")
        else:
            curve = np.abs(wide[0] + wide[1] - 2 * f0) / 2
            bent = curve > _LINEAR * np.maximum(step, 1e-15)
            move = np.maximum(step, np.maximum(np.abs(wide[0] - f0), np.abs(wide[1] - f0)))
            why = f"the VRE is not linear in {name} over its u ({x:.4g} ± {u:.2g})"
        if identified:
            jac[:, j] = d
            nonlinear |= bent & (move > 0)
            if (bent & (move > 0)).any():
                bent_why.append(why)
        else:
            sources[name] = np.where(bent, move, step)
            if (bent & (move > 0)).any() and wide[0] is not None and wide[1] is not None:
                curved[name] = u
    notes: list[str] = []
    # the Monte Carlo only where the curved parameters weigh: above _CURVED_SHARE of the assumed u²
    # at some level (a curve in a parameter that moves the VRE by a hundredth of the rest is not
    # worth 60 predictions; the larger move at ±u stands for it)
    assumed_u2 = sum((v**2 for v in sources.values()), np.zeros(n_out))
    weigh = sum((sources[n] ** 2 for n in curved), np.zeros(n_out))
    if curved and np.any(weigh > _CURVED_SHARE * assumed_u2):
        _assumed_monte_carlo(_Problem(sensor, excitation, lv, static_g, kind, predictor), curved, sources, level_notes,
                             notes)
    if names:
        problem = _Problem(sensor, excitation, lv, static_g, kind, predictor)
        sources = {IDENTIFIED: _identified_u(problem, names, sigma, jac, nonlinear, bent_why, level_notes, notes),
                   **sources}
    return _propagated(sources, names, assumed, level_notes, notes, n_out)


# Monte Carlo propagation where the linear one fails: draws, and the fraction of draws outside the
# parameters' domain (Q <= 0, rails crossing the static field) beyond which u is no claim.
_MC_DRAWS = 200
_MC_OUTSIDE = 0.15
# The assumed parameters' Monte Carlo (where the VRE is curved in them): fewer draws (each is a
# prediction; the standard deviation of 60 normal draws is known to ±9 %, enough to see an
# understatement by the tangent), and the source's name in u_sources_g.
_MC_ASSUMED_DRAWS = 60
CURVED_SOURCE = "assumed, beyond the tangent (Monte Carlo)"
_CURVED_SHARE = 0.01


def _whole_valued(name: str) -> bool:
    """Whether the assumable parameter ``name`` takes whole values only (a filter order)."""
    from vrelab.sensor.parameters import ASSUMABLE

    p = ASSUMABLE.get(name)
    return bool(p is not None and p.integer)


def _orders(x: float, span: int, name: str) -> list[int]:
    """The ends of a filter order's span ``x ± span``, within the orders the field allows (1 to its upper bound)."""
    from vrelab.sensor.parameters import ASSUMABLE

    top = int(ASSUMABLE[name].upper or 12)
    return sorted({min(max(int(round(x)) + s, 1), top) for s in (-span, span)} - {int(round(x))})


def _identified_u(problem: _Problem, names: Sequence[str], sigma: NDArray[np.float64], jac: NDArray[np.float64],
                  nonlinear: NDArray[np.bool_], bent_why: list[str], level_notes: list[list[str]],
                  notes: list[str]) -> NDArray[np.float64]:
    """The identified block's u per level: ``sqrt(J·Σ·Jᵀ)``, or the Monte Carlo's over ``Σ``
    (:func:`_monte_carlo`) at the levels where the VRE is not linear in the parameters."""
    u_cov = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", jac, sigma, jac), 0.0))
    if nonlinear.any():
        u_mc, outside, lo95, hi95 = _monte_carlo(problem.sensor, problem.excitation, problem.levels,
                                                  problem.static_g, problem.kind, names, sigma, problem.predictor)
        for i in np.flatnonzero(nonlinear).tolist():
            if outside > _MC_OUTSIDE:
                level_notes[i].append(f"{'; '.join(bent_why)}; a Monte Carlo over the covariance leaves the "
                                      f"parameters' domain in {100 * outside:.0f} % of draws: u_vre_g is not a claim "
                                      "(the campaign does not bound these parameters)")
            else:
                u_cov[i] = u_mc[i]
        if outside <= _MC_OUTSIDE:
            notes.append(f"u_vre_g of the identified parameters by Monte Carlo over their covariance (GUM S1, "
                         f"{_MC_DRAWS} seeded draws; {100 * outside:.0f} % outside the parameters' domain dropped) "
                         f"where the VRE is not linear in them ({'; '.join(bent_why)}); 95 % intervals "
                         + ", ".join(f"[{1e3 * a:.4g}, {1e3 * b:.4g}] mg" for a, b in zip(lo95, hi95)))
    return np.asarray(u_cov, dtype=np.float64)


def _propagated(sources: dict[str, NDArray[np.float64]], names: Sequence[str], assumed: Mapping[str, float],
                level_notes: list[list[str]], notes: list[str], n_out: int) -> Propagation:
    """The sources combined in quadrature, with the notes saying which were carried and which dominate."""
    u2 = sum((v**2 for v in sources.values()), np.zeros(n_out))
    if names:
        notes.append("u_vre_g: the identified parameters' covariance (" + ", ".join(names) + ") carried by linear "
                     "propagation; the model's own approximations are not in it")
    if assumed:
        notes.append("u_vre_g carries the assumed uncertainties of parameters no measurement fixed ("
                     + ", ".join(f"{n} ± {u:.3g}" for n, u in assumed.items()) + ", the sensor file's [uncertainty])")
    share = {k: float(np.max(np.where(u2 > 0, v**2 / np.where(u2 > 0, u2, 1.0), 0.0))) for k, v in sources.items()}
    top = sorted((k for k in share if share[k] >= _DOMINANT), key=lambda k: -share[k])
    if top:
        notes.append("u_vre_g dominated by " + ", ".join(f"{'assumed ' if k not in (IDENTIFIED, CURVED_SOURCE) else ''}{k} "
                                                          f"(up to {100 * share[k]:.0f} % of u²)" for k in top)
                     + "; per source in u_sources_g")
    return Propagation(np.sqrt(u2), sources, tuple(tuple(n) for n in level_notes), tuple(notes))


@dataclass(frozen=True)
class _Problem:
    """What is propagated: ``predictor(sensor, excitation, levels, static_g, kind)``, the
    prediction whose parameters are moved."""

    sensor: Any
    excitation: Any
    levels: NDArray[np.float64]
    static_g: float
    kind: ClipKind
    predictor: Callable[..., Prediction]


def _assumed_monte_carlo(problem: _Problem, curved: Mapping[str, float], sources: dict[str, NDArray[np.float64]],
                         level_notes: list[list[str]], notes: list[str]) -> None:
    """Cross-check the shares of the assumed parameters in which the VRE is curved (GUM
    Supplement 1): ``_MC_ASSUMED_DRAWS`` seeded joint draws, each parameter independent and
    uniform: over the bound ``±√3·u`` its assumed standard uncertainty stands for (an assumption
    or a datasheet tolerance is a bound, read as rectangular: GUM 4.3.7, GUM S1 6.4.2; the
    presets write u = a/√3 for a bound ±a) or, for a filter order, over the whole orders of its
    span; :func:`predict` at
    each. Where the draws' standard deviation exceeds the quadrature sum of those parameters'
    shares (the tangent, or the larger move at ±u), the excess enters ``sources`` as
    :data:`CURVED_SOURCE` (so ``u_vre_g`` is the Monte Carlo's) with a note; where more than
    ``_MC_OUTSIDE`` of the draws leave the parameters' domain, the level's u is no claim."""
    from vrelab.sensor.parameters import parameter, with_parameters

    sensor, excitation, levels, static_g, kind = problem.sensor, problem.excitation, problem.levels, problem.static_g, problem.kind
    predictor = problem.predictor
    rng = np.random.default_rng(20261128)
    names = list(curved)
    centre = {n: float(parameter(sensor, n) or 0.0) for n in names}
    vre = []
    for _ in range(_MC_ASSUMED_DRAWS):
        point = {}
        for n in names:
            if _whole_valued(n):
                span = int(curved[n])
                lo = max(1, int(round(centre[n])) - span)
                point[n] = float(rng.integers(lo, int(round(centre[n])) + span + 1))
            else:  # the bound ±√3·u the u stands for (GUM 4.3.7), uniform within it
                half = math.sqrt(3.0) * curved[n]
                point[n] = float(rng.uniform(centre[n] - half, centre[n] + half))
        try:
            p = predictor(with_parameters(sensor, point), excitation, levels, static_g, kind)
        except ValueError:  # outside the parameters' domain (a rail across the static field, Q <= 0)
            continue
        vre.append([x.vre_g for x in p.levels])
    n_out = len(level_notes)
    outside = 1.0 - len(vre) / _MC_ASSUMED_DRAWS
    what = ", ".join(names)
    if outside > _MC_OUTSIDE or len(vre) < 2:
        for i in range(n_out):
            level_notes[i].append(f"a Monte Carlo over the assumed {what} leaves their domain in {100 * outside:.0f} % "
                                  "of draws: the VRE over their stated u is not known — u_vre_g is not a claim")
        return
    v = np.asarray(vre, dtype=np.float64)
    spread = v.std(axis=0, ddof=1)
    tangent = np.sqrt(sum((sources[n] ** 2 for n in names), np.zeros(n_out)))
    excess = np.sqrt(np.maximum(spread**2 - tangent**2, 0.0))
    if np.any(excess > 0):
        sources[CURVED_SOURCE] = excess
        worst = int(np.argmax(spread - tangent))
        notes.append(f"the VRE is curved in the assumed {what}: the linearised propagation understates its spread "
                     f"over their u; a Monte Carlo ({len(vre)} seeded draws, GUM S1) gives "
                     f"{1e3 * spread[worst]:.4g} mg against the tangent's {1e3 * tangent[worst]:.4g} mg: u_vre_g takes the "
                     f"Monte Carlo's (95 % of draws in [{1e3 * np.quantile(v[:, worst], 0.025):.4g}, "
                     f"{1e3 * np.quantile(v[:, worst], 0.975):.4g}] mg)")


def _monte_carlo(sensor: Sensor, excitation: object, levels: NDArray[np.float64], static_g: float, kind: ClipKind,
                 names: Sequence[str], sigma: NDArray[np.float64],
                 predictor: Callable[..., Prediction]) -> tuple[NDArray[np.float64], float,
                                                                           NDArray[np.float64], NDArray[np.float64]]:
    """GUM Supplement 1 over the identified parameters: ``_MC_DRAWS`` seeded draws from the
    normal distribution of mean the identified values and covariance ``Σ`` (numpy's
    multivariate_normal), :func:`predict` at each. Returns the standard deviation of the VRE
    per level, the fraction of draws outside the parameters' domain (dropped), and the 2.5 %
    and 97.5 % quantiles per level."""
    from vrelab.sensor.parameters import parameter, with_parameters

    mean = np.array([parameter(sensor, n) for n in names], dtype=np.float64)
    draws = np.random.default_rng(20240518).multivariate_normal(mean, sigma, size=_MC_DRAWS, method="eigh")
    vre = []
    for x in draws:
        try:
            p = predictor(with_parameters(sensor, dict(zip(names, (float(v) for v in x)))), excitation, levels,
                        static_g, kind)
        except ValueError:
            continue
        vre.append([lv.vre_g for lv in p.levels])
    outside = 1.0 - len(vre) / _MC_DRAWS
    if len(vre) < 2:
        nan = np.full(levels.size, math.nan)
        return nan, outside, nan, nan
    v = np.array(vre)
    return v.std(axis=0, ddof=1), outside, np.quantile(v, 0.025, axis=0), np.quantile(v, 0.975, axis=0)


# An assumption with no stated u is probed by this relative change (a conservative engineering
# spread for a number nobody bounded: a rail's headroom, a corner's convention are of this order).
PROBE_REL = 0.1
# The parameters only a vibration off the input axis reaches (physics §1.6; the triaxial prediction's).
OFF_AXIS = ("cross_axis_", "kip_", "kio_", "kpp_", "koo_", "kpo_")


def unstated_check(sensor: Sensor, excitation: object, levels: NDArray[np.float64], static_g: float, kind: ClipKind,
                   out: Sequence[LevelPrediction], *,
                   predictor: Callable[..., Prediction]) -> tuple[list[LevelPrediction], list[str]]:
    """The assumptions with no stated u (``sensor.unstated``: facts "assumption..." and no
    ``[uncertainty]`` or covariance entry) are never silently exact (physics §1.5, §6.1): each one is
    named, and where moving it by ``PROBE_REL`` (±10 %) moves a level's VRE by more than the
    level's stated u (the larger of ``u_vre_g``, 1 % of |VRE| and 1 µg), that level is not valid,
    naming the parameter and the move. A parameter at 0 cannot be moved relatively: it is named
    only. Returns the levels and the prediction's notes.

    Examples
    --------
    Each assumption without a stated u is named in the notes, and a level whose VRE moves by more
    than its u when one moves by 10 % is not valid. The ADXL355 preset states a u for each of its
    assumptions: nothing to name, the level stays valid.

    >>> import numpy as np
    >>> import vrelab
    >>> from vrelab.prediction.propagation import unstated_check
    >>> from vrelab.prediction.single import predict
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> levels = predict(sensor, 100.0, [1.0], 1.0).levels
    >>> checked, notes = unstated_check(sensor, 100.0, np.array([1.0]), 1.0, "censored", levels, predictor=predict)
    >>> checked[0].valid, len(notes)
    (True, 0)
    """
    from vrelab.sensor.parameters import parameter, with_parameters

    levels_out = list(out)
    probed: list[str] = []
    zero: list[str] = []
    for name in sensor.unstated:
        x = parameter(sensor, name)
        if x is None:
            continue
        if x == 0:
            if not name.startswith(OFF_AXIS):  # (off-axis terms: a single-axis vibration does not reach them)
                zero.append(name)
            continue
        probed.append(f"{name} = {x:.6g}")
        moves: list[NDArray[np.float64] | None] = []
        for r in (1 + PROBE_REL, 1 - PROBE_REL):
            try:
                p = predictor(with_parameters(sensor, {name: x * r}), excitation, levels, static_g, kind)
                moves.append(np.array([lv.vre_g for lv in p.levels]))
            except ValueError:  # outside its domain (a rail moved across the static field)
                moves.append(None)
        for i, lv in enumerate(levels_out):
            stated = max(lv.u_vre_g or 0.0, TOLERANCE_REL * abs(lv.vre_g), TOLERANCE_ABS_G)
            ends = [m[i] for m in moves if m is not None]
            move = max((abs(e - lv.vre_g) for e in ends), default=math.inf) if len(ends) == 2 else math.inf
            if move > stated:
                shown = "cannot be evaluated" if not math.isfinite(move) else f"moves by up to {move * 1e3:.3g} mg"
                levels_out[i] = dataclasses.replace(lv, valid=False, notes=(*lv.notes, (
                    f"{name} = {x:.6g} is an assumption with no stated u: at ±{100 * PROBE_REL:.0f} % the VRE {shown}, "
                    f"more than its stated u ({stated * 1e3:.3g} mg) — give it a u ([uncertainty]) or measure it")))
    said = []
    if probed:
        said.append("assumed with no stated u (probed at ±{:.0f} %, not in u_vre_g): {}".format(
            100 * PROBE_REL, ", ".join(probed)))
    if zero:
        said.append("assumed exactly 0 with no stated u (not in u_vre_g): " + ", ".join(zero))
    return levels_out, said
