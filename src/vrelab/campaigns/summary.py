"""Combining a campaign's runs per channel: VRC by frequency and orientation, k2 and k3, the
rail, the mounted runs' apparent VRCs (the package docstring says how)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Mapping, Sequence

from vrelab._display import Shown
from vrelab._format import finite_or_none
from vrelab.gum import (
    common_sensitivity_terms,
    weighted_mean,
    weighted_mean_chi2,
)
from vrelab.results import Estimate, FitResult, K2K3Model, K2Model, VreResult, group_by_frequency

if TYPE_CHECKING:
    pass

from vrelab.campaigns.manifest import SAME_ORIENTATION_G, Mount
from vrelab.campaigns.runs import RunResult


@dataclass(frozen=True, repr=False)
class ChannelSummary(Shown):
    """What a campaign gives for one channel (physics §4.1, the CLI reference).

    Examples
    --------
    One orientation: the VRC at 80 Hz, and no k2 and k3 apart (they need two orientations):

    >>> from vrelab.campaigns.manifest import read_manifest
    >>> from vrelab.campaigns.runs import run_campaign
    >>> from vrelab.campaigns.summary import combine
    >>> (summary,) = combine(run_campaign(read_manifest("examples/campaign/one-run.toml")), ["sn1"])
    >>> len(summary.vrc_by_freq), summary.k2, summary.k2_k3
    (1, None, None)
    """

    channel: str
    vrc_by_freq: tuple[dict[str, Any], ...]
    k2_k3_by_freq: tuple[FitResult, ...]
    k2: Estimate | None
    k3: Estimate | None
    k2_k3: FitResult | None  # the combined fit (covariance kept), when both are determined
    rail: Estimate | None
    rails_by_run: tuple[dict[str, Any], ...]
    notes: tuple[str, ...]
    # the apparent VRC (VRE/rms²) of every sine run mounted at an angle (IEEE 1293, physics §1.6): not
    # the input axis's alone, so kept out of k2, k3 and the rail; vrelab.identify fits the cross terms
    vrc_by_mount: tuple[dict[str, Any], ...] = ()
    # the channel's noise with vibration off in each run (physics §4.4: density, bias instability,
    # the Allan deviation's minimum; the whole curve is in the run's own results)
    noise_by_run: tuple[dict[str, Any], ...] = ()
    _SHOW = ("channel", "k2", "k3", "rail", "vrc_by_freq", "rails_by_run", "notes")
    _ROWS = "vrc_by_freq"  # its levels: the VRC at each frequency and orientation

    def to_dict(self) -> dict[str, Any]:
        def est(e: Estimate | None) -> dict[str, Any] | None:
            return None if e is None else {"value": finite_or_none(e.value), "u": finite_or_none(e.u)}

        return {
            "channel": self.channel,
            "vrc_by_freq": list(self.vrc_by_freq),
            "k2_ug_per_g2": est(self.k2),
            "k3_ug_per_g3": est(self.k3),
            "k2_k3": None if self.k2_k3 is None else self.k2_k3.to_dict(),
            "k2_k3_by_freq": [f.to_dict() for f in self.k2_k3_by_freq],
            "rail_g": est(self.rail),
            "rails_by_run": list(self.rails_by_run),
            **({"vrc_by_mount": list(self.vrc_by_mount)} if self.vrc_by_mount else {}),
            "noise_by_run": list(self.noise_by_run),
            "notes": list(self.notes),
        }


def combine(results: Sequence[RunResult], channels: Sequence[str]) -> list[ChannelSummary]:
    """Per channel: VRC by frequency and orientation, k2/k3, the rail (see the module docstring).

    Examples
    --------
    >>> from vrelab.campaigns.manifest import read_manifest
    >>> from vrelab.campaigns.runs import run_campaign
    >>> from vrelab.campaigns.summary import combine
    >>> (summary,) = combine(run_campaign(read_manifest("examples/campaign/one-run.toml")), ["sn1"])
    >>> vrc = summary.vrc_by_freq[0]["vrc_ug_per_g2"]
    >>> print(summary.channel, f"VRC {vrc['value']:.0f} ± {vrc['u']:.0f} µg/g²", summary.k2)
    sn1 VRC 2853 ± 87 µg/g² None
    """
    return [_combine_channel(ch, results) for ch in channels]


_Lists = list[dict[str, Any]]


def _collect(channel: str, results: Sequence[RunResult]) -> tuple[_Lists, _Lists, _Lists, list[str], _Lists]:
    """The channel's entries over the runs: (its sine VRCs along the vibration, its rails, its
    mounted runs' apparent VRCs, notes on what was left out, its noise by run)."""
    vrcs: list[dict[str, Any]] = []
    rails: list[dict[str, Any]] = []
    mounted: list[dict[str, Any]] = []
    notes: list[str] = []
    noise: list[dict[str, Any]] = []
    for rr in results:
        for name, res in rr.results:
            if name != channel:
                continue
            if res.noise is not None:
                nd = res.noise.to_dict()
                noise.append({"run": rr.run.index, "label": rr.run.label, "off_s": nd["off_s"],
                              **{k: nd[k] for k in ("density_ug_rthz", "bias_instability_ug", "allan")}})
            g0 = rr.run.static_g[name]
            mount = rr.run.mount.get(name)
            if mount is not None and mount.tilted:
                mounted += _mounted_vrcs(rr, mount, res)
                notes.append(f"{rr.run.where}: mounted at {mount.deg:+g}° in the {mount.plane.upper()} plane: its VRE is "
                             "not the input axis's alone (cross-coupling, physics §1.6): not used for k2, k3 or the rail "
                             "(`vrelab identify` fits the cross-coupling coefficients from it)")
                continue
            for f in res.fits:
                if f.model.vrc is not None and res.method == "sine":
                    e = _type_a(f, "vrc_ug_per_g2")
                    if f.n_points < 2 or not (math.isfinite(e.value) and math.isfinite(e.u) and e.u > 0):
                        notes.append(f"{rr.run.where}: the VRC at {f.freq_hz:g} Hz rests on {f.n_points} level(s): "
                                     "not used for k2/k3")
                        continue
                    vrcs.append({"freq_hz": f.freq_hz, "static_g": g0, "run": rr.run.index, "label": rr.run.label,
                                 "vrc_ug_per_g2": {"value": e.value, "u": e.u}, "n_levels": f.n_points,
                                 **({} if f.static_shift_g is None else {"static_shift_g": f.static_shift_g})})
                elif f.model.rail is not None:
                    e = _type_a(f, "rail_g")
                    if math.isfinite(e.value) and math.isfinite(e.u) and e.u > 0:
                        rails.append({"run": rr.run.index, "label": rr.run.label, "static_g": g0,
                                      "rail_g": {"value": e.value, "u": e.u}, "model": f.model.name})
    return vrcs, rails, mounted, notes, noise


