"""Sensor descriptions: presets (TOML data files) and user files with the same schema.

A :class:`Sensor` is one resolved configuration of a part (range, axis, ODR chosen) with every
number marked as a data-sheet fact or an assumption (``facts``). It builds its signal chain at
an internal simulation rate (:meth:`Sensor.chain`) and gives the analog equivalents of its
linear dynamics for the analytic prediction (:meth:`Sensor.linear_responses`).

File schema (see ``presets/README``): top-level keys give the defaults, ``[axes.<axis>]``
overrides per axis, ``[ranges."<nominal g>"]`` overrides per range, and ``[facts]`` maps a field
name to its source. An absent key means "not present" (no resonance, no filter, ...).

A Sensor is an ordered tuple of stage configurations (:mod:`vrelab.sensor.configs`, each
declaring its own fields); :meth:`Sensor.stages` walks it in order (order is data; write a
:class:`SensorChain` by hand, or register a stage, for another)::

    Resonator -> Polynomial -> OverRange -> [Clip if clip_position = "proof-mass"] -> Noise
    -> AntiAlias -> LowPass (ODR/4; AnalogLowPass without an ODR) -> HighPass -> Offset -> [Drift] -> Decimate (fs/ODR)
    -> [Clip if clip_position = "output"] -> Quantize

The nonlinearity and the over-range trip act on the proof-mass motion (after the resonance,
physics §1.3); noise is added before the filters so the output shows the data-sheet density in band;
the output clip sits after the low-pass, which is why a narrower bandwidth rectifies less.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import math
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable, Literal, Mapping, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vrelab._load import toml_loads
from vrelab.results import Conditions
from vrelab.sensor import fields
from vrelab.sensor.chain import SensorChain
from vrelab.sensor.configs import (
    AntiAliasFilter,
    Bias,
    HighPassFilter,
    Mechanics,
    Mount,
    NoiseFloor,
    OutputFilter,
    ProofMassClip,
    Protection,
    Rails,
    Resolution,
    Sampling,
    Sense,
    StageConfig,
    nonlinearity_u,
)
from vrelab.sensor.fields import is_number
from vrelab.sensor.parameters import Param, assumable, check_u, identifiable, parameter
from vrelab.sensor.stages import Resonator, Stage
from vrelab.sensor.statement import VRE_STATEMENT, vre_statement

__all__ = ["Sensor", "load_sensor", "list_presets", "NUMERIC_FIELDS"]

ClipPosition = Literal["output", "proof-mass"]
Where = Literal["proof-mass", "output"]

# The sensor-file schema this version reads (the ``schema`` key every file starts with).
SCHEMA = 1
# Relative tolerance when matching a requested ODR to the list (the data sheet rounds 7.8125
# to 7.813 and 3.90625 to 3.906).
_ODR_RTOL = 1e-3
# A requested range matches a nominal range or its full scale within this.
_RANGE_RTOL = 1e-6



def numeric_fields() -> tuple[str, ...]:
    """Every number a Sensor holds, for describe() and the facts a file marks: the resolved range
    and ODR, and the field table's numeric rows."""
    return ("range_g", "odr_hz") + fields.numeric()


NUMERIC_FIELDS: tuple[str, ...] = numeric_fields()  # as the table stands at import


if TYPE_CHECKING:
    # For the type checker only: the built-in stages' fields read as typed Sensor attributes
    # (sensor.fn_hz: float | None) and set by dataclasses.replace(sensor, fn_hz=...). At run time
    # they resolve through the sensor's stage configurations (Sensor.__getattr__), so a stage
    # registered later (vrelab.sensor.fields.register_stage) reads the same way, typed Any.
    class _StageFields(Mount, Mechanics, Sense, Protection, ProofMassClip, NoiseFloor, AntiAliasFilter, OutputFilter,
                       HighPassFilter, Bias, Sampling, Rails, Resolution):
        pass
else:
    _StageFields = object


@functools.lru_cache(maxsize=64)
def _field_index(kinds: tuple[type[StageConfig], ...]) -> dict[str, int]:
    """Attribute name -> position in a stage tuple of these kinds."""
    return {a.name: k for k, kind in enumerate(kinds) for a in dataclasses.fields(kind)}


