"""Result objects: every estimate carries its value, its standard uncertainty and its conditions.

Modelled on lmfit's parameters (``value`` and ``stderr``) and its plain-dict summary: a result
prints as ``-83.1 ± 0.4 mg`` and ``to_dict()`` gives what the CLI's ``--json`` prints. No bare
tuples or ad-hoc dicts travel between modules: bench, analysis, fits and report exchange these.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
from typing import TYPE_CHECKING, Any, Callable, ClassVar, Iterable, Literal, Mapping, Sequence, TypeVar

from vrelab._axes import ByAxis
from vrelab._axes import channels_to_dict as channels_to_dict  # (its former place)
from vrelab._display import Shown
from vrelab._format import finite_or_none, format_mg_text, format_value_u

if TYPE_CHECKING:
    from vrelab.triaxial.result import TriaxialPart

# Two sine levels belong to the same frequency when they differ by at most this fraction: a
# controller steps its drive by much more than 1 % between frequencies, and the frequency an
# analysis estimates from a record scatters by far less.
FREQ_RTOL = 0.01


def same_frequency(a: float | None, b: float | None) -> bool:
    """Whether two drive frequencies [Hz] are the same sine test point (within ``FREQ_RTOL``).

    ``None`` (a random level, or an unknown frequency) matches anything.

    Examples
    --------
    >>> from vrelab.results import same_frequency
    >>> same_frequency(80.0, 80.0000002), same_frequency(80.0, 81.0), same_frequency(None, None)
    (True, False, True)
    """
    return a is None or b is None or abs(a - b) <= FREQ_RTOL * max(abs(a), abs(b))


_T = TypeVar("_T")


def group_by_frequency(items: Iterable[_T], freq: Callable[[_T], float]) -> list[list[_T]]:
    """``items`` grouped by drive frequency, the one rule for every caller: sorted by ``freq``
    (a stable sort: items of one frequency keep their order), each item joins the current group
    when :func:`same_frequency` holds against the group's first (lowest) item, else starts the
    next. The groups, low to high, therefore depend only on the frequencies, never on the order
    the items came in. Every ``freq(item)`` must be a number; callers set aside items without
    one (a random level).

    Examples
    --------
    Sine levels at 80 Hz and 300 Hz, read back with the small scatter of a measured frequency:

    >>> from vrelab.results import group_by_frequency
    >>> group_by_frequency([300.0, 80.0000001, 80.0, 299.9999998], lambda f: f)
    [[80.0, 80.0000001], [299.9999998, 300.0]]
    """
    groups: list[list[_T]] = []
    for x in sorted(items, key=freq):
        if groups and same_frequency(freq(groups[-1][0]), freq(x)):
            groups[-1].append(x)
        else:
            groups.append([x])
    return groups


class Notice(str):
    """A warning a result carries: its text (a ``Notice`` *is* that string, so it prints, joins
    and serialises as one) and a stable ``code`` that code decides on, never the wording.

    Codes in use: ``rail-found`` (a DUT rail found in the data), ``saturated-levels``,
    ``schedule``, ``segment``, ``reference``, ``bracket``, ``frequency``, ``tolerance``,
    ``fit`` (a fit skipped or limited), ``departure`` (data leave the clipping model), ``drive``
    (a sine level whose DUT may not see the reference's distorted waveform),
    ``rate`` (the file library's sample rate differs from the one used: its effect per level),
    ``simulation`` (the simulated test's own), ``note`` (anything else).

    Examples
    --------
    >>> from vrelab.results import Notice
    >>> n = Notice("overrange", "level 3: the DUT over-ranged")
    >>> print(n)
    level 3: the DUT over-ranged
    >>> n.code
    'overrange'
    """

    code: str

    def __new__(cls, code: str, text: str) -> Notice:
        obj = super().__new__(cls, text)
        obj.code = code
        return obj

    def __getnewargs__(self) -> tuple[str, str]:  # type: ignore[override]  # pickling (process pools)
        return (self.code, str(self))

    def to_dict(self) -> dict[str, str]:
        return {"code": self.code, "text": str(self)}


def notice(text: str, code: str = "note") -> Notice:
    """``text`` as a :class:`Notice` (kept as it is when it already is one).

    Examples
    --------
    >>> from vrelab.results import notice
    >>> n = notice("the fit used 3 of 4 levels")
    >>> print(n.code, "|", n)
    note | the fit used 3 of 4 levels
    """
    return text if isinstance(text, Notice) else Notice(code, text)


@dataclass(frozen=True, repr=False)
class Estimate(Shown):
    """A value with its standard uncertainty (k = 1), in ``unit``.

    Examples
    --------
    A VRE of -82.9 mg known to 1.2 mg (standard uncertainty, k = 1):

    >>> from vrelab import Estimate
    >>> vre = Estimate(-0.0829, 0.0012)
    >>> print(f"{vre.value * 1e3:.1f} ± {vre.u * 1e3:.1f} m{vre.unit}")
    -82.9 ± 1.2 mg
    >>> vre.to_dict()
    {'value': -0.0829, 'u': 0.0012, 'unit': 'g'}
    """

    value: float
    u: float
    unit: str = "g"

    def display_fields(self) -> list[tuple[str, Any]]:  # every digit (plain floats, never np.float64(...))
        return [("value", repr(float(self.value))), ("u", repr(float(self.u))), ("unit", self.unit)]

    def __repr__(self) -> str:  # it evaluates back
        return "Estimate(" + ", ".join(f"{k}={v if k != 'unit' else repr(v)}" for k, v in self.display_fields()) + ")"

    def as_field(self) -> str:
        return str(self)

    def expanded(self, k: float) -> float:
        """The expanded uncertainty ``U = k·u`` (GUM 6.2.1) for a coverage factor ``k``: the
        one product behind every U a result carries (:func:`vrelab.gum.level_budget`)."""
        return k * self.u

    def __str__(self) -> str:
        if self.unit == "g" and abs(self.value) < 1:
            return format_mg_text(self.value, self.u, signed=False)
        rel = f" ({100 * self.u / abs(self.value):.2g} %)" if self.value else ""
        return format_value_u(self.value, self.u, unit=self.unit) + rel

    def to_dict(self) -> dict[str, Any]:
        return {"value": finite_or_none(self.value), "u": finite_or_none(self.u), "unit": self.unit}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Estimate:
        return cls(_nan(d["value"]), _nan(d["u"]), d.get("unit", "g"))


def _nan(x: Any) -> float:
    return math.nan if x is None else float(x)


@dataclass(frozen=True, repr=False)
class Conditions(Shown):
    """What a VRE figure depends on (physics §1.4). Unknown fields stay ``None``.

    Examples
    --------
    What a VRE figure depends on; a field not known stays None:

    >>> from vrelab import Conditions
    >>> conditions = Conditions(sensor="adxl355", range_g=2.0, axis="z", static_g=1.0, odr_hz=4000.0)
    >>> conditions.range_g, conditions.bandwidth_hz
    (2.0, None)
    """

    sensor: str | None = None
    model: str | None = None  # "censored", "truncated", "simulation", "measured", ...
    profile: str | None = None  # human description: "random flat 50-2000 Hz", "sine 100 Hz"
    static_g: float | None = None
    range_g: float | None = None
    bandwidth_hz: float | None = None
    odr_hz: float | None = None
    axis: str | None = None
    extra: Mapping[str, Any] = field(default_factory=dict)
    _SHOW = ("sensor", "model", "profile", "static_g", "range_g", "axis")

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["extra"] = dict(self.extra)
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Conditions:
        known = {k: d.get(k) for k in cls.__dataclass_fields__ if k != "extra"}
        return cls(**known, extra=dict(d.get("extra") or {}))


# A sine drive whose THD reaches this (1 %) is named as distorted in notes (physics §4.4); a pure
# drive's measured THD is its reference's noise floor, 1e-5 in the tests' records.
NOTABLE_THD = 0.01


@dataclass(frozen=True, repr=False)
class DriveWaveform(Shown):
    """The reference's waveform over one sine level (physics §4.4): a shaker's drive is not a pure sine.

    ``harmonics_rms_g[h-1]`` is the rms of harmonic h (h = 1 the fundamental), each an
    :class:`Estimate` in g; ``thd`` the total harmonic distortion √(Σ_{h≥2} A_h²)/A_1 (a ratio,
    IEC 60050-551-20-13's definition relative to the fundamental); ``mean_square_g2`` = E[x²] and
    ``mean_cube_g3`` = E[x³] of the mean-removed waveform the harmonics make, the moments a
    polynomial sensor rectifies (physics §1.2: VRE = k2·E[x²] + k3·(3·g0·E[x²] + E[x³]) + ...; for a
    pure sine E[x²] = rms² and E[x³] = 0). ``residual_rms_g``: the rms the harmonics leave
    (the reference's noise, motion at other frequencies), which the moments do not hold.

    Examples
    --------
    The drive waveform of each level of a sine test, as the reduction measures it from the
    reference (one level of ``vrelab.simulate``'s sine method, ±2 g ADXL355 at 100 Hz):

    >>> import vrelab
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> result = vrelab.simulate(sensor, levels=[1.0], static_g=1.0, freq_hz=100, seconds=2, seed=1)
    >>> drive = result.levels[0].drive
    >>> print(f"THD {drive.thd.value:.4f}, E[x²] {drive.mean_square_g2.value:.4f} g²")
    THD 0.0000, E[x²] 1.0000 g²
    """

    harmonics_rms_g: tuple[Estimate, ...]
    thd: Estimate
    mean_square_g2: Estimate
    mean_cube_g3: Estimate
    residual_rms_g: float
    _SHOW = ("thd", "harmonics_rms_g", "mean_square_g2", "mean_cube_g3")

    @property
    def distorted(self) -> bool:
        """Whether the drive's THD reaches ``NOTABLE_THD``: what the fits and the DUT-response
        check name in their notes (the moments are used whatever the THD)."""
        return math.isfinite(self.thd.value) and self.thd.value >= NOTABLE_THD

    def to_dict(self) -> dict[str, Any]:
        return {
            "harmonics": [{"h": i + 1, "rms_g": finite_or_none(e.value), "u": finite_or_none(e.u)}
                          for i, e in enumerate(self.harmonics_rms_g)],
            "thd": {"value": finite_or_none(self.thd.value), "u": finite_or_none(self.thd.u)},
            "mean_square_g2": {"value": finite_or_none(self.mean_square_g2.value),
                               "u": finite_or_none(self.mean_square_g2.u)},
            "mean_cube_g3": {"value": finite_or_none(self.mean_cube_g3.value), "u": finite_or_none(self.mean_cube_g3.u)},
            "residual_rms_g": finite_or_none(self.residual_rms_g),
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> DriveWaveform:
        def est(e: Mapping[str, Any], unit: str) -> Estimate:
            return Estimate(_nan(e.get("value")), _nan(e.get("u")), unit)

        return cls(
            harmonics_rms_g=tuple(Estimate(_nan(h.get("rms_g")), _nan(h.get("u")), "g") for h in d.get("harmonics") or ()),
            thd=est(d["thd"], "1"),
            mean_square_g2=est(d["mean_square_g2"], "g^2"),
            mean_cube_g3=est(d["mean_cube_g3"], "g^3"),
            residual_rms_g=_nan(d.get("residual_rms_g")),
        )

    def scaled(self, factor: float) -> DriveWaveform:
        """The waveform as a reference whose sensitivity is off by ``factor`` would read it: every
        amplitude times factor, E[x²] times factor², E[x³] times factor³ (the GUM budget's
        perturbation of the reference sensitivity, :func:`vrelab.gum.perturb_levels`)."""
        def sc(e: Estimate, p: int) -> Estimate:
            return Estimate(e.value * factor**p, e.u * abs(factor) ** p, e.unit)

        return DriveWaveform(tuple(sc(e, 1) for e in self.harmonics_rms_g), self.thd, sc(self.mean_square_g2, 2),
                             sc(self.mean_cube_g3, 3), self.residual_rms_g * abs(factor))


def level_vrc(vre_g: float, rms_g: float, u_vre_g: float | None = None,
              u_rms_g: float | None = None) -> tuple[float, float | None]:
    """The level's VRC [µg/g²]: its VRE per vibration mean square, ``VRE / rms²`` (physics §1.2:
    ``VRE = VRC·vib_rms²``; the datasheets' figure, k2 + 3·k3·g0 where the polynomial alone
    rectifies), and its standard uncertainty by GUM 5.1.2 with VRE and rms uncorrelated:
    ``u² = (u_vre/rms²)² + (2·VRE·u_rms/rms³)²`` (``u_rms_g`` None: the rms is exact, as in a
    prediction). NaN (and u None) where the rms is not > 0 or the VRE is not finite; u None
    without ``u_vre_g``.

    Examples
    --------
    A VRE of 0.40 ± 0.03 mg at 2 g rms is a VRC of 100 ± 7.5 µg/g²:

    >>> from vrelab.results import level_vrc
    >>> vrc, u = level_vrc(4e-4, 2.0, 3e-5)
    >>> print(f"{vrc:.1f} ± {u:.1f} µg/g²")
    100.0 ± 7.5 µg/g²
    """
    from vrelab.units import UG_PER_G  # (units imports numpy: not at this light module's import)

    if not (math.isfinite(rms_g) and rms_g > 0 and math.isfinite(vre_g)):
        return math.nan, None
    vrc = vre_g / rms_g**2 * UG_PER_G
    if u_vre_g is None or not math.isfinite(u_vre_g):
        return vrc, None
    rel_rms = (u_rms_g / rms_g) if u_rms_g is not None and math.isfinite(u_rms_g) else 0.0
    return vrc, math.hypot(u_vre_g / rms_g**2 * UG_PER_G, 2.0 * vrc * rel_rms)


@dataclass(frozen=True, repr=False)
class LevelResult(Shown):
    """VRE measured (or simulated) at one vibration level.

    Examples
    --------
    One level of a test: its rms, its VRE with u, and what follows (the VRC, VRE/rms²):

    >>> from vrelab import Estimate, LevelResult
    >>> level = LevelResult(rms_g=2.0, vre=Estimate(4e-4, 3e-5))
    >>> print(f"{level.vrc.value:.1f} ± {level.vrc.u:.1f} {level.vrc.unit}")
    100.0 ± 7.5 ug/g^2
    """

    rms_g: float  # vibration level: reference rms in the test band (or at the drive frequency)
    vre: Estimate  # in g
    freq_hz: float | None = None  # sine method
    u_rms_g: float | None = None
    duration_s: float | None = None
    n_samples: int | None = None
    n_saturated: int = 0
    flags: tuple[str, ...] = ()
    # effective degrees of freedom of ``vre.u`` (the record's Type A: batch means), inf if unknown
    dof: float | None = None
    # the GUM budget (vrelab.gum): u_vre_g combined with the Type B terms, U = k·u, the terms
    budget: tuple[Mapping[str, Any], ...] = ()
    U_vre_g: float | None = None
    k: float | None = None
    decision: str | None = None  # pass | fail | indeterminate against a limit (vrelab.gum.decide)
    # sine: the rectified shift estimated from the DUT's 2f line less the reference's (immune to
    # drift; the analysis's _sine_level says how), beside the DC estimate ``vre``
    vre_2f: Estimate | None = None
    # sine: the reference's waveform over the level (harmonics, THD, E[x²], E[x³]); None for a
    # random level or a record without a reference
    drive: DriveWaveform | None = None
    _SHOW = ("freq_hz", "rms_g", "vre", "vrc", "U_vre_g", "k", "decision", "flags")

    @property
    def vrc(self) -> Estimate:
        """The level's VRC ``VRE / rms²`` [µg/g²] and its u (:func:`level_vrc`, the rms's u included)."""
        v, u = level_vrc(self.vre.value, self.rms_g, self.vre.u, self.u_rms_g)
        return Estimate(v, math.nan if u is None else u, "ug/g^2")

    def to_dict(self) -> dict[str, Any]:
        vrc = self.vrc
        d: dict[str, Any] = {
            "rms_g": finite_or_none(self.rms_g),
            "vre_g": finite_or_none(self.vre.value),
            "u_vre_g": finite_or_none(self.vre.u),
            "vrc_ug_per_g2": finite_or_none(vrc.value),
            "u_vrc_ug_per_g2": finite_or_none(vrc.u),
        }
        if self.budget:
            d.update(U_vre_g=finite_or_none(self.U_vre_g), k=finite_or_none(self.k),
                     budget=[dict(b) for b in self.budget])
        if self.decision is not None:
            d["decision"] = self.decision
        if self.dof is not None:
            d["dof"] = finite_or_none(self.dof)
        if self.freq_hz is not None:
            d["freq_hz"] = finite_or_none(self.freq_hz)
        if self.vre_2f is not None:
            d["vre_2f"] = {"value": finite_or_none(self.vre_2f.value), "u": finite_or_none(self.vre_2f.u)}
        if self.drive is not None:
            d["drive"] = self.drive.to_dict()
        d.update(
            u_rms_g=finite_or_none(self.u_rms_g),
            duration_s=finite_or_none(self.duration_s),
            n_samples=self.n_samples,
            n_saturated=int(self.n_saturated),
            flags=list(self.flags),
        )
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> LevelResult:
        return cls(
            rms_g=_nan(d["rms_g"]),
            vre=Estimate(_nan(d["vre_g"]), _nan(d["u_vre_g"]), "g"),
            freq_hz=d.get("freq_hz"),
            u_rms_g=d.get("u_rms_g"),
            duration_s=d.get("duration_s"),
            n_samples=d.get("n_samples"),
            n_saturated=int(d.get("n_saturated") or 0),
            flags=tuple(d.get("flags") or ()),
            dof=math.inf if "dof" in d and d["dof"] is None else d.get("dof"),
            budget=tuple(d.get("budget") or ()),
            U_vre_g=d.get("U_vre_g"),
            k=d.get("k"),
            decision=d.get("decision"),
            vre_2f=Estimate(_nan(d["vre_2f"]["value"]), _nan(d["vre_2f"]["u"]), "g") if d.get("vre_2f") else None,
            drive=DriveWaveform.from_dict(d["drive"]) if isinstance(d.get("drive"), Mapping) else None,
        )


# --- the fitted models ------------------------------------------------------------------------
# Each fit model is a small frozen class: its name (what results files and reports call it), its
# parameters (name -> Estimate, in the order of the fit's covariance), its equation and source,
# and ``eval(rms_g)``, the VRE it gives at a level. Code asks the model (``vrc``, ``rail``,
# ``no_fit_reason``, ``static_coefficients``) instead of branching on its name. The classes live
# here beside FitResult, not in vrelab.fits: results files are read back (FitResult.from_dict)
# without the fitting code, and fits imports this module (no import cycle, tests/test_imports.py).


def _ug(e: Estimate | None) -> float:
    """An Estimate in µg/g^n (or its absence, 0) as g/g^n."""
    from vrelab.units import UG_PER_G  # (units imports numpy: not at this light module's import)

    return 0.0 if e is None else e.value / UG_PER_G


def _as_rms(rms_g: Any) -> Any:
    """``rms_g`` [g] as a float array (a scalar stays 0-d), refused unless finite and >= 0."""
    import numpy as np

    r = np.asarray(rms_g, dtype=np.float64)
    if not (np.all(np.isfinite(r)) and np.all(r >= 0)):
        raise ValueError(f"rms_g must be finite and >= 0, got {rms_g!r}")
    return r


def _out(x: Any) -> Any:
    """A 0-d result as a float, an array as it is."""
    return float(x) if getattr(x, "ndim", 1) == 0 else x


@dataclass(frozen=True, repr=False)
class FitModel(Shown):
    """A fitted model: its parameters and the VRE [g] it gives at a vibration level.

    ``params`` maps the parameter names (units in them: ``vrc_ug_per_g2``, ``rail_g``) to
    estimates, in the order of the fit's covariance. ``PARAMS``: the parameter sets the model
    accepts (each a tuple of names); a model built with another set is refused.

    Examples
    --------
    Every model gives the VRE [g] at a vibration level from its parameters:

    >>> from vrelab import Estimate
    >>> from vrelab.results import VrcModel
    >>> model = VrcModel({"vrc_ug_per_g2": Estimate(100.0, 3.0, "ug/g^2")})
    >>> print(model.name, f"{model.eval(2.0) * 1e3:.2f} mg")
    vrc 0.40 mg
    """

    params: Mapping[str, Estimate]
    NAME: ClassVar[str] = ""
    PARAMS: ClassVar[tuple[tuple[str, ...], ...]] = ()
    _SHOW = ("name", "params")

    def __post_init__(self) -> None:
        if self.PARAMS and set(self.params) not in [set(p) for p in self.PARAMS]:
            need = " or ".join("(" + ", ".join(p) + ")" for p in self.PARAMS)
            raise ValueError(f"fit model {self.name!r}: parameters {tuple(self.params)} are not {need}")

    @property
    def name(self) -> str:
        """What results files, reports and the CLI call the model."""
        return self.NAME

    def __str__(self) -> str:
        return self.name

    def eval(self, rms_g: Any, static_g: float | None = None) -> Any:
        """The fitted VRE [g] at vibration level(s) ``rms_g`` [g rms] (a float, or an array like
        ``rms_g``). ``static_g`` [g]: the static field, for a model fitted across orientations
        (k2-k3); a model fitted at one field gives the VRE at that field and refuses another."""
        raise NotImplementedError

    @property
    def vrc(self) -> Estimate | None:
        """The VRC [µg/g²] where the model is physics §1.2's ``VRE = VRC·rms²`` alone, else None."""
        return None

    @property
    def rail(self) -> Estimate | None:
        """The symmetric effective rail ±r [g] where the model has one, else None."""
        return None

    def no_fit_reason(self, n_points: int) -> str | None:
        """Why a fit of this model over ``n_points`` points determines nothing (None: it does)."""
        return None

    def static_coefficients(self, rms_g: Sequence[float], static_g: float) -> list[float | None] | None:
        """∂VRE/∂g0 at each level, where the model gives it (None: it does not depend on g0)."""
        return None

    def with_params(self, params: Mapping[str, Estimate]) -> FitModel:
        """The same model with other estimates of its parameters (a budget's combined u)."""
        return replace(self, params=dict(params))

    def to_dict(self) -> dict[str, Any]:
        return {"model": self.name, "parameters": {k: v.to_dict() for k, v in self.params.items()}}


def _one_field(model: FitModel, static_g: float | None) -> None:
    if static_g is not None:
        raise ValueError(f"fit model {model.name!r} holds at the static field it was fitted at: "
                         "it takes no static_g")


@dataclass(frozen=True, repr=False)
class VrcModel(FitModel):
    """physics §1.2 and IEEE Std 1293-1998: ``VRE = VRC·rms²`` [g], VRC [µg/g²] = k2 + 3·k3·g0 at the
    static field g0 the levels were measured at (a sine fit over a distorted drive: at g0 +
    ``FitResult.static_shift_g``, :func:`vrelab.fits.fit_vrc`).

    Examples
    --------
    VRC = 100 µg/g²: at 2 g rms, 0.4 mg.

    >>> from vrelab import Estimate
    >>> from vrelab.results import VrcModel
    >>> print(f"{VrcModel({'vrc_ug_per_g2': Estimate(100.0, 3.0, 'ug/g^2')}).eval(2.0) * 1e3:.2f} mg")
    0.40 mg
    """

    NAME: ClassVar[str] = "vrc"
    PARAMS: ClassVar[tuple[tuple[str, ...], ...]] = (("vrc_ug_per_g2",),)

    def eval(self, rms_g: Any, static_g: float | None = None) -> Any:
        _one_field(self, static_g)
        r = _as_rms(rms_g)
        return _out(_ug(self.params["vrc_ug_per_g2"]) * r**2)

    @property
    def vrc(self) -> Estimate | None:
        return self.params["vrc_ug_per_g2"]

    def no_fit_reason(self, n_points: int) -> str | None:
        return "one level only (a VRC needs two levels or more)" if n_points < 2 else None


@dataclass(frozen=True, repr=False)
class VrcK4Model(FitModel):
    """physics §1.2 with the quartic term: ``VRE = VRC·rms² + c4·rms⁴`` [g], c4 [µg/g⁴] =
    k4·E[x⁴]/rms⁴ (3·k4 for Gaussian vibration, 1.5·k4 for a sine; :func:`vrelab.fits.fit_vrc`).

    Examples
    --------
    VRC = 100 µg/g² and c4 = 10 µg/g⁴: at 2 g rms, 0.4 + 0.16 mg.

    >>> from vrelab import Estimate
    >>> from vrelab.results import VrcK4Model
    >>> model = VrcK4Model({"vrc_ug_per_g2": Estimate(100.0, 3.0, "ug/g^2"), "c4_ug_per_g4": Estimate(10.0, 1.0, "ug/g^4")})
    >>> print(f"{model.eval(2.0) * 1e3:.2f} mg")
    0.56 mg
    """

    NAME: ClassVar[str] = "vrc+k4"
    PARAMS: ClassVar[tuple[tuple[str, ...], ...]] = (("vrc_ug_per_g2", "c4_ug_per_g4"),)

    def eval(self, rms_g: Any, static_g: float | None = None) -> Any:
        _one_field(self, static_g)
        r = _as_rms(rms_g)
        return _out(_ug(self.params["vrc_ug_per_g2"]) * r**2 + _ug(self.params["c4_ug_per_g4"]) * r**4)


@dataclass(frozen=True, repr=False)
class ClipModel(FitModel):
    """physics §1.1 (the Analog Devices article): Gaussian vibration of rms σ at static field g0
    clipped at the rails, ``VRE(σ) = E[clip(g0 + x)] − g0`` (``kind`` "censored": samples beyond
    a rail read as the rail, :func:`vrelab.models.clipping.censored_mean_shift`; "truncated":
    they are discarded, ``truncated_mean_shift``), ``+ VRC·σ²`` when fitted with the VRC term.
    Rails ±``rail_g`` or (``rail_low_g``, ``rail_high_g``) [g]; ``static_g`` the field it was
    fitted at (None: unknown, in a results file written before it was recorded).

    Examples
    --------
    The article's Figure 1 as a fitted model: rails at ±2 g, a 1 g field, 1 g rms.

    >>> from vrelab import Estimate
    >>> from vrelab.results import ClipModel
    >>> model = ClipModel({"rail_g": Estimate(2.0, 0.01)}, static_g=1.0)
    >>> print(f"{model.eval(1.0) * 1e3:.1f} mg")
    -82.9 mg
    """

    kind: str = "censored"
    static_g: float | None = None
    PARAMS: ClassVar[tuple[tuple[str, ...], ...]] = (
        ("rail_g",), ("rail_low_g", "rail_high_g"), ("rail_g", "vrc_ug_per_g2"),
        ("rail_low_g", "rail_high_g", "vrc_ug_per_g2"))

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.kind not in ("censored", "truncated"):
            raise ValueError(f"clip model: kind must be censored or truncated, got {self.kind!r}")

    @property
    def name(self) -> str:
        return f"clip-{self.kind}"

    def _rails(self) -> tuple[float, float]:
        p = self.params
        if "rail_g" in p:
            return -p["rail_g"].value, p["rail_g"].value
        return p["rail_low_g"].value, p["rail_high_g"].value

    def _shift(self) -> Callable[..., Any]:
        from vrelab.models import clipping

        return clipping.censored_mean_shift if self.kind == "censored" else clipping.truncated_mean_shift

    def eval(self, rms_g: Any, static_g: float | None = None) -> Any:
        if self.static_g is None:
            raise ValueError(f"fit model {self.name!r}: the static field it was fitted at is unknown "
                             "(a results file written before it was recorded): no VRE")
        if static_g is not None and static_g != self.static_g:
            raise ValueError(f"fit model {self.name!r} was fitted at {self.static_g:g} g: it gives no VRE "
                             f"at {static_g:g} g")
        r = _as_rms(rms_g)
        low, high = self._rails()
        return _out(self._shift()(self.static_g, r, low, high) + _ug(self.params.get("vrc_ug_per_g2")) * r**2)

    @property
    def rail(self) -> Estimate | None:
        return self.params.get("rail_g")

    def static_coefficients(self, rms_g: Sequence[float], static_g: float) -> list[float | None] | None:
        # a central difference of the Gaussian mean shift: the clipping alone moves with g0
        shift, (lo, hi), h = self._shift(), self._rails(), 1e-4
        return [float(shift(static_g + h, r, lo, hi) - shift(static_g - h, r, lo, hi)) / (2 * h)
                if math.isfinite(r) and r > 0 else None for r in rms_g]

    def to_dict(self) -> dict[str, Any]:
        return {**super().to_dict(), "static_g": finite_or_none(self.static_g)}


def _static_g(model: FitModel, static_g: float | None) -> float:
    if static_g is None or not math.isfinite(static_g):
        raise ValueError(f"fit model {model.name!r}: the VRE depends on the static field: give a finite static_g, "
                         f"got {static_g!r}")
    return float(static_g)


@dataclass(frozen=True, repr=False)
class K2K3Model(FitModel):
    """physics §1.2 across orientations: ``VRE = (k2 + 3·k3·g0)·rms²`` [g] at static field g0 (the k4
    term ``6·k4·g0²`` folds into k2 at ±g0; :func:`vrelab.fits.fit_k2_k3`).

    Examples
    --------
    k2 = 100 µg/g², k3 = 10 µg/g³ at 2 g rms, axis up (+1 g) and down (-1 g):

    >>> from vrelab import Estimate
    >>> from vrelab.results import K2K3Model
    >>> model = K2K3Model({"k2_ug_per_g2": Estimate(100.0, 3.0, "ug/g^2"), "k3_ug_per_g3": Estimate(10.0, 1.0, "ug/g^3")})
    >>> print(f"{model.eval(2.0, static_g=1.0) * 1e3:.2f} mg, {model.eval(2.0, static_g=-1.0) * 1e3:.2f} mg")
    0.52 mg, 0.28 mg
    """

    NAME: ClassVar[str] = "k2-k3"
    PARAMS: ClassVar[tuple[tuple[str, ...], ...]] = (("k2_ug_per_g2", "k3_ug_per_g3"),)

    def eval(self, rms_g: Any, static_g: float | None = None) -> Any:
        g0 = _static_g(self, static_g)
        r = _as_rms(rms_g)
        return _out((_ug(self.params["k2_ug_per_g2"]) + 3.0 * _ug(self.params["k3_ug_per_g3"]) * g0) * r**2)


@dataclass(frozen=True, repr=False)
class K2Model(FitModel):
    """k2 alone, the VRC at 0 g (physics §1.2: VRC(0) = k2, a campaign's k2 from runs at 0 g only):
    ``VRE = k2·rms²`` [g] at 0 g, the field it was measured at (k3 unknown: no other field).

    Examples
    --------
    >>> from vrelab import Estimate
    >>> from vrelab.results import K2Model
    >>> print(f"{K2Model({'k2_ug_per_g2': Estimate(100.0, 3.0, 'ug/g^2')}).eval(2.0) * 1e3:.2f} mg")
    0.40 mg
    """

    NAME: ClassVar[str] = "k2"
    PARAMS: ClassVar[tuple[tuple[str, ...], ...]] = (("k2_ug_per_g2",),)

    def eval(self, rms_g: Any, static_g: float | None = None) -> Any:
        _one_field(self, static_g)
        r = _as_rms(rms_g)
        return _out(_ug(self.params["k2_ug_per_g2"]) * r**2)


# the models by name, as results files name them
_MODELS: dict[str, Callable[..., FitModel]] = {
    "vrc": VrcModel, "vrc+k4": VrcK4Model, "k2-k3": K2K3Model, "k2": K2Model,
    "clip-censored": lambda params, static_g=None: ClipModel(params, "censored", static_g),
    "clip-truncated": lambda params, static_g=None: ClipModel(params, "truncated", static_g),
}


def fit_model(name: str, params: Mapping[str, Estimate], static_g: float | None = None) -> FitModel:
    """The model called ``name`` in a results file, with ``params`` (and, for a clipping model,
    the static field it was fitted at).

    Examples
    --------
    The model a results file names, rebuilt from its parameters:

    >>> from vrelab import Estimate
    >>> from vrelab.results import fit_model
    >>> model = fit_model("vrc", {"vrc_ug_per_g2": Estimate(100.0, 3.0, "ug/g^2")})
    >>> print(type(model).__name__, f"{model.eval(2.0) * 1e3:.2f} mg")
    VrcModel 0.40 mg
    """
    if name not in _MODELS:
        raise ValueError(f"unknown fit model {name!r}: one of {', '.join(_MODELS)}")
    if name.startswith("clip-"):
        return _MODELS[name](dict(params), static_g)
    return _MODELS[name](dict(params))


@dataclass(frozen=True, repr=False)
class FitResult(Shown):
    """A fitted model (:class:`FitModel`: its name, its parameters with standard errors, the VRE
    it gives) and how it was fitted. ``departure_rms_g`` is the first level at which the data
    leave the model (None when they never do).

    Examples
    --------
    A VRC fitted through three levels of a k2 = 100 µg/g² sensor, and the VRE it gives at 2.5 g rms:

    >>> from vrelab import Estimate, LevelResult
    >>> from vrelab.fits import fit_vrc
    >>> fit = fit_vrc([LevelResult(rms_g=r, vre=Estimate(1e-4 * r**2, 3e-5)) for r in (1.0, 2.0, 3.0)])
    >>> print(fit.model.name, fit.n_points, f"{fit.params['vrc_ug_per_g2'].value:.1f}", f"{fit.eval(2.5) * 1e3:.3f} mg")
    vrc 3 100.0 0.625 mg
    >>> fit.to_dict()["parameters"]["vrc_ug_per_g2"]["unit"]
    'ug/g^2'
    """

    model: FitModel
    n_points: int
    chi2_reduced: float | None = None
    freq_hz: float | None = None
    levels_used: tuple[float, ...] = ()  # rms_g of the levels that entered the fit
    departure_rms_g: float | None = None
    notes: tuple[str, ...] = ()
    # Covariance of the fitted parameters, in the order and units of ``params`` (each row and
    # column a parameter; its diagonal is each ``u``²): identification and prediction carry it.
    covariance: tuple[tuple[float, ...], ...] | None = None
    # a sine VRC fit over a distorted drive (physics §4.4): the drive's E[x³] makes the cubic term
    # rectify as at g0 + static_shift_g, so VRC = k2 + 3·k3·(g0 + static_shift_g) (None: a pure drive)
    static_shift_g: float | None = None
    _SHOW = ("model", "freq_hz", "n_points", "chi2_reduced", "departure_rms_g", "notes")

    @property
    def params(self) -> Mapping[str, Estimate]:
        """The model's parameters: names with units in them (``vrc_ug_per_g2``, ``rail_g``,
        ``k3_ug_per_g3``) to estimates."""
        return self.model.params

    @property
    def no_fit_reason(self) -> str | None:
        """Why this fit determines nothing (one level for a VRC), None when it does."""
        return self.model.no_fit_reason(self.n_points)

    def eval(self, rms_g: Any, static_g: float | None = None) -> Any:
        """The fitted VRE [g] at ``rms_g`` [g rms] (:meth:`FitModel.eval`)."""
        return self.model.eval(rms_g, static_g)

    def __str__(self) -> str:
        ps = ", ".join(f"{k} = {v}" for k, v in self.params.items())
        return f"{self.model.name}: {ps}"

    def to_dict(self) -> dict[str, Any]:
        """``model`` (its name), ``parameters`` {name: {value, u, unit}} (nested; earlier
        versions wrote them beside ``model``: :meth:`from_dict` reads both forms), the fit's
        figures; a clipping model adds the ``static_g`` it was fitted at."""
        d = self.model.to_dict()
        d.update(
            n_points=self.n_points,
            chi2_reduced=finite_or_none(self.chi2_reduced),
            freq_hz=finite_or_none(self.freq_hz),
            levels_used=[finite_or_none(x) for x in self.levels_used],
            departure_rms_g=finite_or_none(self.departure_rms_g),
            notes=list(self.notes),
        )
        if self.static_shift_g is not None:
            d["static_shift_g"] = finite_or_none(self.static_shift_g)
        if self.covariance is not None:
            d["covariance"] = {"params": list(self.params),
                               "matrix": [[finite_or_none(c) for c in row] for row in self.covariance]}
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> FitResult:
        if isinstance(d.get("parameters"), Mapping):
            raw = d["parameters"]
        else:  # the flat form of earlier files: every mapping beside the fit's own keys is a parameter
            raw = {k: v for k, v in d.items() if k not in _FIT_KEYS and isinstance(v, Mapping)}
        params = {k: Estimate.from_dict(v) for k, v in raw.items()}
        return cls(
            model=fit_model(d["model"], params, d.get("static_g")),
            n_points=int(d["n_points"]),
            chi2_reduced=d.get("chi2_reduced"),
            freq_hz=d.get("freq_hz"),
            levels_used=tuple(x for x in d.get("levels_used") or () if x is not None),
            departure_rms_g=d.get("departure_rms_g"),
            notes=tuple(d.get("notes") or ()),
            covariance=tuple(tuple(math.nan if c is None else float(c) for c in row)
                             for row in d["covariance"]["matrix"]) if d.get("covariance") else None,
            static_shift_g=d.get("static_shift_g"),
        )


# a fit's own keys in its dict (the rest of an old, flat one are its parameters)
_FIT_KEYS = frozenset({"model", "parameters", "static_g", "n_points", "chi2_reduced", "freq_hz", "levels_used",
                       "departure_rms_g", "notes", "covariance", "static_shift_g"})


Method = Literal["random", "sine"]


@dataclass(frozen=True, repr=False)
class NoiseResult(Shown):
    """A DUT channel's own noise on the vibration-off stretches of its record (physics §4.4): what a
    metrologist checks first (:func:`vrelab.analysis.noise.channel_noise`).

    ``density`` [µg/√Hz]: the white level √h₀ of the fitted ``S(f) = h₀ + h₋₁/f + h₋₂/f²``,
    one-sided (as datasheets state it; IEEE Std 952's N is ``density/√2``), at the frequencies
    the windows resolve (below ``1/(2·window)``); ``bias_instability`` [µg]: ``B = √(π·h₋₁)``
    (IEEE Std 952-1997 C.3: the Allan deviation's flicker floor is ``0.664·B``); ``adev``: the
    overlapping Allan deviation [µg] at ``tau_s`` (IEEE Std 1554), pooled over ``n_stretches``
    stretches, ``off_s`` seconds of record in all; ``n_pairs`` pairs of τ-means per point.

    Examples
    --------
    A DUT's own noise, measured on the vibration-off stretches of a record (the example campaign's
    80 Hz run, whose parts were simulated with 25 µg/√Hz; ``noise`` is None where the record has
    too little vibration-off time):

    >>> import vrelab
    >>> result = vrelab.analyze("examples/campaign/runs/01_z_up_80hz.tdms", dut="shaker/sn1_z",
    ...                         reference="shaker/ref", dut_units="lsb", dut_sensitivity=256000,
    ...                         reference_units="mv", reference_sensitivity=10)
    >>> noise = result.noise
    >>> print(f"{noise.density_ug_rthz.value:.0f} ± {noise.density_ug_rthz.u:.0f} µg/√Hz")
    22 ± 3 µg/√Hz
    """

    density_ug_rthz: Estimate
    bias_instability_ug: Estimate
    tau_s: tuple[float, ...]
    adev_ug: tuple[float, ...]
    n_pairs: tuple[int, ...]
    off_s: float
    n_stretches: int
    window_s: float
    _SHOW = ("density_ug_rthz", "bias_instability_ug", "off_s", "n_stretches")

    def __str__(self) -> str:
        i = int(min(range(len(self.adev_ug)), key=lambda j: self.adev_ug[j])) if self.adev_ug else -1
        low = f"; Allan deviation {self.adev_ug[i]:.3g} µg at {self.tau_s[i]:.3g} s (its minimum)" if i >= 0 else ""
        bi = self.bias_instability_ug
        bi_text = (f"{format_value_u(bi.value, bi.u)} µg" if math.isfinite(bi.value) and math.isfinite(bi.u)
                   else "not resolved (the stretches are too short to tell flicker from white noise)")
        return (f"noise on {self.off_s:.3g} s vibration-off ({self.n_stretches} stretch(es)): density "
                f"{format_value_u(self.density_ug_rthz.value, self.density_ug_rthz.u)} µg/√Hz, bias instability "
                f"{bi_text} (IEEE 952){low}")

    def to_dict(self) -> dict[str, Any]:
        return {
            "density_ug_rthz": self.density_ug_rthz.to_dict(),
            "bias_instability_ug": self.bias_instability_ug.to_dict(),
            "allan": {"tau_s": [finite_or_none(x) for x in self.tau_s],
                      "adev_ug": [finite_or_none(x) for x in self.adev_ug],
                      "n_pairs": list(self.n_pairs)},
            "off_s": finite_or_none(self.off_s),
            "n_stretches": self.n_stretches,
            "window_s": finite_or_none(self.window_s),
            "conventions": "density one-sided (IEEE 952 N = density/√2); bias instability B of IEEE 952 C.3 "
                           "(flicker floor of the Allan deviation = 0.664·B); overlapping Allan deviation (IEEE 1554)",
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> NoiseResult:
        a = d.get("allan") or {}
        return cls(Estimate.from_dict(d["density_ug_rthz"]), Estimate.from_dict(d["bias_instability_ug"]),
                   tuple(_nan(x) for x in a.get("tau_s") or ()), tuple(_nan(x) for x in a.get("adev_ug") or ()),
                   tuple(int(x) for x in a.get("n_pairs") or ()), _nan(d.get("off_s")),
                   int(d.get("n_stretches") or 0), _nan(d.get("window_s")))


@dataclass(frozen=True, repr=False, eq=False)  # (eq: ByAxis's, on the fields as stored)
class VreResult(ByAxis, Shown):
    """A whole test (simulated or measured), one DUT axis or several (``axes``, ``triaxial``:
    :mod:`vrelab._axes`): levels, fits, warnings, provenance.

    ``to_dict()`` is the document that ``simulate --json``, ``analyze --json`` print and that
    ``--out DIR`` writes as ``results.json``; ``vrelab report DIR`` reads it back with
    ``from_dict``. ``fit`` in the dict merges the parameters of all fits (the CLI reference asks
    for ``fit.vrc_ug_per_g2`` and ``fit.rail_g``); ``fits`` keeps each fit whole.

    Examples
    --------
    A whole test: its levels, fits and conditions (here a simulated one of two sine levels):

    >>> import vrelab
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> result = vrelab.simulate(sensor, levels=[0.5, 1.0], static_g=1.0, freq_hz=100, seconds=2, seed=1)
    >>> result.method, result.kind, len(result.levels), [fit.model.name for fit in result.fits]
    ('sine', 'simulation', 2, ['vrc'])
    >>> print(result.conditions.sensor, result.conditions.range_g)
    adxl355 2.0

    The same test along 45° in x-z: a triaxial one, the same type, its one DUT axis read alike:

    >>> tri = vrelab.TriaxialSine(100.0, (1.0, 0.0, 1.0))
    >>> test = vrelab.simulate(sensor, tri, [0.5, 1.0], static_g=(0, 0, 1), seconds=2, seed=1)
    >>> type(test).__name__, list(test.axes), len(test.levels), [fit.model.name for fit in test.fits]
    ('VreResult', ['z'], 2, ['vrc'])
    >>> test.triaxial.static_g, len(test.reference_levels)
    ((0.0, 0.0, 1.0), 2)
    """

    method: Method
    conditions: Conditions
    levels: tuple[LevelResult, ...]
    fits: tuple[FitResult, ...] = ()
    warnings: tuple[str, ...] = ()
    provenance: Mapping[str, Any] = field(default_factory=dict)
    kind: Literal["simulation", "measurement"] = "measurement"
    # the DUT's noise on the record's vibration-off stretches (None: not measured)
    noise: NoiseResult | None = None
    axis_results: tuple[tuple[str, VreResult], ...] = ()
    triaxial: TriaxialPart | None = None
    _ROWS = "levels"

    def display_fields(self) -> list[tuple[str, Any]]:  # the fits' parameters are the headline
        if self.axis_results:
            return self.axes_fields()
        fits = "; ".join(str(f) if f.no_fit_reason is None else f"{f.model.name}: no fit" for f in self.fits)
        return [("kind", self.kind), ("method", self.method), ("conditions", self.conditions),
                ("levels", self.levels), ("fits", fits or None), ("warnings", self.warnings)]

    def display_rows(self) -> list[dict[str, Any]] | None:
        return self.axes_rows() if self.axis_results else super().display_rows()

    def fit_summary(self) -> dict[str, Any]:
        merged: dict[str, Any] = {}
        for f in self.fits:
            if f.freq_hz is not None and "vrc_ug_per_g2" in merged:
                continue  # sine sweeps: the summary carries the first frequency; `fits` has all
            for k, v in f.params.items():
                merged.setdefault(k, v.to_dict())
            merged.setdefault("model", f.model.name)
        return merged

    def to_dict(self) -> dict[str, Any]:
        if self.axis_results:
            return self.axes_document()
        d: dict[str, Any] = {
            "kind": self.kind,
            "method": self.method,
            "conditions": self.conditions.to_dict(),
            "levels": [lv.to_dict() for lv in self.levels],
            "fit": self.fit_summary(),
            "fits": [f.to_dict() for f in self.fits],
            "warnings": [str(w) for w in self.warnings],
            "notices": [notice(w).to_dict() for w in self.warnings],
            "provenance": dict(self.provenance),
        }
        if self.noise is not None:
            d["noise"] = self.noise.to_dict()
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> VreResult:
        return cls(
            method=d["method"],
            conditions=Conditions.from_dict(d.get("conditions") or {}),
            levels=tuple(LevelResult.from_dict(x) for x in d.get("levels") or ()),
            fits=tuple(FitResult.from_dict(x) for x in d.get("fits") or ()),
            warnings=tuple(Notice(n["code"], n["text"]) for n in d["notices"]) if d.get("notices")
            else tuple(d.get("warnings") or ()),
            provenance=dict(d.get("provenance") or {}),
            kind=d.get("kind", "measurement"),
            noise=NoiseResult.from_dict(d["noise"]) if d.get("noise") else None,
        )