def _combine_channel(channel: str, results: Sequence[RunResult]) -> ChannelSummary:
    from vrelab.fits import combine_fits, fit_k2_k3

    vrcs, rails, mounted, notes, noise = _collect(channel, results)
    vrcs.sort(key=lambda v: (v["freq_hz"], v["static_g"]))
    groups = group_by_frequency(vrcs, lambda v: v["freq_hz"])

    def est(v: Mapping[str, Any]) -> Estimate:
        return Estimate(v["vrc_ug_per_g2"]["value"], v["vrc_ug_per_g2"]["u"], "ug/g^2")

    by_freq: list[FitResult] = []
    k2_only: list[FitResult] = []
    for grp in groups:
        fields = [v["static_g"] for v in grp]
        f0 = grp[0]["freq_hz"]
        if max(fields) - min(fields) >= SAME_ORIENTATION_G:
            # each VRC at the static field its cubic term saw (a distorted drive's E[x³] moves it:
            # FitResult.static_shift_g), so k2 and k3 are those of the pure polynomial (physics §4.4)
            by_freq.append(fit_k2_k3([(v["static_g"] + v.get("static_shift_g", 0.0), est(v)) for v in grp], freq_hz=f0))
            _at_nominal_static(grp, by_freq[-1])
        elif all(abs(g) < SAME_ORIENTATION_G / 2 for g in fields):
            k2_only.append(FitResult(K2Model({"k2_ug_per_g2": Estimate(est(grp[0]).value, est(grp[0]).u, "ug/g^2")}
                                             if len(grp) == 1 else {"k2_ug_per_g2": weighted_mean([est(v) for v in grp])}),
                                     n_points=len(grp), freq_hz=f0))
    notes += _mounted_at_pure_drive(mounted, by_freq)
    k2 = k3 = None
    both = None
    names = ["k2_ug_per_g2", "k3_ug_per_g3"]
    if by_freq:
        both = combine_fits(by_freq, names, K2K3Model)
        k2, k3 = both.params[names[0]], both.params[names[1]]
        notes += [n for n in both.notes if "scatter" in n]
        notes += _k2_across_frequencies(by_freq)
        if k2_only:
            notes.append("k2 from the orientations' fits; frequencies measured at 0 g only are not combined with them")
    elif k2_only:
        c = combine_fits(k2_only, names[:1], K2Model)
        k2 = c.params[names[0]]
        notes.append("k2 from VRC at 0 g (VRC = k2 there); k3 needs two orientations (+g and -g): "
                     "one orientation only, k3 = null")
        notes += [n for n in c.notes if "scatter" in n]
        notes += _k2_across_frequencies(k2_only)
    elif vrcs:
        notes.append("one orientation only (no sine frequency measured at two static fields, nor at 0 g): "
                     "k2 and k3 = null")
    else:
        notes.append("no sine run with a VRC fit of two levels or more: k2 and k3 = null")
    if not by_freq:
        shifted = [v for v in vrcs if abs(v.get("static_shift_g", 0.0)) > 0]
        if shifted:
            worst = max(shifted, key=lambda v: abs(v["static_shift_g"]))
            notes.append(f"a distorted drive (physics §4.4): each VRC is k2 + 3*k3*(g0 + shift) with the shift its drive's "
                         f"E[x³] gives (up to {worst['static_shift_g']:+.3g} g, run {worst['run']}); without two "
                         "orientations k3 is unknown, so 3*k3*shift is an unknown bias of these VRCs (and of k2)")
    budgets = [rr.run.budget for rr in results if any(n == channel for n, _ in rr.results)]
    if k2 is not None or k3 is not None:
        (k2, k3), note = common_sensitivity_terms((k2, k3), budgets)
        if note:
            notes.append(note)
    rail = None
    if rails:
        rail = weighted_mean([Estimate(r["rail_g"]["value"], r["rail_g"]["u"], "g") for r in rails])
    elif not any(rr.run.method != "sine" for rr in results):
        notes.append("no random run: rail = null")
    else:
        notes.append("no random run with a rail fit: rail = null")
    return ChannelSummary(channel, tuple(vrcs), tuple(by_freq), k2, k3, both, rail, tuple(rails), tuple(notes),
                          tuple(mounted), tuple(noise))