@dataclass(frozen=True, init=False, kw_only=True)
class Sensor(_StageFields):
    """One configuration of a sensor (range, axis, ODR resolved), in g and Hz: its identity and
    an ordered tuple of stage configurations (:mod:`vrelab.sensor.configs`).

    ``Sensor(name=..., range_g=..., axis=..., fn_hz=..., ...)``: every field of a stage is a
    keyword (its default the row's), and reads as an attribute (``sensor.fn_hz``), resolved
    through ``configs``; ``dataclasses.replace(sensor, fn_hz=...)`` sets it on its stage.
    ``configs`` defaults to one configuration of each registered stage
    (:data:`vrelab.sensor.fields.STAGES`, in their order).

    ``None`` means the element is absent (no ODR: analog or ideal, output at the input rate;
    no ``fn_hz``: no resonance; no ``overrange_threshold_g``: no over-range protection; ...).
    ``facts[field]`` says where each number comes from ("datasheet ..." or "assumption: ...").

    Examples
    --------
    A sensor is its identity and its stage configurations; it builds its chain:

    >>> import vrelab
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> print(sensor.name, sensor.range_g, sensor.fn_hz, sensor.bandwidth_hz)
    adxl355 2.0 2400.0 1000.0
    >>> [type(c).__name__ for c in sensor.configs][:4]
    ['Mount', 'Mechanics', 'Sense', 'Protection']
    """

    name: str
    range_g: float  # nominal range, as selected (2 for the ±2.048 g ADXL355 range)
    axis: str
    odr_hz: float | None = None
    configs: tuple[StageConfig, ...] = ()  # the stages, in chain order
    description: str = ""
    source: str = ""
    ranges_g: tuple[float, ...] = ()  # nominal ranges the description declares (() = any > 0)
    axes: tuple[str, ...] = ("x", "y", "z")
    odrs_hz: tuple[float, ...] = ()
    facts: Mapping[str, str] = field(default_factory=dict, hash=False)  # a dict: not hashable
    # An identified sensor's parameter covariance (vrelab.identify, physics §6.1): {"params": names
    # of vrelab.sensor.parameters.PARAMETERS, "matrix": rows}; predict carries it into u_vre_g.
    covariance: Mapping[str, Any] | None = field(default=None, hash=False, compare=False)
    # Assumed standard uncertainties [the parameter's unit] of parameters no campaign measured
    # (a datasheet tolerance, a base sensor's filter corner): names of
    # vrelab.sensor.parameters.ASSUMABLE, independent of each other and of the covariance;
    # predict propagates them beside it (the file's [uncertainty] tables).
    uncertainty: Mapping[str, float] = field(default_factory=dict, hash=False, compare=False)
    # Parameters the file marks as an assumption (their facts start with "assumption") with no
    # stated u (neither in ``uncertainty`` nor in ``covariance``): never silently exact, predict
    # probes them (:func:`vrelab.predict.unstated_check`). Set by the loader from the facts
    # (:func:`unstated_assumptions`); a point of the parameter space (with_parameters) has none.
    unstated: tuple[str, ...] = field(default=(), hash=False, compare=False)

    def __init__(self, *, name: str, range_g: float, axis: str, configs: tuple[StageConfig, ...] = (),
                 **values: object) -> None:
        """``values``: the other identity fields above (``odr_hz``, ``facts``, ...; each its default
        when not given) and any stage's fields by attribute."""
        put = functools.partial(object.__setattr__, self)
        put("name", name)
        put("range_g", range_g)
        put("axis", axis)
        for f in dataclasses.fields(Sensor):
            if f.name not in ("name", "range_g", "axis", "configs"):
                factory = cast(Callable[[], Any], f.default_factory)  # facts, uncertainty: a fresh dict each
                default = factory() if f.default is dataclasses.MISSING else f.default
                put(f.name, values.pop(f.name) if f.name in values else default)
        put("facts", dict(self.facts))
        put("uncertainty", dict(self.uncertainty))
        put("unstated", tuple(self.unstated))
        put("configs", _set_fields(tuple(configs) or tuple(kind() for kind in fields.STAGES), values, name))
        self._check()

    def __getattr__(self, name: str) -> Any:
        """A stage's field, from the stage configuration that declares it."""
        configs: tuple[StageConfig, ...] = () if name.startswith("__") else self.__dict__.get("configs", ())
        k = _field_index(tuple(type(c) for c in configs)).get(name)
        if k is None:
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
        return getattr(configs[k], name)

    def stage_values(self) -> dict[str, Any]:
        """Every stage's fields by attribute, in stage order."""
        return {a.name: getattr(c, a.name) for c in self.configs for a in dataclasses.fields(c)}

    def _check(self) -> None:
        if not is_number(self.range_g) or not math.isfinite(self.range_g) or self.range_g <= 0:
            raise ValueError(f"sensor {self.name}: range_g must be a number > 0, got {self.range_g!r}")
        object.__setattr__(self, "configs", tuple(c.resolved(self) for c in self.configs))
        if self.odr_hz is not None and (not is_number(self.odr_hz) or not math.isfinite(self.odr_hz) or self.odr_hz <= 0):
            raise ValueError(f"sensor {self.name}: odr_hz must be a number > 0, got {self.odr_hz!r}")
        values = self.stage_values()
        for f in fields.FIELDS:
            if f.name in values:
                f.check(values[f.name], self.name)
        for c in self.configs:
            c.validate(self)
        if self.covariance is not None:
            object.__setattr__(self, "covariance", _check_covariance(self.covariance, self.name))
        object.__setattr__(self, "uncertainty", _check_uncertainty(self))
        known = assumable()
        bad = [n for n in self.unstated if n not in known]
        if bad:
            raise ValueError(f"sensor {self.name}: unstated names unknown parameters {bad!r}; allowed: {', '.join(known)}")


    # ------------------------------------------------------------------ beyond one axis

    @property
    def triad(self) -> tuple[int, int, int]:
        """IEEE 1293's (input, pendulous, output) axes as indices of (x, y, z).

        The input axis is ``input_axis`` or, by default, :attr:`axis`; the pendulous axis is
        ``pendulous_axis`` or, by default, the next axis in x -> y -> z -> x; the output axis is
        the third. Raises for an axis that is none of x, y, z and says no ``input_axis``.
        """
        names = ("x", "y", "z")
        own = self.sensed_axis
        if own is None:
            raise ValueError(f"sensor {self.name}: axis {self.axis!r} is not x, y or z and the file gives no "
                             "input_axis: no IEEE 1293 triad (set input_axis = \"x\", \"y\" or \"z\" in its axis table)")
        i = names.index(own)
        p = names.index(self.pendulous_axis) if self.pendulous_axis is not None else (i + 1) % 3
        return i, p, 3 - i - p

    @property
    def sensed_axis(self) -> str | None:
        """The part's axis (x, y or z) this one senses: ``input_axis``, else the axis's own name
        when it is x, y or z; None for an axis named otherwise (a campaign channel) that says none."""
        return self.input_axis or (self.axis if self.axis in ("x", "y", "z") else None)

    @property
    def sensitivity_row(self) -> NDArray[np.float64]:
        """This axis's output per g along (x, y, z): 1 on its own axis, the cross-axis sensitivity elsewhere."""
        row = np.array([self.cross_axis_x, self.cross_axis_y, self.cross_axis_z], dtype=np.float64)
        i, _, _ = self.triad
        row[i] = 1.0
        return row

    @property
    def is_single_axis(self) -> bool:
        """True when no cross-axis term is set (the sensor of physics §1.1-1.5)."""
        return not any((self.cross_axis_x, self.cross_axis_y, self.cross_axis_z, self.kip_per_g, self.kio_per_g,
                        self.kpp_per_g, self.koo_per_g, self.kpo_per_g))

    # ------------------------------------------------------------------ rates and chain

    def internal_rate_hz(self, f_max_hz: float) -> float:
        """The simulation rate for a drive reaching ``f_max_hz`` [Hz]: the one rate rule,
        :func:`vrelab.rates.simulation_rate_hz` (its docstring gives the rule and its error bound)."""
        from vrelab.rates import simulation_rate_hz

        return simulation_rate_hz(self, f_max_hz)

    def decimation(self, fs_hz: float) -> int:
        """fs / ODR, checked to be an integer (1 without an ODR)."""
        fs = float(fs_hz)
        if not math.isfinite(fs) or fs <= 0:
            raise ValueError(f"fs_hz must be a finite number > 0, got {fs_hz!r}")
        if self.odr_hz is None:
            return 1
        ratio = fs / self.odr_hz
        m = round(ratio)
        if m < 1 or abs(ratio - m) > 1e-9 * ratio:
            raise ValueError(
                f"fs_hz must be an integer multiple of the ODR {self.odr_hz:g} Hz of {self.name}, got {fs_hz!r}"
            )
        return m

    def stages(self, fs_hz: float | None = None) -> tuple[Stage, ...]:
        """The sensor as an ordered tuple of stages: the one reading of a sensor description.

        Both the simulation (:meth:`chain`) and the analytic prediction
        (:func:`vrelab.predict.predict`, which walks these stages and takes each one's closed
        form) use it, so they cannot read a sensor two ways. Each stage configuration, in
        ``configs`` order (order is data), gives its runtime stages
        (:meth:`vrelab.sensor.configs.StageConfig.build`). With ``fs_hz`` (an integer multiple
        of the ODR) a :class:`Decimate` to the ODR is included; without, the stages are
        rate-free (what the prediction needs). Order: see :mod:`vrelab.sensor.configs`.
        """
        factor = 1 if fs_hz is None else self.decimation(fs_hz)
        return tuple(s for c in self.configs for s in c.build(self, factor))

    def output_filter(self, corner_hz: float) -> Stage:
        """The band-limit at the output at ``corner_hz`` [Hz] (:class:`~vrelab.sensor.configs.OutputFilter`):
        with an ODR the part's digital low-pass (:class:`LowPass`), without one an analog output
        filter of the same order and family (:class:`AnalogLowPass`)."""
        return OutputFilter(lowpass_order=self.lowpass_order, lowpass_kind=self.lowpass_kind,
                            lowpass_corner=self.lowpass_corner).filter(corner_hz, self.odr_hz)

    def chain(self, fs_hz: float) -> SensorChain:
        """The signal chain at internal rate ``fs_hz`` (an integer multiple of the ODR)."""
        return SensorChain(self.stages(fs_hz))

    def fs_out_hz(self, fs_hz: float) -> float:
        return float(fs_hz) / self.decimation(fs_hz)

    def linear_responses(self, where: Where = "output") -> list[Callable[[NDArray[np.float64]], NDArray[np.complex128]]]:
        """Analog responses of the linear stages of :meth:`stages`, as functions of f [Hz].

        ``"proof-mass"``: the mechanical ones (the resonance: what the nonlinearity and the
        over-range trip see). ``"output"``: every linear stage (resonance, anti-alias, low-pass,
        high-pass: what an output clip sees). Empty list: flat (ideal sensor).
        """
        if where not in ("proof-mass", "output"):
            raise ValueError(f"where must be one of proof-mass, output; got {where!r}")
        return [
            s.response
            for s in self.stages()
            if hasattr(s, "response") and (where == "output" or isinstance(s, Resonator))
        ]

    def response(self, f_hz: ArrayLike, where: Where = "output") -> NDArray[np.complex128]:
        """Product of :meth:`linear_responses` at ``f_hz``."""
        f = np.asarray(f_hz, dtype=float)
        h = np.ones(f.shape, dtype=complex)
        for r in self.linear_responses(where):
            h = h * r(f)
        return h

    # ------------------------------------------------------------------ reporting

    def conditions(self, static_g: float | None = None, profile: str | None = None, model: str | None = None) -> Conditions:
        """The :class:`vrelab.results.Conditions` this sensor configuration contributes (physics §1.4)."""
        return Conditions(
            sensor=self.name,
            model=model,
            profile=profile,
            static_g=static_g,
            range_g=self.range_g,
            bandwidth_hz=self.bandwidth_hz,
            odr_hz=self.odr_hz,
            axis=self.axis,
            extra={"full_scale_g": self.full_scale_g, "rails_g": list(self.rails_g), "clip_position": self.clip_position},
        )

    def to_dict(self) -> dict[str, Any]:
        """The identity and every stage's fields by attribute (tuples as lists), as plain data."""
        ident = {f.name: copy.deepcopy(getattr(self, f.name)) for f in dataclasses.fields(self) if f.name != "configs"}
        d = {**{k: ident.pop(k) for k in ("name", "range_g", "axis", "odr_hz")}, **self.stage_values(), **ident}
        for key, value in d.items():
            if isinstance(value, tuple):
                d[key] = list(value)
        d["facts"] = dict(self.facts)
        return d

    def describe(self) -> str:
        odr = f"ODR {self.odr_hz:g} Hz" if self.odr_hz is not None else "no ODR (output at the input rate)"
        lines = [
            f"{self.name}: ±{self.range_g:g} g range (full scale ±{self.full_scale_g:g} g), axis {self.axis}, {odr}",
        ]
        if self.description:
            lines.append(f"  {self.description}")
        for name in numeric_fields():
            value = getattr(self, name)
            shown = "none" if value is None else (f"[{value[0]:g}, {value[1]:g}]" if isinstance(value, tuple) else f"{value:g}")
            lines.append(f"  {name} = {shown}    ({self.facts.get(name, 'unmarked')})")
        lines.append(f"  clip_position = {self.clip_position}")
        return "\n".join(lines)


