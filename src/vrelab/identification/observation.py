"""Identification's observations: a campaign document's runs as the fit uses them, and the
identified model's types (:class:`Observation`, :class:`ChannelModel`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal, Mapping, NotRequired, Sequence, TypedDict

import numpy as np
from numpy.typing import NDArray

from vrelab import _validate as V
from vrelab._display import Shown
from vrelab._format import finite_or_none
from vrelab.campaigns import (
    MOUNT_PLANES,
    Mount,
)
from vrelab.profiles import RandomProfile
from vrelab.results import Estimate, group_by_frequency
from vrelab.units import to_ug

if TYPE_CHECKING:
    from vrelab.identification.cross_coupling import CrossCoupling


@dataclass(frozen=True)
class Observation:
    """One run of one channel as identification uses it: the excitation and the levels.

    Examples
    --------
    Two sine runs at 80 Hz of a part with k2 = 100 µg/g² and k3 = 10 µg/g³, axis up (VRC 130 µg/g²)
    and axis down (70 µg/g²), three levels clear of the ±2 g rails, each known to 2 µg:

    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> obs[0].method, obs[0].static_g, obs[0].freq_hz
    ('sine', 1.0, 80.0)
    """

    run: int
    label: str
    method: str  # "sine" | "random"
    static_g: float
    freq_hz: float | None  # sine
    profile: RandomProfile | None  # random: the drive's spectrum shape (scaled to each level)
    rms_g: NDArray[np.float64]
    vre_g: NDArray[np.float64]
    u_g: NDArray[np.float64]  # Type A standard uncertainty of each VRE
    harmonic_g: tuple[tuple[float, float] | None, ...] = ()  # per level: the 2f estimate (value, u)
    # per sine level: the analysis flagged DUT samples at a rail (its own rail, not the identified one)
    saturated: tuple[bool, ...] = ()
    mount: Mount | None = None  # an IEEE 1293 mount-angle run (physics §1.6): its angle, plane and static vector
    # per sine level: the reference's measured waveform as (E[x²]/rms², E[x³]/rms³), rms the
    # fundamental's (physics §4.4, :class:`vrelab.results.DriveWaveform`); None: a pure sine. Held
    # relative to rms so that a Type B scaling of the levels scales the moments with them.
    drive: tuple[tuple[float, float] | None, ...] = ()

    @property
    def n(self) -> int:
        return int(self.rms_g.size)

    @property
    def tilted(self) -> bool:
        """Mounted with the input axis off the vibration: the cross-coupling fit's, not the model's."""
        return self.mount is not None and self.mount.tilted


class ValueU(TypedDict):
    """A value and its standard uncertainty (k = 1) in the identification's JSON.

    Examples
    --------
    >>> from vrelab.identification.observation import value_u
    >>> value_u(130.0, 1.5)["u"]
    1.5
    """

    value: float
    u: float


class Residual(TypedDict):
    """One level of a run in :class:`RunFit`: measured, modelled, and the pull between them.

    Examples
    --------
    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> import vrelab
    >>> base = vrelab.load_sensor("ideal", range_g=2)
    >>> from vrelab.identification.channel import identify_channel
    >>> residual = identify_channel("sn1", obs, base).runs[0]["residuals"][-1]
    >>> print(f"{residual['rms_g']:.1f} g rms: measured {residual['vre_g'] * 1e6:.2f} µg, model {residual['model_g'] * 1e6:.2f} µg, pull {abs(residual['pull']):.1f}")
    0.6 g rms: measured 46.80 µg, model 46.80 µg, pull 0.0
    """

    rms_g: float
    vre_g: float
    u_vre_g: float
    model_g: float
    pull: float
    model_valid: bool


class RunFit(TypedDict):
    """One run of a channel as the fitted model meets it (``ChannelModel.runs``, the JSON's ``runs``).

    Examples
    --------
    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> import vrelab
    >>> base = vrelab.load_sensor("ideal", range_g=2)
    >>> from vrelab.identification.channel import identify_channel
    >>> run = identify_channel("sn1", obs, base).runs[0]
    >>> run["label"], f"{run['vrc_ug_per_g2']['value']:.1f}", len(run["residuals"])
    ('run 1', '130.0', 3)
    """

    run: int
    label: str
    method: str
    static_g: float
    freq_hz: float | None
    profile: str | None  # the random drive's description
    n: int
    chi2: float
    vrc_ug_per_g2: ValueU | None  # a sine run's apparent VRC
    residuals: list[Residual]


class TypeBTerm(TypedDict):
    """One Type B source's effect on the fitted parameters (``ChannelModel.budget``): the refit's
    shifts under its perturbation, or None with a note where the refit failed.

    Examples
    --------
    The reference's sensitivity known to 1 %: its term moves k2 and k3 by 2 % (a VRC scales by -2·r):

    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> import vrelab
    >>> base = vrelab.load_sensor("ideal", range_g=2)
    >>> from vrelab import TypeB
    >>> from vrelab.identification.channel import IdentifyOptions, identify_channel
    >>> model = identify_channel("sn1", obs, base, IdentifyOptions(typeb=TypeB(u_reference_pct=1.0)))
    >>> term = model.budget[0]
    >>> print(term["source"], f"{abs(term['shifts']['k2_ug_per_g2']):.2f}")
    reference sensitivity 1.97
    """

    source: str
    type: Literal["B"]
    shifts: dict[str, float] | None
    perturbation: NotRequired[dict[str, float]]
    note: NotRequired[str]


class Check2f(TypedDict):
    """One sine run's 2f cross-check (:func:`cross_check_2f`).

    Examples
    --------
    The fields of one check (:func:`vrelab.identification.check2f.cross_check_2f` makes them):

    >>> from vrelab.identification.observation import Check2f
    >>> list(Check2f.__annotations__)[:5]
    ['run', 'label', 'freq_hz', 'static_g', 'vrc_2f_ug_per_g2']
    """

    run: int
    label: str
    freq_hz: float | None
    static_g: float
    vrc_2f_ug_per_g2: ValueU
    vrc_dc_ug_per_g2: ValueU
    filter_gain_2f: float
    difference_sigma: float | None
    agree: bool | None


@dataclass(frozen=True, repr=False)
class ChannelModel(Shown):
    """The identified model of one channel.

    Examples
    --------
    What :func:`vrelab.identification.channel.identify_channel` returns: each parameter
    determined (an Estimate) or not (None, and the reason).

    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> import vrelab
    >>> base = vrelab.load_sensor("ideal", range_g=2)
    >>> from vrelab.identification.channel import identify_channel
    >>> model = identify_channel("sn1", obs, base)
    >>> print(f"{model.parameters['k2_ug_per_g2'].value:.1f}", model.parameters["fn_hz"])
    100.0 None
    >>> print(model.reasons["fn_hz"])
    sine runs at one frequency only (80 Hz): VRC(f) has no shape
    """

    channel: str
    parameters: Mapping[str, Estimate | None]  # every name of PARAMETERS; None: not determined
    reasons: Mapping[str, str]  # why a parameter is null
    values: Mapping[str, float | None]  # the value used for each parameter (identified or base)
    covariance: tuple[tuple[str, ...], NDArray[np.float64]] | None  # over the identified ones
    chi2: float
    dof: int
    runs: tuple[RunFit, ...]  # per run: chi2, n, residuals
    notes: tuple[str, ...]
    budget: tuple[TypeBTerm, ...] = ()
    cross_check_2f: tuple[Check2f, ...] = ()
    # parameters written to the sensor file as assumptions (not identified): their standard u
    # (from the base sensor's [uncertainty], or the profile of a resonance only bounded) and why
    assumed: Mapping[str, tuple[float | None, str]] = field(default_factory=dict)
    cross_coupling: CrossCoupling | None = None  # the mount-angle runs' fit (fit_cross_coupling)
    _SHOW = ("channel", "parameters", "chi2_reduced", "dof", "runs", "notes")

    @property
    def chi2_reduced(self) -> float | None:
        return self.chi2 / self.dof if self.dof > 0 else None

    def to_dict(self) -> dict[str, Any]:
        params = {n: (None if e is None else {"value": finite_or_none(e.value), "u": finite_or_none(e.u),
                                              "unit": e.unit}) for n, e in self.parameters.items()}
        return {
            "channel": self.channel,
            "parameters": params,
            "null_reasons": dict(self.reasons),
            "values_used": {n: finite_or_none(v) if v is not None else None for n, v in self.values.items()},
            "covariance": None if self.covariance is None else {
                "params": list(self.covariance[0]),
                "matrix": [[finite_or_none(float(c)) for c in row] for row in self.covariance[1]]},
            "chi2_reduced": finite_or_none(self.chi2_reduced),
            "chi2": finite_or_none(self.chi2),
            "dof": self.dof,
            "runs": list(self.runs),
            "budget": list(self.budget),
            "cross_check_2f": list(self.cross_check_2f),
            "assumed": {n: {"value": finite_or_none(self.values.get(n)), "u": finite_or_none(u), "source": why}
                        for n, (u, why) in self.assumed.items()},
            "cross_coupling": None if self.cross_coupling is None else self.cross_coupling.to_dict(),
            "notes": list(self.notes),
        }  # fmt: skip


def value_u(value: float, u: float) -> ValueU:
    """A value and its standard uncertainty as the identification's JSON writes them.

    Examples
    --------
    >>> from vrelab.identification.observation import value_u
    >>> value_u(130.0, 1.5)
    {'value': 130.0, 'u': 1.5}
    """
    return {"value": value, "u": u}


def _is_num(v: object, finite: bool = True) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and (not finite or math.isfinite(v))


# A level's numbers within physical bounds (vrelab._validate's: beyond any shaker, centrifuge or
# shock test), so that a hand-edited document's 1e308 is refused by name instead of overflowing
# in its square deep in the fit.
_LEVEL_BOUNDS = {
    "rms_g": (0.0, V.MAX_LEVEL_G_RMS, f"a vibration rms within 0..{V.MAX_LEVEL_G_RMS:g} g"),
    "vre_g": (-V.MAX_ACCELERATION_G, V.MAX_ACCELERATION_G, f"a VRE within ±{V.MAX_ACCELERATION_G:g} g"),
    "u_vre_g": (0.0, V.MAX_ACCELERATION_G, f"an uncertainty within 0..{V.MAX_ACCELERATION_G:g} g"),
    "freq_hz": (V.MIN_FREQ_HZ, V.MAX_FREQ_HZ, f"a frequency within {V.MIN_FREQ_HZ:g}..{V.MAX_FREQ_HZ:g} Hz"),
}


def check_document(doc: Any) -> None:  # Any: a JSON document, checked here field by field
    """The campaign document's schema, as identification reads it (``vrelab campaign``'s
    results.json, :func:`vrelab.campaigns.campaign_doc`): a ValueError naming the first field
    that is missing or of the wrong type (``runs[2].channels[0].static_g``), never a KeyError or
    a TypeError deep in the fit.

    Examples
    --------
    A document without runs is refused with the reason:

    >>> from vrelab.identification.observation import check_document
    >>> check_document({"kind": "campaign"})
    Traceback (most recent call last):
        ...
    ValueError: identify: campaign document runs must be a list of runs (give a manifest or a `vrelab campaign --out` folder), got None
    """

    def need(where: str, ok: bool, what: str, value: object) -> None:
        if not ok:
            shown = repr(value)
            raise ValueError(f"identify: campaign document {where} must be {what}, got "
                             f"{shown if len(shown) <= 60 else shown[:57] + '...'}")

    missing = object()
    need("(the whole)", isinstance(doc, Mapping), "an object", type(doc).__name__)
    need("runs", isinstance(doc.get("runs"), list), "a list of runs (give a manifest or a `vrelab campaign --out` "
         "folder)", doc.get("runs"))
    for i, run in enumerate(doc["runs"]):
        w = f"runs[{i}]"
        need(w, isinstance(run, Mapping), "an object", run)
        need(f"{w}.index", _is_num(run.get("index")) and float(run["index"]).is_integer(), "an integer",
             run.get("index", "missing"))
        need(f"{w}.status", isinstance(run.get("status"), str), "a string (ok or failed)", run.get("status", "missing"))
        if run["status"] != "ok":
            continue
        need(f"{w}.method", isinstance(run.get("method"), str), "a string (sine or random)", run.get("method", "missing"))
        need(f"{w}.channels", isinstance(run.get("channels"), list), "a list", run.get("channels", "missing"))
        if run.get("budget") is not None:
            need(f"{w}.budget", isinstance(run["budget"], Mapping) and all(_is_num(v) for v in run["budget"].values()),
                 "an object of numbers", run["budget"])
        prof = run.get("profile")
        if prof is not None:
            need(f"{w}.profile", isinstance(prof, Mapping), "an object", prof)
            bp = prof.get("breakpoints")
            need(f"{w}.profile.breakpoints", bp is None or (isinstance(bp, list) and all(
                isinstance(r, list) and len(r) == 2 and all(_is_num(x) for x in r) for r in bp)),
                "a list of [frequency, psd] pairs", bp)
        for j, ch in enumerate(run["channels"]):
            wc = f"{w}.channels[{j}]"
            need(wc, isinstance(ch, Mapping), "an object", ch)
            need(f"{wc}.channel", isinstance(ch.get("channel"), str) and bool(ch.get("channel")), "a channel name",
                 ch.get("channel", "missing"))
            need(f"{wc}.static_g", _is_num(ch.get("static_g", missing)), "a finite number [g]",
                 ch.get("static_g", "missing"))
            need(f"{wc}.static_g", abs(ch["static_g"]) <= V.MAX_ACCELERATION_G,
                 f"a static field within ±{V.MAX_ACCELERATION_G:g} g", ch["static_g"])
            need(f"{wc}.levels", isinstance(ch.get("levels"), list), "a list", ch.get("levels", "missing"))
            if ch.get("mount_deg") is not None or ch.get("mount_plane") is not None:
                need(f"{wc}.mount_deg", _is_num(ch.get("mount_deg")), "a finite number [°]", ch.get("mount_deg"))
                need(f"{wc}.mount_plane", ch.get("mount_plane") in MOUNT_PLANES, "ip or io", ch.get("mount_plane"))
                vec = ch.get("static_vector_g")
                need(f"{wc}.static_vector_g", isinstance(vec, list) and len(vec) == 3 and all(_is_num(v) for v in vec),
                     "three finite numbers [i, p, o] in g", vec)
            for k, lv in enumerate(ch["levels"]):
                wl = f"{wc}.levels[{k}]"
                need(wl, isinstance(lv, Mapping), "an object", lv)
                for key in ("rms_g", "vre_g", "u_vre_g", "freq_hz", "dof"):
                    v = lv.get(key)
                    need(f"{wl}.{key}", v is None or _is_num(v, finite=False), "a number or null", v)
                    if v is not None and math.isfinite(v) and key in _LEVEL_BOUNDS:
                        lo, hi, what = _LEVEL_BOUNDS[key]
                        need(f"{wl}.{key}", lo <= v <= hi, what, v)
                need(f"{wl}.flags", isinstance(lv.get("flags", []), list), "a list", lv.get("flags"))
                b = lv.get("budget")
                need(f"{wl}.budget", b is None or (isinstance(b, list) and all(isinstance(t, Mapping) for t in b)),
                     "a list of terms", b)
                for t in b or ():
                    need(f"{wl}.budget[].u_g", t.get("u_g") is None or _is_num(t.get("u_g"), finite=False),
                         "a number or null", t.get("u_g"))
                h = lv.get("vre_2f")
                need(f"{wl}.vre_2f", h is None or (isinstance(h, Mapping) and all(
                    h.get(x) is None or _is_num(h.get(x), finite=False) for x in ("value", "u"))),
                    "an object with value and u", h)
                for x, key in (("value", "vre_g"), ("u", "u_vre_g")):
                    v = None if h is None else h.get(x)
                    if v is not None and math.isfinite(v):
                        lo, hi, what = _LEVEL_BOUNDS[key]
                        need(f"{wl}.vre_2f.{x}", lo <= v <= hi, what, v)
                dw = lv.get("drive")
                need(f"{wl}.drive", dw is None or isinstance(dw, Mapping), "an object (the reference's waveform)", dw)
                for key, p in (("mean_square_g2", 2), ("mean_cube_g3", 3)):
                    m = None if dw is None else dw.get(key)
                    need(f"{wl}.drive.{key}", m is None or (isinstance(m, Mapping) and all(
                        m.get(x) is None or _is_num(m.get(x), finite=False) for x in ("value", "u"))),
                        "an object with value and u", m)
                    v = None if m is None else m.get("value")
                    if v is not None and math.isfinite(v):
                        top = V.MAX_LEVEL_G_RMS**p
                        need(f"{wl}.drive.{key}.value", (0.0 if p == 2 else -top) <= v <= top,
                             f"within {0 if p == 2 else -top:g}..{top:g} g^{p}", v)


def failed_runs(doc: Mapping[str, Any]) -> list[str]:
    """One line per run of the campaign that failed: it is not in the identification.

    Examples
    --------
    >>> from vrelab.identification.observation import failed_runs
    >>> failed_runs({"runs": [{"index": 1, "label": "Z up", "status": "ok"},
    ...                       {"index": 2, "label": "Z down", "status": "failed", "error": "unreadable file"}]})
    ["run 2 ('Z down') failed (unreadable file): not used"]
    """
    return [f"run {r['index']} ({r.get('label')!r}) failed ({r.get('error') or 'no error given'}): not used"
            for r in doc["runs"] if r.get("status") != "ok"]


def observations(doc: Mapping[str, Any]) -> tuple[dict[str, list[Observation]], dict[str, list[str]]]:
    """Per channel, its runs' levels from a campaign document (:func:`vrelab.campaigns.campaign_doc`).

    The document is checked first (:func:`check_document`). Levels without a finite VRE and a
    positive uncertainty are left out; a random run without its profile (the manifest's
    ``profile``) cannot be modelled and is left out with a note. A failed run is named in every
    channel's notes (:func:`failed_runs`).

    Examples
    --------
    The observations of a campaign of one run (the example campaign's 80 Hz run):

    >>> import vrelab
    >>> from vrelab.identification.observation import observations
    >>> per_channel, notes = observations(vrelab.campaign("examples/campaign/one-run.toml"))
    >>> ob = per_channel["sn1"][0]
    >>> ob.method, ob.static_g, [f"{r:.1f}" for r in ob.rms_g]
    ('sine', 1.0, ['0.2', '0.4', '0.6'])
    """
    check_document(doc)
    obs: dict[str, list[Observation]] = {}
    notes: dict[str, list[str]] = {}
    for run in doc["runs"]:
        if run.get("status") != "ok":
            continue
        for ch in run.get("channels") or ():
            name = ch["channel"]
            obs.setdefault(name, [])
            notes.setdefault(name, [])
            obs[name] += _observation(run, ch, notes[name])
    failed = failed_runs(doc)
    for name in notes:
        notes[name] = failed + notes[name]
    return obs, notes


def _pooled(u: NDArray[np.float64], dof: NDArray[np.float64]) -> NDArray[np.float64]:
    """The levels of one sine frequency share the DUT's noise (the drive is removed exactly, so
    the VRE's scatter is the sensor's and the baselines'), and each level's batch-means u rests
    on few degrees of freedom: their variances are pooled, weighted by those dof (unknown dof:
    the plain mean), so one level whose u came out low by chance does not steer the fit."""
    w = np.where(np.isfinite(dof), dof, 1.0)
    return np.full_like(u, math.sqrt(float(np.sum(w * u**2) / np.sum(w))))


def apparent_vrc(ob: Observation) -> tuple[float, float]:
    """A sine observation's apparent VRC [µg/g²] and its u: the weighted least-squares fit
    through the origin of VRE = VRC·rms² over its levels, which is the weighted mean of each
    level's VRE/rms² (u: its u/rms²), so it is :func:`vrelab.gum.weighted_mean`'s: u scaled up by
    the Birge ratio when the levels scatter about the line more than their u say.

    Examples
    --------
    Two sine runs at 80 Hz of a part with k2 = 100 µg/g² and k3 = 10 µg/g³, axis up (VRC 130 µg/g²)
    and axis down (70 µg/g²), three levels clear of the ±2 g rails, each known to 2 µg:

    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> from vrelab.identification.observation import apparent_vrc
    >>> vrc, u = apparent_vrc(obs[0])
    >>> print(f"{vrc:.1f} ± {u:.2f} µg/g²")
    130.0 ± 5.05 µg/g²
    """
    from vrelab.gum import weighted_mean

    x2 = drive_equivalent(ob)[0] ** 2 if ob.drive else ob.rms_g**2
    e = weighted_mean([Estimate(to_ug(float(v / x)), to_ug(float(u / x)), "ug/g^2")
                       for v, u, x in zip(ob.vre_g, ob.u_g, x2)])
    return e.value, e.u


def _type_a(level: Mapping[str, Any]) -> float | None:
    """A level's Type A standard uncertainty (its budget's record term when a budget was declared)."""
    for term in level.get("budget") or ():
        if term.get("type") == "A":
            u_a: float | None = term.get("u_g")
            return u_a
    u: float | None = level.get("u_vre_g")
    return u


def _drive_moments(level: Mapping[str, Any], rms: float) -> tuple[float, float] | None:
    """A sine level's measured drive moments relative to its fundamental's rms, (E[x²]/rms²,
    E[x³]/rms³) (the campaign document's ``drive``, physics §4.4), or None (a pure sine assumed, as
    without them) when the level carries none or they are not finite."""
    d = level.get("drive")
    if not isinstance(d, Mapping):
        return None
    m2, m3 = ((d.get(k) or {}).get("value") for k in ("mean_square_g2", "mean_cube_g3"))
    if m2 is None or m3 is None or not (math.isfinite(m2) and math.isfinite(m3) and m2 > 0):
        return None
    return float(m2) / rms**2, float(m3) / rms**3


def _observation(run: Mapping[str, Any], ch: Mapping[str, Any], notes: list[str]) -> list[Observation]:
    """A run's levels of one channel: one observation per sine frequency (a run may step
    several), or one for a random run."""
    where = f"run {run['index']} ({run.get('label')!r})"
    method = run.get("method")
    rows = []
    saturated = []
    for lv in ch.get("levels") or ():
        v, u, rms = lv.get("vre_g"), _type_a(lv), lv.get("rms_g")
        if v is None or u is None or rms is None or not (u > 0 and math.isfinite(v) and rms > 0):
            continue
        sat = method == "sine" and "saturated" in (lv.get("flags") or ())
        if sat:
            saturated.append(f"{rms:.4g}")  # the DUT reached a rail: see _modelled for why a sine level must not
        h = lv.get("vre_2f")
        h2f = (float(h["value"]), float(h["u"])) if isinstance(h, Mapping) and h.get("value") is not None \
            and h.get("u") else None
        dof = lv.get("dof")
        rows.append((float(rms), float(v), float(u), lv.get("freq_hz"), h2f,
                     float(dof) if dof is not None and math.isfinite(dof) and dof > 0 else math.inf, sat,
                     _drive_moments(lv, float(rms)) if method == "sine" else None))
    if saturated:
        notes.append(f"{where}: sine level(s) {', '.join(saturated)} g rms flagged saturated by the analysis (DUT "
                     "samples at its rail): left out, unless the identified rails clear their peaks")
    if not rows:
        notes.append(f"{where}: no level with a VRE and its uncertainty: not used")
        return []
    g0 = float(ch["static_g"])
    index, label = int(run["index"]), str(run.get("label", ""))
    mount = None
    if ch.get("mount_deg") is not None:
        vec = ch["static_vector_g"]
        mount = Mount(float(ch["mount_deg"]), str(ch["mount_plane"]), (float(vec[0]), float(vec[1]), float(vec[2])))

    def make(sel: Sequence[tuple[Any, ...]], freq: float | None, profile: RandomProfile | None) -> Observation:
        rms, vre, u, _, h2f, dof, sat, drv = zip(*sel)
        return Observation(index, label, str(method), g0, freq, profile, np.array(rms), np.array(vre),
                           _pooled(np.array(u), np.array(dof)) if freq is not None else np.array(u), tuple(h2f),
                           tuple(sat), mount, tuple(drv) if any(d is not None for d in drv) else ())

    if method == "sine":
        if any(r[3] is None for r in rows):
            notes.append(f"{where}: sine levels without a drive frequency: not used")
            return []
        groups = group_by_frequency(rows, lambda r: r[3])
        return [make(g, float(np.median([r[3] for r in g])), None) for g in groups]
    if method == "random":
        prof = run.get("profile")
        if not prof or not prof.get("breakpoints"):
            notes.append(f"{where}: random run without its profile (the manifest's `profile`, what the controller "
                         "ran): the drive's spectrum is unknown, its levels are not used")
            return []
        bp = np.asarray(prof["breakpoints"], dtype=np.float64)
        return [make(rows, None, RandomProfile(bp[:, 0], bp[:, 1], name=prof.get("name"), source=prof.get("spec")))]
    notes.append(f"{where}: method {method!r}: not used")
    return []


def drive_equivalent(ob: Observation) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per sine level, the pure sine a polynomial sensor rectifies as it does the measured drive
    (physics §4.4): its rms √E[x²] and its static-field shift s = E[x³]/(3·E[x²]) [g].

    For ``f(a) = a + k2·a² + k3·a³`` at ``a = g0 + x``, ``VRE = E[f(g0 + x)] - f(g0) =
    k2·E[x²] + k3·(3·g0·E[x²] + E[x³])`` (the drive's mean is 0), which a pure sine y with
    E[y²] = E[x²] gives exactly at the static field g0 + s: ``k2·E[x²] + 3·k3·(g0 + s)·E[x²]``.
    Exact for the cubic polynomial; assumed, as in the reduction, that the DUT sees the reference's
    waveform (its response at the harmonics that of the fundamental). Levels without a measured
    drive: their rms and no shift (a pure sine).

    Examples
    --------
    Without a measured drive waveform the levels are pure sines: their own rms and static field.

    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> from vrelab.identification.observation import drive_equivalent
    >>> rms_eq, g0_eq = drive_equivalent(obs[0])
    >>> print(rms_eq, g0_eq)
    [0.2 0.4 0.6] [0. 0. 0.]
    """
    q = np.array([d if d is not None else (1.0, 0.0) for d in ob.drive] if ob.drive else [(1.0, 0.0)] * ob.n)
    return ob.rms_g * np.sqrt(q[:, 0]), ob.rms_g * q[:, 1] / (3.0 * q[:, 0])