def _at_nominal_static(group: Sequence[dict[str, Any]], fit: FitResult) -> None:
    """Each VRC entry of ``group`` (one frequency, fitted by ``fit``, :func:`vrelab.fits.fit_k2_k3`
    at the static fields g0 + shift) carried to its nominal g0 (physics §1.2's VRC = k2 + 3·k3·g0),
    in place: ``VRC - 3·k3·shift``, its variance ``u² + 9·shift²·u(k3)² - 6·shift·cov(VRC, k3)``
    with ``cov(VRC_i, k3) = C[1,0] + 3·g_i·C[1,1]`` (C the fit's covariance, g_i the field the
    point was fitted at: the weighted least squares' k3 is a linear function of the VRCs). The
    measured VRC stays as ``vrc_measured_ug_per_g2``. Entries without a shift are left as they are."""
    cov = fit.covariance
    k3 = fit.params["k3_ug_per_g3"]
    if cov is None:
        return
    for v in group:
        shift = v.get("static_shift_g", 0.0)
        if not shift:
            continue
        e = v["vrc_ug_per_g2"]
        g = v["static_g"] + shift
        c = cov[1][0] + 3.0 * g * cov[1][1]
        var = e["u"] ** 2 + 9.0 * shift**2 * cov[1][1] - 6.0 * shift * c
        v["vrc_measured_ug_per_g2"] = dict(e)
        v["vrc_ug_per_g2"] = {"value": e["value"] - 3.0 * k3.value * shift, "u": math.sqrt(max(var, 0.0))}


def _mounted_vrcs(rr: RunResult, mount: Mount, res: VreResult) -> list[dict[str, Any]]:
    """The apparent VRC (VRE/rms², Type A u) of each sine frequency of a run mounted at an angle."""
    out = []
    for f in res.fits:
        if f.model.vrc is not None and res.method == "sine":
            e = _type_a(f, "vrc_ug_per_g2")
            if math.isfinite(e.value) and math.isfinite(e.u) and e.u > 0:
                out.append({"freq_hz": f.freq_hz, **mount.to_dict(), "run": rr.run.index, "label": rr.run.label,
                            "vrc_ug_per_g2": {"value": e.value, "u": e.u}, "n_levels": f.n_points,
                            **({} if f.static_shift_g is None else {"static_shift_g": f.static_shift_g})})
    return out