def _set_fields(configs: tuple[StageConfig, ...], values: Mapping[str, Any], name: str) -> tuple[StageConfig, ...]:
    """``configs`` with ``values`` (stage fields by attribute) set on the stages that declare them."""
    index = _field_index(tuple(type(c) for c in configs))
    unknown = sorted(set(values) - set(index))
    if unknown:
        raise TypeError(f"sensor {name}: no stage has the field(s) {', '.join(unknown)}; "
                        f"stages: {', '.join(type(c).__name__ for c in configs)}")
    per: dict[int, dict[str, Any]] = {}
    for key, v in values.items():
        per.setdefault(index[key], {})[key] = v
    return tuple(dataclasses.replace(c, **per[k]) if k in per else c for k, c in enumerate(configs))


# ---------------------------------------------------------------------------- files

# Keys a file may set at top level besides the rows of the field table (vrelab.sensor.fields,
# written in the field's units: µg/g² for the nonlinearity, physics §1.2), which it may also set in
# [axes.*] or in [ranges.*].
_FILE_KEYS = {
    "schema", "name", "description", "source", "default_range_g", "default_axis", "odrs_hz",
    "default_odr_hz", "bandwidth_per_odr", "axes", "ranges", "facts", "uncertainty", "vre_statement",
}
# The table of assumed standard uncertainties (top level < [axes.*] < [ranges.*]).
UNCERTAINTY = "uncertainty"
# An [uncertainty] key that is no parameter: the u of bandwidth_per_odr (the corner as a
# fraction of the ODR), bandwidth_hz's u at the chosen ODR.
PER_ODR = "bandwidth_per_odr"
# A fact saying a number is assumed starts with this (the presets' and identify's convention).
ASSUMPTION = "assumption"


