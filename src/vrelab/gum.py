"""Uncertainty budget in the GUM's sense, and decisions against a limit (physics §4.3).

Every VRE carries a Type A standard uncertainty from its record (batch means, with effective
degrees of freedom ν_A). The user declares the Type B terms of the test (:class:`TypeB`):

* ``u_reference_pct``: relative standard uncertainty of the reference sensitivity. The level
  (an rms read from the reference) scales with it; the VRE does not (it is read from the DUT).
  A VRC = VRE/rms² changes by −2·r (closed form).
* ``u_dut_pct``: relative standard uncertainty of the DUT sensitivity: VRE and VRC scale by it.
* ``u_static_g``: the static field's error (fixture alignment). A VRE depends on it through the
  physics (the clipping model's rails at g0, the nonlinearity's 3·k3·g0 term): its sensitivity
  coefficient is taken from the fitted model by numerical perturbation (the clipping model for a
  random test; for a VRC fit it needs k3, which one orientation does not give: then not
  evaluated, and said).
* ``u_thermal_g``: an offset change during vibration (temperature): added to every VRE, one for
  one.

Combined: ``u_c² = u_A² + Σ (c_i·u_i)²``; effective degrees of freedom by Welch-Satterthwaite
``ν_eff = u_c⁴ / (u_A⁴/ν_A)`` (Type B terms taken as exactly known, ν = ∞); coverage factor
``k = t_{0.97725}(ν_eff)`` (the two-sided 95.45 % quantile of Student's t: k = 2 for large ν);
``U = k·u_c`` (JCGM 100:2008, G.4 and G.6).

A fitted parameter (VRC, rail) combines its fit's standard error with each Type B term's
effect found by refitting with that input perturbed by its standard uncertainty (linear
propagation by finite differences; the VRC's −2·r is checked against it in the tests, and the
whole against a Monte Carlo propagation, JCGM 101:2008).

Decision (guarded acceptance, ILAC-G8:09/2019 and ISO 14253-1): ``pass`` when
``|VRE| + U ≤ limit``, ``fail`` when ``|VRE| − U > limit``, else ``indeterminate``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Callable, Mapping, Sequence

from vrelab import _validate as V
from vrelab.results import Estimate, FitResult, LevelResult

COVERAGE_P = 0.9545  # two-sided: k = 2 for a normal distribution
# The conventional coverage factor (GUM 6.2.1, 6.3.3: U = k·u with k = 2, "about 95 %", where the
# u has many degrees of freedom): exactly 2, what a datasheet or a design budget means by 2σ.
# :func:`coverage_factor` with no degrees of freedom gives the normal quantile for COVERAGE_P,
# 1.99998 (ndtri(0.97725)): the analysis's U is that one; a prediction's U (vrelab compare) is k = 2.
CONVENTIONAL_K = 2.0
DECISION_RULE = ("guarded acceptance: pass when |VRE| + U <= limit; fail when |VRE| - U > limit; "
                 "indeterminate otherwise (U = k·u, coverage about 95 %)")


# An estimate whose relative standard uncertainty exceeds this determines nothing: `vrelab
# identify` takes the base sensor's fn or Q instead, and a report shows such a fitted parameter
# (a rail the levels never reached) as "not determined", never as a number.
MAX_REL_U = 0.5


def undetermined(value: float | None, u: float | None) -> str | None:
    """Why ``value ± u`` determines nothing (its relative standard uncertainty above
    :data:`MAX_REL_U`, or no finite value or u), None when it is determined.

    Examples
    --------
    >>> from vrelab.gum import undetermined
    >>> undetermined(2.0, 0.1) is None
    True
    >>> undetermined(0.0, 1.6e13)
    'u = 1.6e+13 with a value of 0'
    >>> undetermined(1.0, 3.0)
    'u = 3 × the value (above 0.5 ×)'
    """
    if value is None or u is None or not (math.isfinite(value) and math.isfinite(u)):
        return "no finite value and uncertainty"
    if value == 0:
        return None if u == 0 else f"u = {u:.2g} with a value of 0"
    rel = u / abs(value)
    return None if rel <= MAX_REL_U else f"u = {rel:.2g} × the value (above {MAX_REL_U:g} ×)"


# The Type B inputs a test declares (a campaign run's budget keys, TypeB's fields).
TYPE_B_KEYS: tuple[str, ...] = ("u_reference_pct", "u_dut_pct", "u_static_g", "u_thermal_g")


@dataclass(frozen=True)
class TypeB:
    """The Type B inputs of a test (physics §4.3); zero means not declared.

    Examples
    --------
    The Type B inputs of a test: the reference's sensitivity to 1 %, the static field to 5 mg.

    >>> from vrelab import TypeB
    >>> typeb = TypeB(u_reference_pct=1.0, u_static_g=0.005)
    >>> typeb.declared, typeb.to_dict()
    (True, {'u_reference_pct': 1.0, 'u_dut_pct': 0.0, 'u_static_g': 0.005, 'u_thermal_g': 0.0})
    """

    u_reference_pct: float = 0.0
    u_dut_pct: float = 0.0
    u_static_g: float = 0.0
    u_thermal_g: float = 0.0

    def __post_init__(self) -> None:
        for name in TYPE_B_KEYS:
            object.__setattr__(self, name, float(V.non_negative(name, getattr(self, name))))

    @property
    def declared(self) -> bool:
        return any(getattr(self, n) > 0 for n in TYPE_B_KEYS)

    def to_dict(self) -> dict[str, float]:
        return {n: getattr(self, n) for n in TYPE_B_KEYS}

    @classmethod
    def from_mapping(cls, d: Mapping[str, Any]) -> TypeB:
        return cls(**{k: float(v) for k, v in d.items() if v is not None})


def coverage_factor(dof: float | None) -> float:
    """k for 95.45 % two-sided coverage from Student's t with ``dof`` degrees of freedom.

    Examples
    --------
    k for 95.45 % coverage: 2 for a normal distribution (infinite degrees of freedom), more with few:

    >>> from vrelab.gum import coverage_factor
    >>> print(f"{coverage_factor(None):.3f} {coverage_factor(10):.3f} {coverage_factor(3):.3f}")
    2.000 2.284 3.307
    """
    # scipy.special's quantiles, which scipy.stats.norm.ppf and t.ppf call (the same bits):
    # importing scipy.stats cost an analysis a second of CPU
    from scipy.special import ndtri, stdtrit

    if dof is None or not math.isfinite(dof) or dof > 1e6:
        return float(ndtri(0.5 + COVERAGE_P / 2))
    return float(stdtrit(max(dof, 1.0), 0.5 + COVERAGE_P / 2))


def welch_satterthwaite(u_c: float, parts: Sequence[tuple[float, float | None]]) -> float:
    """ν_eff = u_c⁴ / Σ u_i⁴/ν_i over (u_i, ν_i); ν None or inf: exactly known (no term).

    Examples
    --------
    A Type A term of 0.03 mg from 4 degrees of freedom and an exactly known Type B term of 0.04 mg:

    >>> import math
    >>> from vrelab.gum import welch_satterthwaite
    >>> u_c = math.hypot(0.03, 0.04)
    >>> print(f"{welch_satterthwaite(u_c, [(0.03, 4), (0.04, None)]):.1f}")
    30.9
    """
    den = sum(u**4 / nu for u, nu in parts if nu is not None and math.isfinite(nu) and nu > 0 and u > 0)
    return math.inf if den == 0 else u_c**4 / den


def decide(vre_g: float, U_g: float, limit_g: float) -> str | None:
    """Guarded acceptance against ``limit_g`` (see the module docstring); None when VRE is undefined.

    Examples
    --------
    VREs of -0.5, -0.9 and -1.5 mg, each with U = 0.3 mg, against a 1 mg limit: the middle one's
    interval straddles the limit.

    >>> from vrelab.gum import decide
    >>> decide(-0.5e-3, 0.3e-3, 1e-3), decide(-0.9e-3, 0.3e-3, 1e-3), decide(-1.5e-3, 0.3e-3, 1e-3)
    ('pass', 'indeterminate', 'fail')
    """
    if not (math.isfinite(vre_g) and math.isfinite(U_g)):
        return None
    if abs(vre_g) + U_g <= limit_g:
        return "pass"
    if abs(vre_g) - U_g > limit_g:
        return "fail"
    return "indeterminate"


def level_budget(level: LevelResult, typeb: TypeB, static_coeff: float | None,
                 limit_g: float | None = None) -> LevelResult:
    """``level`` with its budget, ``U_vre_g``, ``k`` (and ``decision`` against ``limit_g``).

    ``static_coeff`` is ∂VRE/∂g0 at this level [g/g] (None: unknown, the term is listed as not
    evaluated).

    Examples
    --------
    A level of -3 mg measured to 0.03 mg (Type A, 9 degrees of freedom) with a declared thermal
    term of 0.04 mg: u = 0.05 mg, k from the Welch-Satterthwaite degrees of freedom, and the
    decision against a 5 mg limit:

    >>> from vrelab import Estimate, LevelResult, TypeB
    >>> from vrelab.gum import level_budget
    >>> level = LevelResult(rms_g=1.0, vre=Estimate(-0.0030, 0.00003), dof=9)
    >>> budgeted = level_budget(level, TypeB(u_thermal_g=0.00004), None, limit_g=0.005)
    >>> print(f"u {budgeted.vre.u * 1e3:.4f} mg, k {budgeted.k:.2f}, U {budgeted.U_vre_g * 1e3:.3f} mg, {budgeted.decision}")
    u 0.0500 mg, k 2.04, U 0.102 mg, pass
    """
    v, u_a = level.vre.value, level.vre.u
    terms: list[dict[str, Any]] = [{"source": "record (batch means, low-frequency noise)", "type": "A", "u_g": u_a,
                                    "dof": None if level.dof is None or not math.isfinite(level.dof) else level.dof}]
    if typeb.u_dut_pct:
        terms.append({"source": "DUT sensitivity", "type": "B", "u_g": abs(v) * typeb.u_dut_pct / 100,
                      "note": f"{typeb.u_dut_pct:g} % of the VRE"})
    if typeb.u_reference_pct:
        terms.append({"source": "reference sensitivity", "type": "B", "u_g": 0.0,
                      "note": f"{typeb.u_reference_pct:g} % of the level's rms, not of the VRE (read from the DUT)"})
    if typeb.u_static_g:
        if static_coeff is None:
            terms.append({"source": "static field (alignment)", "type": "B", "u_g": None,
                          "note": "not evaluated: the fitted model gives no static-field dependence "
                                  "(k3 needs two orientations)"})
        else:
            terms.append({"source": "static field (alignment)", "type": "B",
                          "u_g": abs(static_coeff) * typeb.u_static_g,
                          "note": f"dVRE/dg0 = {static_coeff:.4g} g/g from the fitted model × {typeb.u_static_g:g} g"})
    if typeb.u_thermal_g:
        terms.append({"source": "thermal offset", "type": "B", "u_g": typeb.u_thermal_g})
    u_c = math.sqrt(sum(t["u_g"] ** 2 for t in terms if t["u_g"] is not None and math.isfinite(t["u_g"])))
    if not math.isfinite(v):
        u_c = math.nan
    nu = welch_satterthwaite(u_c, [(u_a, level.dof)]) if math.isfinite(u_c) else math.nan
    k = coverage_factor(nu) if math.isfinite(u_c) else math.nan
    vre = Estimate(v, u_c, level.vre.unit)
    U = vre.expanded(k)
    decision = decide(v, U, limit_g) if limit_g is not None else None
    return replace(level, vre=vre, budget=tuple(terms), U_vre_g=U, k=k, decision=decision)


def weighted_mean_chi2(values: Sequence[float], us: Sequence[float]) -> tuple[float, float, float]:
    """(mean, u, χ²) of independent values with standard uncertainties ``us``: the
    inverse-variance weighted mean, its internal u = 1/√Σw (w = 1/u²) and χ² = Σ w·(x − mean)²
    of the values about it (JCGM 100:2008 does not treat the combination of repeated results;
    this is the usual least-squares one, e.g. Bevington & Robinson, Data Reduction, ch. 4).

    Examples
    --------
    Two VRCs of 100 ± 5 and 110 ± 5 µg/g²:

    >>> from vrelab.gum import weighted_mean_chi2
    >>> mean, u, chi2 = weighted_mean_chi2([100.0, 110.0], [5.0, 5.0])
    >>> print(f"{mean:.1f} ± {u:.2f}, chi2 {chi2:.1f}")
    105.0 ± 3.54, chi2 2.0
    """
    w = [1.0 / u**2 for u in us]
    m = sum(wi * x for wi, x in zip(w, values)) / sum(w)
    chi2 = sum(wi * (x - m) ** 2 for wi, x in zip(w, values))
    return m, math.sqrt(1.0 / sum(w)), chi2


def weighted_mean(es: Sequence[Estimate]) -> Estimate:
    """Inverse-variance weighted mean of independent estimates; its u scaled by the Birge ratio
    √(χ²/(n−1)) when the values scatter more than their uncertainties (never scaled down: R. T.
    Birge, Phys. Rev. 40, 207 (1932); the CODATA adjustments' practice).

    Examples
    --------
    The same two VRCs as estimates; their scatter (χ² = 2 for one degree of freedom) widens the
    u by the Birge ratio √2:

    >>> from vrelab import Estimate
    >>> from vrelab.gum import weighted_mean
    >>> mean = weighted_mean([Estimate(100.0, 5.0, "µg/g²"), Estimate(110.0, 5.0, "µg/g²")])
    >>> print(f"{mean.value:.1f} ± {mean.u:.2f} {mean.unit}")
    105.0 ± 5.00 µg/g²
    """
    m, u, chi2 = weighted_mean_chi2([e.value for e in es], [e.u for e in es])
    if len(es) > 1:
        u *= math.sqrt(max(chi2 / (len(es) - 1), 1.0))
    return Estimate(m, u, es[0].unit)


def common_sensitivity_terms(estimates: Sequence[Estimate | None], budgets: Sequence[Mapping[str, float]]
                             ) -> tuple[list[Estimate | None], str | None]:
    """Nonlinearity coefficients (k2, k3: a VRC's kin) with the sensitivity terms every run of a
    campaign shares (one reference, one DUT): a VRC = VRE/rms² scales by −2·r with the reference
    sensitivity and by p with the DUT's (closed form, this module's docstring), so k2 and k3 do
    too. Added once, after the weighted combination that independent Type A errors allow; the
    largest declared values of the runs are used. Returns the estimates and a note (None when no
    run declares either term).

    Examples
    --------
    k2 = 100 ± 3 µg/g² combined from runs that share a reference known to 1 %: a VRC scales by
    -2·r with the reference's sensitivity, so 2 µg/g² is added in quadrature once.

    >>> from vrelab import Estimate
    >>> from vrelab.gum import common_sensitivity_terms
    >>> (k2,), note = common_sensitivity_terms([Estimate(100.0, 3.0, "µg/g²")], [{"u_reference_pct": 1.0}])
    >>> print(f"{k2.value:.1f} ± {k2.u:.2f} {k2.unit}")
    100.0 ± 3.61 µg/g²
    """
    r = max((b.get("u_reference_pct", 0.0) for b in budgets), default=0.0) / 100
    p = max((b.get("u_dut_pct", 0.0) for b in budgets), default=0.0) / 100
    if not (r or p):
        return list(estimates), None
    rel = math.hypot(2 * r, p)
    out = [None if e is None else Estimate(e.value, math.hypot(e.u, rel * abs(e.value)), e.unit) for e in estimates]
    return out, (f"k2, k3: reference ({100 * r:g} %) and DUT ({100 * p:g} %) sensitivity terms, common to "
                 "every run, added after the combination (the static-field and thermal terms are not)")


# The Type B inputs as perturbations of a reduction's inputs: a refit with one of them moved by
# its standard uncertainty gives that term's share of every fitted parameter.
def type_b_perturbations(typeb: TypeB) -> list[tuple[str, dict[str, float]]]:
    """(source, perturbation) for each declared Type B input (``rms_rel``: every level's rms
    scales by 1 + r; ``vre_rel``: every VRE by 1 + p; ``static_g``: the static field moves;
    ``offset_g``: an offset on every VRE).

    Examples
    --------
    >>> from vrelab import TypeB
    >>> from vrelab.gum import type_b_perturbations
    >>> type_b_perturbations(TypeB(u_reference_pct=1.0, u_static_g=0.01))
    [('reference sensitivity', {'rms_rel': 0.01}), ('static field (alignment)', {'static_g': 0.01})]
    """
    every = [
        ("reference sensitivity", {"rms_rel": typeb.u_reference_pct / 100}),
        ("DUT sensitivity", {"vre_rel": typeb.u_dut_pct / 100}),
        ("static field (alignment)", {"static_g": typeb.u_static_g}),
        ("thermal offset", {"offset_g": typeb.u_thermal_g}),
    ]
    return [(source, delta) for source, delta in every if any(delta.values())]


def type_b_shifts(values: Mapping[str, float], refit: Callable[[dict[str, float]], Mapping[str, float] | None],
                  typeb: TypeB) -> list[tuple[str, dict[str, float], dict[str, float] | None]]:
    """For each declared Type B input: (source, perturbation, each parameter's shift), the shifts
    from refitting with that input moved by its standard uncertainty (None: the refit failed).
    ``refit`` takes the perturbation and returns the refitted parameter values.

    Examples
    --------
    A VRC refitted with the reference's sensitivity 1 % high: every rms 1 % higher, so the VRC
    (VRE/rms²) 2 % lower.

    >>> from vrelab import TypeB
    >>> from vrelab.gum import type_b_shifts
    >>> def refit(perturbation):
    ...     return {"vrc_ug_per_g2": 100.0 / (1 + perturbation.get("rms_rel", 0.0)) ** 2}
    >>> for source, perturbation, shift in type_b_shifts({"vrc_ug_per_g2": 100.0}, refit, TypeB(u_reference_pct=1.0)):
    ...     print(f"{source}: {shift['vrc_ug_per_g2']:.2f} µg/g²")
    reference sensitivity: -1.97 µg/g²
    """
    out: list[tuple[str, dict[str, float], dict[str, float] | None]] = []
    for source, delta in type_b_perturbations(typeb):
        other = refit(delta)
        out.append((source, delta, None if other is None else
                    {name: float(other[name]) - float(v) for name, v in values.items() if name in other}))
    return out


def fit_budget(fit: FitResult, refit: Callable[[dict[str, float]], FitResult | None],
               typeb: TypeB) -> FitResult:
    """``fit`` with each parameter's ``u`` combined with the Type B terms, found by refitting
    with one input perturbed by its standard uncertainty (``refit`` takes the perturbations
    ``{"rms_rel", "vre_rel", "static_g", "offset_g"}``); the budget is kept in the notes.

    Examples
    --------
    A VRC fit of 100 ± 3 µg/g² with the reference's sensitivity known to 1 %: the refit with every
    rms 1 % high moves the VRC by 2 µg/g², added to its u.

    >>> from vrelab import Estimate, LevelResult, TypeB
    >>> from vrelab.fits import fit_vrc
    >>> from vrelab.gum import fit_budget, perturb_levels
    >>> levels = [LevelResult(rms_g=r, vre=Estimate(1e-4 * r**2, 3e-5)) for r in (1.0, 2.0, 3.0)]
    >>> def refit(perturbation):
    ...     return fit_vrc(perturb_levels(levels, **perturbation))
    >>> fit = fit_budget(fit_vrc(levels), refit, TypeB(u_reference_pct=1.0))
    >>> print(f"{fit.params['vrc_ug_per_g2'].value:.1f} ± {fit.params['vrc_ug_per_g2'].u:.2f}")
    100.0 ± 3.61
    """
    params = dict(fit.params)
    notes = list(fit.notes)
    extra: dict[str, float] = {name: 0.0 for name in params}

    def values_of(delta: dict[str, float]) -> dict[str, float] | None:
        other = refit(delta)
        return None if other is None else {k: e.value for k, e in other.params.items()}

    for source, delta, diffs in type_b_shifts({k: e.value for k, e in params.items()}, values_of, typeb):
        if diffs is None:
            notes.append(f"budget: {source} not evaluated (the refit did not converge)")
            continue
        if source.startswith("static") and all(d == 0 for d in diffs.values()):
            notes.append("budget: static field not evaluated: this fit does not depend on g0 (its k3 term needs "
                         "two orientations: see the campaign's k2/k3)")
            continue
        for name, d in diffs.items():
            extra[name] += d * d
        notes.append(f"budget: {source} ({', '.join(f'{k}={v:g}' for k, v in delta.items())}): "
                     + ", ".join(f"{name} {d:+.3g}" for name, d in diffs.items()))
    combined = {name: Estimate(e.value, math.sqrt(e.u**2 + extra[name]), e.unit) for name, e in params.items()}
    return replace(fit, model=fit.model.with_params(combined), notes=tuple(notes))


def perturb_levels(levels: Sequence[LevelResult], rms_rel: float = 0.0, vre_rel: float = 0.0,
                   offset_g: float = 0.0) -> list[LevelResult]:
    """Levels as they would read with the reference sensitivity off by ``rms_rel`` (every rms
    scales by 1 + rms_rel, a sine level's measured E[x²] and E[x³] by its square and cube: 2r
    and 3r, physics §4.3), the DUT's by ``vre_rel`` and an offset ``offset_g`` on every VRE.

    Examples
    --------
    A level as it reads with the reference's sensitivity 1 % high (every rms 1 % higher):

    >>> from vrelab import Estimate, LevelResult
    >>> from vrelab.gum import perturb_levels
    >>> level = LevelResult(rms_g=1.0, vre=Estimate(-0.0030, 0.00003))
    >>> print(f"{perturb_levels([level], rms_rel=0.01)[0].rms_g:.2f} g rms")
    1.01 g rms
    """
    return [replace(lv, rms_g=lv.rms_g * (1 + rms_rel),
                    vre=Estimate(lv.vre.value * (1 + vre_rel) + offset_g, lv.vre.u, lv.vre.unit),
                    drive=None if lv.drive is None else lv.drive.scaled(1 + rms_rel))
            for lv in levels]