def _mounted_at_pure_drive(mounted: Sequence[dict[str, Any]], by_freq: Sequence[FitResult]) -> list[str]:
    """Each mount-angle VRC of ``mounted`` whose drive was distorted (its fit's
    ``static_shift_g`` s, along the vibration) carried to a pure drive, in place, as
    :func:`_at_nominal_static` does the axial ones: the input axis senses cos φ of the vibration,
    so the drive's E[x³] adds ``3·k3·cos³φ·s`` to VRE/E[x²] (physics §1.6's cross terms are quadratic:
    they see E[x²] only); subtracted with k3 of the axial k2/k3 fit at the same frequency, its
    variance ``u² + 9·cos⁶φ·s²·u(k3)²`` (independent runs: no covariance). The measured VRC stays
    as ``vrc_measured_ug_per_g2``. Returns a note for the entries no fit at their frequency
    corrects (their VRC carries the unknown ``3·k3·cos³φ·s``)."""
    from vrelab.results import same_frequency

    left = []
    for v in mounted:
        shift = v.get("static_shift_g", 0.0)
        if not shift:
            continue
        fit = next((f for f in by_freq if f.freq_hz is not None and same_frequency(f.freq_hz, v["freq_hz"])
                    and f.covariance is not None), None)
        c3 = math.cos(math.radians(v["mount_deg"])) ** 3
        if fit is None or fit.covariance is None:
            left.append(f"run {v['run']} at {v['freq_hz']:g} Hz")
            continue
        k3, var_k3 = fit.params["k3_ug_per_g3"].value, fit.covariance[1][1]
        e = v["vrc_ug_per_g2"]
        v["vrc_measured_ug_per_g2"] = dict(e)
        v["vrc_ug_per_g2"] = {"value": e["value"] - 3.0 * k3 * c3 * shift,
                              "u": math.sqrt(e["u"] ** 2 + 9.0 * c3 * c3 * shift * shift * var_k3)}
    if not left:
        return []
    return [f"a distorted drive (physics §4.4) on mount-angle run(s) {', '.join(left)}: no k2/k3 fit at their "
            "frequency, so their VRC carries an unknown 3*k3*cos³φ*shift (the fit's static_shift_g)"]


# Below this p-value of the χ² of the per-frequency k2 about their mean, they are said to disagree.
K2_CONSISTENCY_P = 0.05


def _k2_across_frequencies(fits: Sequence[FitResult]) -> list[str]:
    """What the combined k2 is, when it comes from more than one frequency: each frequency measures
    the apparent VRC(f) = k2·|H(f)|² (physics §1.3), and |H|² > 1 grows toward the resonance, so the
    combination is an apparent k2, biased upward by the highest frequencies. Their consistency is
    the χ² of the per-frequency k2 (Type A u) about their weighted mean, with its Birge ratio
    √(χ²/dof) and p-value (scipy.stats.chi2)."""
    from scipy.stats import chi2 as chi2_dist

    from vrelab._format import format_value, format_value_u

    ks = [(f.freq_hz, _type_a(f, "k2_ug_per_g2")) for f in fits if "k2_ug_per_g2" in f.params]
    ks = [(fq, e) for fq, e in ks if fq is not None and math.isfinite(e.value) and math.isfinite(e.u) and e.u > 0]
    if len(ks) < 2:
        return []
    _, _, chi2 = weighted_mean_chi2([e.value for _, e in ks], [e.u for _, e in ks])
    dof = len(ks) - 1
    p = float(chi2_dist.sf(chi2, dof))
    each = ", ".join(f"{fq:g} Hz {format_value_u(e.value, e.u, unit='µg/g²')}" for fq, e in ks)
    stats = f"χ²/dof = {format_value(chi2 / dof, digits=2)}, Birge ratio {format_value(math.sqrt(chi2 / dof), digits=2)}, p = {format_value(p, digits=2)}"
    apparent = ("the combined k2 is apparent: each frequency measures k2·|H(f)|², which rises toward the "
                "resonance, so the combination is biased (too large in magnitude) by the higher frequencies; `vrelab identify` "
                "fits fn and Q and gives k2 corrected by |H(f)|²")
    if p < K2_CONSISTENCY_P:
        return [f"k2 per frequency DISAGREE ({each}; {stats}): {apparent}"]
    return [f"k2 per frequency agree within their uncertainties ({each}; {stats}); {apparent}"]


def _type_a(fit: FitResult, name: str) -> Estimate:
    """A fitted parameter with its fit's own (Type A) standard error: the covariance's diagonal,
    before a budget's Type B terms (combined after the runs are, being common to all)."""
    e = fit.params[name]
    if fit.covariance is not None and name in fit.params:
        i = list(fit.params).index(name)
        return Estimate(e.value, math.sqrt(fit.covariance[i][i]), e.unit)
    return e