def _is_assumed(facts: Mapping[str, str], p: Param) -> bool:
    """Whether the facts mark parameter ``p`` (a :class:`vrelab.sensor.parameters.Param`) as an
    assumption: its fact starts with "assumption" (a rails pair's per side, ``lower: ...; upper:
    ...`` as ``vrelab identify`` writes it)."""
    text = str(facts.get(p.fact_key, "")).strip()
    if p.rail is not None:
        side = ("lower", "upper")[p.rail] + ": "
        if side in text:
            text = text[text.index(side) + len(side):].strip()
    return text.lower().startswith(ASSUMPTION)


def unstated_assumptions(sensor: Sensor) -> tuple[str, ...]:
    """The parameters ``sensor``'s facts mark as an assumption that carry no u (neither an
    assumed standard uncertainty nor a place in the covariance) and that the sensor has (not an
    absent element). What ``Sensor.unstated`` holds for a loaded file."""
    cov = set(sensor.covariance["params"]) if sensor.covariance else set()
    out = []
    for name, p in assumable().items():
        if name in sensor.uncertainty or name in cov or not _is_assumed(sensor.facts, p):
            continue
        if name == f"cross_axis_{sensor.sensed_axis}":  # 0 on its own axis by definition, not assumed
            continue
        if parameter(sensor, name) is not None:
            out.append(name)
    return tuple(out)


def _preset_dir() -> Any:
    return resources.files("vrelab.sensor") / "presets"


def list_presets() -> list[str]:
    """Names of the built-in presets (``ideal``, ``adxl355``, ...).

    Examples
    --------
    >>> from vrelab.sensor import list_presets
    >>> presets = list_presets()
    >>> "adxl355" in presets, "ideal" in presets, presets == sorted(presets)
    (True, True, True)
    """
    return sorted(p.name[: -len(".toml")] for p in _preset_dir().iterdir() if p.name.endswith(".toml"))


def read_spec(spec: str) -> tuple[dict[str, Any], str]:
    presets = list_presets()
    if spec in presets:
        text = (_preset_dir() / f"{spec}.toml").read_text(encoding="utf-8")
        origin = f"preset {spec}"
    else:
        path = Path(spec)
        if not path.is_file():
            raise ValueError(
                f"sensor must be one of {', '.join(presets)} or a path to a sensor TOML file; got {spec!r}"
            )
        text = path.read_text(encoding="utf-8")
        origin = f"file {path}"
    try:
        data = toml_loads(text, f"sensor {origin}")
    except tomllib.TOMLDecodeError as e:
        raise ValueError(f"sensor {origin} is not valid TOML: {e}") from None
    return data, origin


def _check_keys(table: Mapping[str, Any], allowed: set[str], where: str) -> None:
    for key in table:
        if key not in allowed:
            raise ValueError(f"sensor {where}: unknown key {key!r}; allowed keys are {', '.join(sorted(allowed))}")


def _number(value: object, key: str, where: str) -> float:
    if not is_number(value):
        raise ValueError(f"sensor {where}: {key} must be a number, got {value!r}")
    return float(value)


def _apply(values: dict[str, Any], table: Mapping[str, Any], where: str) -> None:
    rows = fields.by_key()
    for key, raw in table.items():
        f = rows[key]
        values[f.name] = f.parse(raw, where)



def _choose_axis(data: Mapping[str, Any], axis: str | None, name: str, where: str) -> tuple[dict[str, Any], tuple[str, ...], str]:
    """(the [axes] table, the axes, the chosen axis) of a description."""
    axes_table = data.get("axes", {})
    if not isinstance(axes_table, dict) or not all(isinstance(v, dict) for v in axes_table.values()):
        raise ValueError(f"sensor {where}: axes must be a table of tables ([axes.x] ...), got {axes_table!r}")
    axes = tuple(axes_table) if axes_table else ("x", "y", "z")
    chosen_axis = axis if axis is not None else data.get("default_axis", axes[0])
    # axes match without regard to case (x and X; an identified file's channel names keep theirs)
    match = [a for a in axes if isinstance(chosen_axis, str) and a.lower() == chosen_axis.lower()]
    if not match:
        raise ValueError(f"axis must be one of {', '.join(axes)} for {name}; got {chosen_axis!r}")
    chosen_axis = match[0]
    return axes_table, axes, chosen_axis


def _choose_range(
    data: Mapping[str, Any], range_g: float | None, name: str, where: str
) -> tuple[dict[str, Any], dict[float, str], str | None, float]:
    """(the [ranges] table, nominal range -> table key, the chosen key, the nominal range [g]);
    a requested range matches a nominal range or its full scale."""
    ranges_table = data.get("ranges", {})
    if not isinstance(ranges_table, dict) or not all(isinstance(v, dict) for v in ranges_table.values()):
        raise ValueError(f"sensor {where}: ranges must be a table of tables ([ranges.\"2\"] ...), got {ranges_table!r}")
    nominal: dict[float, str] = {}
    for key in ranges_table:
        try:
            nominal[float(key)] = key
        except ValueError:
            raise ValueError(f"sensor {where}: range keys must be numbers in g, got {key!r}") from None
    requested = range_g if range_g is not None else data.get("default_range_g", 2.0)
    req = _number(requested, "range_g", where) if not isinstance(requested, str) else math.nan
    range_key: str | None = None
    if nominal:
        for nom, key in nominal.items():
            fs_g = _number(ranges_table[key].get("full_scale_g", nom), "full_scale_g", f"{where} [ranges.{key}]")
            if math.isclose(req, nom, rel_tol=_RANGE_RTOL) or math.isclose(req, fs_g, rel_tol=_RANGE_RTOL):
                range_key, req = key, nom
                break
        if range_key is None:
            full = [ranges_table[k].get("full_scale_g", n) for n, k in nominal.items()]
            raise ValueError(
                f"range_g must be one of {_fmt(nominal)} g (full scale {_fmt(full)}) for {name}; got {requested!r}"
            )
    elif not (math.isfinite(req) and req > 0):
        raise ValueError(f"range_g must be a number > 0 for {name}; got {requested!r}")
    return ranges_table, nominal, range_key, req


def _choose_odr(data: Mapping[str, Any], odr_hz: float | None, name: str, where: str) -> tuple[tuple[float, ...], float | None]:
    """(the ODRs a description declares, the chosen one or None for a part without ODR)."""
    odrs_raw = data.get("odrs_hz", [])
    if not isinstance(odrs_raw, list) or ("odrs_hz" in data and not odrs_raw):
        raise ValueError(f"sensor {where}: odrs_hz must be a non-empty list of rates in Hz "
                         f"(leave it out for an analog part), got {odrs_raw!r}")
    odrs = tuple(_number(o, "odrs_hz", where) for o in odrs_raw)
    chosen_odr: float | None = None
    if odrs:
        want = odr_hz if odr_hz is not None else data.get("default_odr_hz", odrs[0])
        w = _number(want, "odr_hz", where) if is_number(want) else math.nan
        for o in odrs:
            if math.isclose(w, o, rel_tol=_ODR_RTOL):
                chosen_odr = o
                break
        if chosen_odr is None:
            raise ValueError(f"odr_hz must be one of {_fmt(odrs)} Hz for {name}; got {want!r}")
    else:
        if odr_hz is not None:
            raise ValueError(f"odr_hz must not be given for {name}: it has no ODR (output at the input rate); got {odr_hz!r}")
        for key in ("default_odr_hz", "bandwidth_per_odr"):  # a file means what it says: no key read and ignored
            if key in data:
                raise ValueError(f"sensor {where}: {key} has no effect without odrs_hz (an analog part has no ODR; "
                                 "its band-limit is bandwidth_hz): give odrs_hz or leave it out")
    return odrs, chosen_odr


def _facts(data: Mapping[str, Any], where: str) -> dict[str, str]:
    """Where each number comes from ([facts], by Sensor attribute or file key)."""
    facts_raw = data.get("facts", {})
    if not isinstance(facts_raw, dict):
        raise ValueError(f"sensor {where}: facts must be a table of strings, got {facts_raw!r}")
    facts: dict[str, str] = {}
    aliases = {f.key: f.name for f in fields.FIELDS}
    _check_keys(facts_raw, set(numeric_fields()) | set(aliases) | set(aliases.values()), f"{where} [facts]")
    key: str  # a TOML table's keys are strings
    for key, text in facts_raw.items():
        if not isinstance(text, str):
            raise ValueError(f"sensor {where}: facts.{key} must be a string, got {text!r}")
        facts[aliases.get(key, key)] = text
    return facts


def _check_covariance(cov: object, name: str) -> dict[str, Any]:
    """An identified sensor's covariance table, checked: known parameter names, a square,
    symmetric, finite matrix with a non-negative diagonal."""
    known = tuple(identifiable())
    where = f"sensor {name}: covariance"
    if not isinstance(cov, Mapping) or set(cov) != {"params", "matrix"}:
        raise ValueError(f"{where} must be a table with params (names) and matrix (rows), got {cov!r}")
    params, matrix = cov["params"], cov["matrix"]
    if not isinstance(params, (list, tuple)) or not params or any(p not in known for p in params) \
            or len(set(params)) != len(params):
        raise ValueError(f"{where}: params must be distinct names of {', '.join(known)}, got {params!r}")
    try:
        m = np.array(matrix, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: matrix must be rows of numbers, got {matrix!r}") from None
    n = len(params)
    if m.shape != (n, n) or not np.all(np.isfinite(m)):
        raise ValueError(f"{where}: matrix must be {n}x{n} finite numbers (one row per parameter), got shape {m.shape}")
    if np.any(np.diag(m) < 0) or not np.allclose(m, m.T, rtol=1e-9, atol=0.0):
        raise ValueError(f"{where}: matrix must be symmetric with a non-negative diagonal")
    for p, var in zip(params, np.diag(m).tolist()):
        check_u(p, math.sqrt(var), where)
    # a covariance is positive semi-definite: a negative eigenvalue (beyond rounding) would give
    # some combination of the parameters a negative variance, and a propagated u of 0 or NaN
    d = np.sqrt(np.diag(m))
    scale = np.where(d > 0, d, 1.0)
    lowest = float(np.linalg.eigvalsh(m / np.outer(scale, scale)).min()) if n else 0.0
    if lowest < -1e-9:
        raise ValueError(f"{where}: matrix is not positive semi-definite (its correlation matrix has the eigenvalue "
                         f"{lowest:.3g} < 0): not a covariance")
    return {"params": [str(p) for p in params], "matrix": [[float(x) for x in row] for row in m]}


def _uncertainty_table(table: object, where: str) -> dict[str, float]:
    """A file's ``[uncertainty]`` table: parameter name -> assumed standard uncertainty (> 0)."""
    if table is None:
        return {}
    if not isinstance(table, dict):
        raise ValueError(f"sensor {where}: uncertainty must be a table of parameter = standard uncertainty, got {table!r}")
    # (bandwidth_per_odr: the u of the corner as a fraction of the ODR, read as bandwidth_hz's u
    # once the ODR is chosen, :func:`load_sensor`)
    out = {}
    allowed = assumable()
    for key, u in table.items():
        if key not in allowed and key != PER_ODR:
            raise ValueError(f"sensor {where}: uncertainty.{key}: unknown parameter; allowed: {', '.join(allowed)}")
        if not is_number(u) or not math.isfinite(u) or u <= 0:
            raise ValueError(f"sensor {where}: uncertainty.{key} must be a standard uncertainty > 0, got {u!r}")
        if key == PER_ODR:  # a fraction of the ODR whose whole range is (0, 0.5): the corner stays below ODR/2
            if not u <= 0.5:
                raise ValueError(f"sensor {where}: uncertainty.{key}: the standard uncertainty {u:g} is wider than "
                                 f"{key}'s whole physical range (0 to 0.5 of the ODR): outside any physical bound")
        else:
            check_u(key, float(u), f"sensor {where}: uncertainty.{key}")
        out[key] = float(u)
    return out


def _check_uncertainty(sensor: Sensor) -> dict[str, float]:
    """The Sensor's assumed uncertainties, checked: each of a parameter the sensor has, none of
    one its covariance already carries (one source of u per parameter)."""
    out = _uncertainty_table(dict(sensor.uncertainty), sensor.name)
    cov = set(sensor.covariance["params"]) if sensor.covariance else set()
    for key in out:
        if key in cov:
            raise ValueError(f"sensor {sensor.name}: uncertainty.{key}: the parameter is in the covariance already "
                             "(identified): give it one uncertainty")
        if parameter(sensor, key) is None:
            raise ValueError(f"sensor {sensor.name}: uncertainty.{key}: the sensor has no {key} (absent element)")
    return out


def _fmt(xs: Iterable[float]) -> str:
    return ", ".join(f"{x:g}" for x in xs)


def load_sensor(
    spec: str,
    range_g: float | None = None,
    axis: str | None = None,
    odr_hz: float | None = None,
    k2_ug_per_g2: float | None = None,
    k3_ug_per_g3: float | None = None,
    overrides: Mapping[str, Any] | None = None,
) -> Sensor:
    """Load a preset (``ideal``, ``adxl355``, ``adxl354``, ``adxl357``) or a user sensor TOML.

    Parameters
    ----------
    spec : preset name or path to a TOML file with the preset schema.
    range_g : nominal range or full scale [g] (2 and 2.048 both select the ADXL355 ±2 g range);
        default: the file's ``default_range_g``.
    axis : ``x``, ``y``, ``z`` (or the file's axes); default: the file's ``default_axis``.
    odr_hz : output data rate [Hz], one of the file's ``odrs_hz``; default ``default_odr_hz``.
    k2_ug_per_g2, k3_ug_per_g3 : override the nonlinearity [µg/g², µg/g³] (the CLI reference ``--k2``/``--k3``);
        the same as ``overrides={"k2_ug_per_g2": ...}``.
    overrides : values set by the user, by file key in the file's units (a sweep point's
        ``fn_hz``, ``kip_ug_per_g2``, ...): they win over every table of the file, their facts
        say "set by the user", and the file's covariance and assumed u of those parameters are
        dropped (they are not about the value set).

    Raises
    ------
    ValueError naming the field and the allowed values for an unknown preset, an invalid file,
    an unknown range, axis or ODR.

    Examples
    --------
    The ADXL355 preset at its ±2 g range, z axis, 4 kHz output rate:

    >>> import vrelab
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> print(sensor.name, sensor.range_g, sensor.axis, sensor.odr_hz)
    adxl355 2.0 z 4000.0
    >>> print(sensor.rails_g)
    (-2.048, 2.048)
    """
    data, origin, name = _read_checked(spec)
    where = f"{name} ({origin})"
    axes_table, axes, chosen_axis = _choose_axis(data, axis, name, where)
    ranges_table, nominal, range_key, req = _choose_range(data, range_g, name, where)
    odrs, chosen_odr = _choose_odr(data, odr_hz, name, where)
    axis_table = dict(axes_table.get(chosen_axis, {})) if axes_table else {}
    range_table = dict(ranges_table[range_key]) if range_key is not None else None
    values, uncertainty, covariance = _layered_values(data, axis_table, range_table, chosen_odr, where,
                                                      f"[axes.{chosen_axis}]", f"[ranges.{range_key}]")
    cov_params = covariance.get("params", ()) if isinstance(covariance, Mapping) else ()
    for key, u in nonlinearity_u(values.get("nonlinearity_pct_fs"), req).items():  # the file's own u wins
        if key not in cov_params:
            uncertainty.setdefault(key, u)
    # ---- values the user sets (--k2/--k3, a sweep point) win over the file
    rows = fields.by_key()
    user = dict(overrides or {})
    user.update({k: v for k, v in (("k2_ug_per_g2", k2_ug_per_g2), ("k3_ug_per_g3", k3_ug_per_g3)) if v is not None})
    _check_keys(user, set(rows), f"{where} (values set by the user)")
    _apply(values, user, f"{where} (set by the user)")
    user_params = {n for k in user for n in rows[k].parameters}
    for n in user_params:
        uncertainty.pop(n, None)  # the file's assumed u is not about the value set
    given = set(values)  # the attributes the file or the user set; the others keep their stage's default
    facts = _resolved_facts(data, axis_table.get("facts", {}), user, given, origin, where, f"[axes.{chosen_axis}]")
    description = data.get("description", "")
    source = data.get("source", origin)
    sensor = Sensor(
        name=name,
        range_g=req,
        axis=chosen_axis,
        odr_hz=chosen_odr,
        description=description if isinstance(description, str) else "",
        source=source if isinstance(source, str) else origin,
        ranges_g=tuple(sorted(nominal)),
        axes=axes,
        odrs_hz=odrs,
        facts=facts,
        covariance=_without(covariance, user_params),
        uncertainty=uncertainty,
        **values,
    )
    # a sensor file means what it says: no field read and ignored (a hold without a threshold)
    for f in fields.idle(sensor.stage_values(), given):
        need = fields.by_name()[f.needs].key
        raise ValueError(f"sensor {where}: {f.key} has no effect without {need} (axis {chosen_axis}, range {req:g} g): "
                         f"give {need} or leave {f.key} out")
    return dataclasses.replace(sensor, unstated=unstated_assumptions(sensor))


def _read_checked(spec: str) -> tuple[dict[str, Any], str, str]:
    """(the file's document, where it comes from, the sensor's name): its keys, schema and name checked."""
    if not isinstance(spec, str) or not spec:
        raise ValueError(f"sensor must be a preset name or a path, got {spec!r}")
    data, origin = read_spec(spec)
    _check_keys(data, _FILE_KEYS | set(fields.by_key()), origin)
    if "schema" not in data:
        raise ValueError(f"sensor {origin}: no schema key: a sensor file starts with schema = {SCHEMA} "
                         "(see the presets README); an empty file is not a sensor")
    if data["schema"] != SCHEMA or isinstance(data["schema"], bool):
        raise ValueError(f"sensor {origin}: schema must be {SCHEMA} (the sensor schema this version reads), "
                         f"got {data['schema']!r}")
    name = data.get("name", Path(spec).stem)
    if not isinstance(name, str) or not name:
        raise ValueError(f"sensor {origin}: name must be a non-empty string, got {name!r}")
    vre_statement(data.get(VRE_STATEMENT), origin)  # the datasheet's VRE statement, checked
    return data, origin, name


def _layered_values(data: Mapping[str, Any], axis_table: dict[str, Any], range_table: dict[str, Any] | None,
                    odr_hz: float | None, where: str, axis_where: str, range_where: str,
                    ) -> tuple[dict[str, Any], dict[str, float], Any]:
    """(the stage fields by attribute, the assumed u, the axis's covariance) of a file's tables:
    top level < the chosen axis's table < the chosen range's table (``axis_table`` loses its
    covariance to the result; ``range_table`` None: the file has no ranges)."""
    rows = fields.by_key()
    values: dict[str, Any] = {}
    _apply(values, {k: v for k, v in data.items() if k in rows}, where)
    uncertainty = _uncertainty_table(data.get(UNCERTAINTY), where)
    covariance = axis_table.pop("covariance", None)
    uncertainty.update(_uncertainty_table(axis_table.get(UNCERTAINTY), f"{where} {axis_where}"))
    own = {k: v for k, v in axis_table.items() if k not in ("facts", UNCERTAINTY)}
    _check_keys(own, set(rows), f"{where} {axis_where}")
    _apply(values, own, f"{where} {axis_where}")
    if range_table is not None:
        own = {k: v for k, v in range_table.items() if k != UNCERTAINTY}
        _check_keys(own, set(rows), f"{where} {range_where}")
        _apply(values, own, f"{where} {range_where}")
        uncertainty.update(_uncertainty_table(range_table.get(UNCERTAINTY), f"{where} {range_where}"))
        # a value the range's table sets was not the one identified on the axis: not an estimate here
        covariance = _without(covariance, {n for n, p in identifiable().items() if p.file_key in range_table})
    u_per_odr = uncertainty.pop(PER_ODR, None)
    per_odr = data.get("bandwidth_per_odr")
    if odr_hz is not None and per_odr is not None:
        values["bandwidth_hz"] = _number(per_odr, "bandwidth_per_odr", where) * odr_hz
        if u_per_odr is not None and "bandwidth_hz" not in uncertainty:
            uncertainty["bandwidth_hz"] = u_per_odr * odr_hz
    return values, uncertainty, covariance


def _resolved_facts(data: Mapping[str, Any], axis_facts: object, user: Mapping[str, Any], given: set[str],
                    origin: str, where: str, axis_where: str) -> dict[str, str]:
    """Where each value comes from: the file's [facts] < the axis's own < "set by the user"; a
    value left at its default has its row's default fact; a user file's other numbers say they
    are unmarked."""
    rows = fields.by_key()
    facts = _facts(data, where)
    if axis_facts:  # an axis's own sources (an identified file marks each number per channel)
        facts.update(_facts({"facts": axis_facts}, f"{where} {axis_where}"))
    for key, raw in user.items():
        shown = ", ".join(f"{x:g}" for x in raw) if isinstance(raw, (list, tuple)) else (
            f"{raw:g}" if is_number(raw) else str(raw))
        facts[rows[key].name] = f"set by the user: {shown} {rows[key].text_unit}".rstrip()
    for f in fields.FIELDS:
        if f.name not in facts and f.name not in given and f.default_fact:
            facts[f.name] = f.default_fact
    if origin.startswith("file"):
        for attr in numeric_fields():
            facts.setdefault(attr, f"unmarked, from user {origin}")
    return facts


def _without(cov: object, names: set[str]) -> Any:
    """The covariance without ``names``: parameters set otherwise than by the identification (by
    hand with --k2/--k3 or a sweep point, or by the chosen range's table), no longer estimates here; None when
    nothing is left."""
    if not isinstance(cov, Mapping) or not names or not isinstance(cov.get("params"), list):
        return cov
    keep = [i for i, p in enumerate(cov["params"]) if p not in names]
    if not keep:
        return None
    try:
        return {"params": [cov["params"][i] for i in keep], "matrix": [[cov["matrix"][i][j] for j in keep] for i in keep]}
    except (IndexError, KeyError, TypeError):
        return cov  # malformed: the Sensor's check names it
