"""A sweep described in a TOML file: the point kind, a grid, a Monte Carlo lot, a seed, outputs.

The file (every key optional except ``kind`` and at least one of ``[grid]`` / ``[montecarlo]``)::

    name = "vre-vs-range"            # label for the outputs
    kind = "model"                   # model | predict | simulate | python
    function = "mypkg.mod:point"     # python kind only: point(params, seed_seq) -> {name: float},
                                     # importable by every worker (installed, or on PYTHONPATH)
    seed = 20161121                  # root of every random number (numpy SeedSequence)
    seconds = 2.0                    # simulate only: seconds of vibration per level (default: the shaker's)
    retries = 1                      # extra attempts for a point that raises or kills its worker
    chunk = 1                        # points per task sent to a worker (cheap points: raise it)

    [fixed]                          # parameters held constant
    static_g = 1.0

    [grid]                           # one axis per key: a list, or "a:b:step" / "1,2,4" (numbers)
    range_g = [2, 4, 8]
    rms_g = "0.5:3:0.5"

    [montecarlo]                     # a lot of `units` sensors, each drawn once from these
    units = 100
    k2_ug_per_g2 = {dist = "normal", mean = 0.0, sd = 50.0}
    q = {dist = "uniform", low = 5.0, high = 9.0}

    [output]
    variables = ["vre_g", "tilt_error_deg"]   # default: everything the point returns
    formats = ["netcdf", "csv"]               # netcdf | csv | zarr (zarr needs the zarr package)

The points are the Cartesian product ``unit × grid axes`` in row-major order (``unit`` first,
then the grid axes in file order); point ``i`` gets the seed ``SeedSequence(seed,
spawn_key=(0, i))`` and unit ``u`` draws its parameters from ``SeedSequence(seed,
spawn_key=(1, u))``, so a result depends on the file alone, never on the backend, the number
of workers, the chunk size or the order in which points finish. (``SeedSequence(s).spawn(n)[i]``
is the same sequence as ``SeedSequence(s, spawn_key=(i,))``; the leading 0/1 keeps the point
and the unit streams apart.)
"""

from __future__ import annotations

import hashlib
import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator, Literal, Mapping, Sequence

import numpy as np

from vrelab._lists import parse_list
from vrelab._load import toml_load
from vrelab.models.kinds import KINDS as CLIP_KINDS
from vrelab.sensor import fields

Kind = Literal["model", "predict", "simulate", "python"]
KINDS: tuple[str, ...] = ("model", "predict", "simulate", "python")
FORMATS: tuple[str, ...] = ("netcdf", "csv", "zarr")
# A typo such as "0:3:0.00001" in two axes should fail at once, not fill memory: the engine
# holds every point's parameters (about 1 kB each) while it runs.
MAX_POINTS = 1_000_000

_POINT_STREAM = 0
_UNIT_STREAM = 1


@dataclass(frozen=True)
class Param:
    """What a point kind accepts for one parameter: its type and the check on its value."""

    type: type  # float or str
    check: Literal["any", "positive", "non-negative"] | tuple[str, ...] = "any"

    def coerce(self, field_name: str, value: object) -> float | str:
        if self.type is str:
            if not isinstance(value, str):
                raise ValueError(f"{field_name} must be a string, got {value!r}")
            if isinstance(self.check, tuple) and value not in self.check:
                raise ValueError(f"{field_name} must be one of {', '.join(self.check)}; got {value!r}")
            return value
        return self.number(field_name, value)

    def number(self, field_name: str, value: object) -> float:
        """A numeric parameter's value as a float, checked (``ValueError`` naming ``field_name``)."""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValueError(f"{field_name} must be a number, got {value!r}")
        x = float(value)
        if not math.isfinite(x):
            raise ValueError(f"{field_name} must be finite, got {value!r}")
        if self.check == "positive" and x <= 0:
            raise ValueError(f"{field_name} must be > 0, got {value!r}")
        if self.check == "non-negative" and x < 0:
            raise ValueError(f"{field_name} must be >= 0, got {value!r}")
        return x


_F, _P, _N = Param(float), Param(float, "positive"), Param(float, "non-negative")

# The parameters each built-in kind understands (vrelab.sweep.points documents their meaning).
_POINT = {"rms_g": _P, "static_g": _F, "range_g": _P}
# The sensor parameters the model kind's closed forms read (vrelab.sweep.points.model_point);
# each is a sweepable row of the field table.
MODEL_SENSOR_PARAMS: tuple[str, ...] = ("k2_ug_per_g2", "k3_ug_per_g3", "fn_hz", "q", "offset_g")
_CHECKS: dict[str, Literal["positive", "non-negative"]] = {"positive": "positive", "non_negative": "non-negative"}


def sensor_params() -> dict[str, Param]:
    """The sensor parameters a predict or simulate point may set, by file key: the sweepable
    rows of the field table (:func:`vrelab.sensor.fields.sweepable`), checked as the row says
    (the Sensor checks the rest, bounds and pairs, when the point builds it)."""
    return {f.key: Param(str, f.choices) if f.kind == "choice" else Param(float, _CHECKS.get(f.kind, "any"))
            for f in fields.sweepable()}


def params_for(kind: str) -> dict[str, Param]:
    """The parameters a built-in point kind understands."""
    sensor = sensor_params()
    if kind == "model":
        return {**_POINT, **{k: sensor[k] for k in MODEL_SENSOR_PARAMS},
                "shape": Param(str, ("gaussian", "sine")), "clip_kind": Param(str, (*CLIP_KINDS, "none")),
                "freq_hz": _P, "f_lo_hz": _P, "f_hi_hz": _P}
    predict = {**_POINT, **sensor,
               "sensor": Param(str),
               "axis": Param(str),  # x, y, z or an identified sensor file's channel: the sensor file checks it
               "odr_hz": _P, "profile": Param(str), "freq_hz": _P}
    if kind == "predict":
        return predict
    return {**predict, "baseline_s": _P, "settle_s": _N}


PARAMS: dict[str, dict[str, Param]] = {k: params_for(k) for k in ("model", "predict", "simulate")}  # at import
REQUIRED: dict[str, tuple[str, ...]] = {"model": ("rms_g",), "predict": ("rms_g",), "simulate": ("rms_g",)}

_DISTS: dict[str, tuple[str, ...]] = {
    "normal": ("mean", "sd"),
    "uniform": ("low", "high"),
    "lognormal": ("mean", "sigma"),  # of the underlying normal, as numpy's Generator.lognormal
}


@dataclass(frozen=True)
class Distribution:
    """A random parameter of a Monte Carlo lot: one draw per unit."""

    param: str
    dist: Literal["normal", "uniform", "lognormal"]
    args: tuple[float, float]

    def draw(self, rng: np.random.Generator) -> float:
        a, b = self.args
        if self.dist == "normal":
            return float(rng.normal(a, b))
        if self.dist == "uniform":
            return float(rng.uniform(a, b))
        return float(rng.lognormal(a, b))

    def to_dict(self) -> dict[str, Any]:
        return {"dist": self.dist, **dict(zip(_DISTS[self.dist], self.args))}


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep: build it with :func:`load_spec` or :func:`parse_spec`."""

    kind: Kind
    grid: tuple[tuple[str, tuple[Any, ...]], ...] = ()
    fixed: Mapping[str, Any] = field(default_factory=dict)
    units: int | None = None
    distributions: tuple[Distribution, ...] = ()
    seed: int = 0
    function: str | None = None
    seconds: float | None = None
    retries: int = 1
    chunk: int = 1
    variables: tuple[str, ...] | None = None
    formats: tuple[str, ...] = ("netcdf", "csv")
    name: str = "sweep"

    @property
    def dims(self) -> tuple[str, ...]:
        return (("unit",) if self.units is not None else ()) + tuple(k for k, _ in self.grid)

    @property
    def shape(self) -> tuple[int, ...]:
        return ((self.units,) if self.units is not None else ()) + tuple(len(v) for _, v in self.grid)

    @property
    def n_points(self) -> int:
        return math.prod(self.shape)

    def point_seed(self, index: int) -> tuple[int, tuple[int, ...]]:
        """(entropy, spawn_key) of point ``index``: ``SeedSequence(*point_seed(i))``."""
        return self.seed, (_POINT_STREAM, index)

    def unit_params(self, unit: int) -> dict[str, float]:
        """The parameters drawn for unit ``unit`` of the lot (independent of the lot size)."""
        rng = np.random.default_rng(np.random.SeedSequence(self.seed, spawn_key=(_UNIT_STREAM, unit)))
        return {d.param: d.draw(rng) for d in self.distributions}

    def point_params(self, index: int, _units: list[dict[str, float]] | None = None) -> dict[str, Any]:
        """Every parameter of point ``index``: fixed, then the unit's draws, then the grid."""
        if not 0 <= index < self.n_points:
            raise ValueError(f"index must be in [0, {self.n_points}), got {index}")
        pos = np.unravel_index(index, self.shape)
        params: dict[str, Any] = dict(self.fixed)
        axes = iter(pos)
        if self.units is not None:
            u = int(next(axes))
            params.update(_units[u] if _units is not None else self.unit_params(u))
        for (name, values), j in zip(self.grid, axes):
            params[name] = values[int(j)]
        if self.seconds is not None:
            params["seconds"] = self.seconds
        return params

    def point_key(self, index: int, _units: list[dict[str, float]] | None = None) -> str:
        """The identity of point ``index`` (16 hex): SHA-256 of its every parameter and its seed.

        A checkpoint line carries it, so a resume can check that the line is the point its index
        names on this grid (a line relabelled to another index, or a unit drawn otherwise by
        another numpy, no longer matches)."""
        entropy, key = self.point_seed(index)
        body = {"params": self.point_params(index, _units), "seed": [entropy, list(key)]}
        return hashlib.sha256(json.dumps(body, sort_keys=True, default=str).encode()).hexdigest()[:16]

    def all_params(self) -> Iterator[dict[str, Any]]:
        units = [self.unit_params(u) for u in range(self.units or 0)]
        for i in range(self.n_points):
            yield self.point_params(i, units)

    def inputs(self) -> dict[str, str]:
        """SHA-256 of every file the points read (a sensor or profile given as a path, in
        ``[fixed]`` or on a grid axis), by the name the file gives it; presets and inline
        profiles need none."""
        from vrelab._io import sha256_file
        from vrelab.profiles import split_tones

        names: list[Any] = [self.fixed.get(k) for k in _FILE_KEYS]
        names += [v for k, values in self.grid if k in _FILE_KEYS for v in values]
        out: dict[str, str] = {}
        for name in names:
            # a profile file with "+sine:..." tones after it reads the file all the same
            path = split_tones(name)[0].strip() if isinstance(name, str) else None
            if path and Path(path).is_file():
                out[name] = sha256_file(path)
        return out

    def fingerprint(self) -> str:
        """Hash of what the results depend on (not retries, chunk, outputs), including the
        content of the files the points read (:meth:`inputs`): guards a resume."""
        d = self.to_dict()
        for k in ("retries", "chunk", "variables", "formats", "name"):
            d.pop(k)
        d["inputs"] = self.inputs()
        return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()[:16]

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "kind": self.kind,
            "function": self.function,
            "seed": self.seed,
            "seconds": self.seconds,
            "retries": self.retries,
            "chunk": self.chunk,
            "fixed": dict(self.fixed),
            "grid": {k: list(v) for k, v in self.grid},
            "montecarlo": None
            if self.units is None
            else {"units": self.units, **{d.param: d.to_dict() for d in self.distributions}},
            "variables": None if self.variables is None else list(self.variables),
            "formats": list(self.formats),
        }


def load_spec(path: str | Path) -> SweepSpec:
    """Read and validate a sweep file (TOML); a bad field raises ValueError naming it."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            doc = toml_load(fh, f"sweep file {path}")
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"sweep file {path}: not valid TOML ({exc})") from None
    doc.setdefault("name", path.stem)
    return parse_spec(doc)


def _int(name: str, value: object, lo: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < lo:
        raise ValueError(f"{name} must be an integer >= {lo}, got {value!r}")
    return value


def _table(doc: Mapping[str, Any], key: str) -> Mapping[str, Any]:
    t = doc.get(key, {})
    if not isinstance(t, Mapping):
        raise ValueError(f"{key} must be a table, got {t!r}")
    return t


def _param_spec(kind: str, field_name: str, name: str) -> Param | None:
    if kind == "python":
        return None
    known = params_for(kind)
    if name not in known:
        raise ValueError(f"{field_name}: unknown parameter for kind {kind!r} (known: {', '.join(sorted(known))})")
    return known[name]


def _axis_values(kind: str, name: str, raw: object) -> tuple[Any, ...]:
    field_name = f"grid.{name}"
    p = _param_spec(kind, field_name, name)
    if isinstance(raw, str):
        if p is not None and p.type is str:
            raise ValueError(f"{field_name} must be a list of strings, got {raw!r}")
        values: list[Any] = parse_list(raw, field_name)
    elif isinstance(raw, list):
        values = list(raw)
    else:
        raise ValueError(f"{field_name} must be a list or a range string 'a:b:step', got {raw!r}")
    if not values:
        raise ValueError(f"{field_name} must not be empty")
    if p is not None:
        values = [p.coerce(field_name, v) for v in values]
    elif not all(isinstance(v, (int, float, str)) and not isinstance(v, bool) for v in values):
        raise ValueError(f"{field_name} values must be numbers or strings, got {raw!r}")
    elif len({type(v) is str for v in values}) > 1:
        raise ValueError(f"{field_name} mixes numbers and strings: {raw!r}")
    if len(set(values)) != len(values):
        raise ValueError(f"{field_name} has repeated values: {raw!r}")
    return tuple(values)


def _distribution(kind: str, name: str, raw: object) -> Distribution:
    field_name = f"montecarlo.{name}"
    p = _param_spec(kind, field_name, name)
    if p is not None and p.type is not float:
        raise ValueError(f"{field_name}: only numeric parameters can be drawn")
    if not isinstance(raw, Mapping):
        raise ValueError(f"{field_name} must be a table like {{dist = 'normal', mean = 0, sd = 1}}, got {raw!r}")
    dist = raw.get("dist")
    if dist not in _DISTS:
        raise ValueError(f"{field_name}.dist must be one of {', '.join(_DISTS)}; got {dist!r}")
    names = _DISTS[dist]
    extra = set(raw) - {"dist", *names}
    if extra:
        raise ValueError(f"{field_name}: unknown key {sorted(extra)[0]!r} for a {dist} distribution")
    args = []
    for a in names:
        if a not in raw:
            raise ValueError(f"{field_name}.{a} is missing")
        args.append(Param(float).number(f"{field_name}.{a}", raw[a]))
    if dist in ("normal", "lognormal") and args[1] < 0:
        raise ValueError(f"{field_name}.{names[1]} must be >= 0, got {args[1]!r}")
    if dist == "uniform" and not args[0] < args[1]:
        raise ValueError(f"{field_name}: low must be < high, got low={args[0]!r}, high={args[1]!r}")
    return Distribution(name, dist, (args[0], args[1]))


def _check_names(fixed: Mapping[str, Any], grid: list[tuple[str, tuple[Any, ...]]]) -> None:
    """Profiles and sensors are names or files: check each once here, not once per point."""
    from vrelab.profiles import parse_profile
    from vrelab.sensor import load_sensor

    values = {k: [("fixed." + k, v)] for k, v in fixed.items()}
    for k, vs in grid:
        values[k] = [(f"grid.{k}", v) for v in vs]
    for field_name, v in values.get("profile", []):
        try:
            parse_profile(v)
        except (ValueError, OSError) as exc:
            raise ValueError(f"{field_name}: {exc}") from None
    for field_name, v in values.get("sensor", []):
        try:
            load_sensor(v)
        except (ValueError, OSError) as exc:
            raise ValueError(f"{field_name}: {exc}") from None
    # an axis is x, y, z or an identified file's channel: each sensor says which it has
    for field_name, a in values.get("axis", []):
        for _, v in values.get("sensor", []) or [("", "adxl355")]:  # the points' default sensor
            try:
                load_sensor(v, axis=a)
            except (ValueError, OSError) as exc:
                raise ValueError(f"{field_name}: {exc}") from None


_RESERVED = frozenset({"unit", "units", "index", "status", "error"})
# Point parameters that may name a file (a sensor TOML, a profile CSV/TOML).
_FILE_KEYS = ("sensor", "profile")
_TOP = {"name", "kind", "function", "seed", "seconds", "retries", "chunk", "fixed", "grid", "montecarlo", "output"}


def parse_spec(doc: Mapping[str, Any]) -> SweepSpec:
    """Validate a sweep description (the parsed TOML as a mapping); the input is not modified.

    Checked in the file's order, so the first problem is the one named: the header, the tables'
    reserved names, [fixed], [grid], [montecarlo], what the kind needs, [output]."""
    kind, name, function, seconds = _header(doc)
    seed = _int("seed", doc.get("seed", 0), 0)
    retries = _int("retries", doc.get("retries", 1), 0)
    chunk = _int("chunk", doc.get("chunk", 1), 1)
    seconds = _seconds(kind, seconds)
    for table in ("fixed", "grid", "montecarlo"):
        for k in _table(doc, table):
            if k in _RESERVED and not (table == "montecarlo" and k == "units"):
                raise ValueError(f"{table}.{k}: the name is reserved for the outputs ({', '.join(sorted(_RESERVED))})")
    fixed = _fixed(kind, doc)
    grid: list[tuple[str, tuple[Any, ...]]] = []
    for k, v in _table(doc, "grid").items():
        if k in fixed:
            raise ValueError(f"grid.{k} is also in [fixed]")
        grid.append((k, _axis_values(kind, k, v)))
    units, dists = _montecarlo(kind, doc, fixed, grid)
    _check_needs(kind, fixed, grid, dists)
    variables, formats = _output(doc)
    spec = SweepSpec(
        kind=kind,
        grid=tuple(grid),
        fixed=fixed,
        units=units,
        distributions=tuple(dists),
        seed=seed,
        function=function,
        seconds=seconds,
        retries=retries,
        chunk=chunk,
        variables=variables,
        formats=tuple(dict.fromkeys(formats)),
        name=name,
    )
    if spec.n_points > MAX_POINTS:
        raise ValueError(f"grid: {spec.n_points} points is more than {MAX_POINTS}; check the ranges")
    return spec


def _header(doc: Mapping[str, Any]) -> tuple[Kind, str, str | None, Any]:
    """(kind, name, function, seconds as written): the top-level fields checked, the tables' names known."""
    unknown = sorted(set(doc) - _TOP)
    if unknown:
        raise ValueError(f"{unknown[0]}: unknown field in sweep file (known: {', '.join(sorted(_TOP))})")
    kind = doc.get("kind")
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {', '.join(KINDS)}; got {kind!r}")
    name = doc.get("name", "sweep")
    if not isinstance(name, str) or not name:
        raise ValueError(f"name must be a non-empty string, got {name!r}")
    function = doc.get("function")
    if kind == "python":
        if not isinstance(function, str) or ":" not in function:
            raise ValueError(f"function must be 'module:name' for kind 'python', got {function!r}")
    elif function is not None:
        raise ValueError(f"function is only for kind 'python', got {function!r} with kind {kind!r}")
    return kind, name, function, doc.get("seconds")


def _seconds(kind: Kind, seconds: object) -> float | None:
    """A simulate sweep's level duration [s] (None: the shaker's default); refused for other kinds."""
    if seconds is None:  # a simulate sweep: the shaker's default
        return None
    if kind != "simulate":
        raise ValueError(f"seconds is only for kind 'simulate', got {seconds!r} with kind {kind!r}")
    return Param(float, "positive").number("seconds", seconds)


def _fixed(kind: Kind, doc: Mapping[str, Any]) -> dict[str, Any]:
    """[fixed]: each known parameter coerced, any other a plain number or string (kind python)."""
    fixed: dict[str, Any] = {}
    for k, v in _table(doc, "fixed").items():
        p = _param_spec(kind, f"fixed.{k}", k)
        if p is None:
            if not isinstance(v, (int, float, str, bool)):
                raise ValueError(f"fixed.{k} must be a number or a string, got {v!r}")
            fixed[k] = v
        else:
            fixed[k] = p.coerce(f"fixed.{k}", v)
    return fixed


def _montecarlo(kind: Kind, doc: Mapping[str, Any], fixed: Mapping[str, Any],
                grid: list[tuple[str, tuple[Any, ...]]]) -> tuple[int | None, list[Distribution]]:
    """[montecarlo]: (units, the parameters' distributions), or (None, []) without the table."""
    mc = dict(_table(doc, "montecarlo"))
    units = None
    dists: list[Distribution] = []
    if "montecarlo" in doc:
        if "units" not in mc:
            raise ValueError("montecarlo.units is missing")
        units = _int("montecarlo.units", mc.pop("units"), 1)
        for k in mc:
            if k in fixed or k in dict(grid):
                raise ValueError(f"montecarlo.{k} is also in [fixed] or [grid]")
            dists.append(_distribution(kind, k, mc[k]))
        if not dists:
            raise ValueError("montecarlo needs at least one parameter distribution besides units")
    if not grid and units is None:
        raise ValueError("grid: a sweep needs a [grid] axis or a [montecarlo] lot")
    return units, dists


def _check_needs(kind: Kind, fixed: Mapping[str, Any], grid: list[tuple[str, tuple[Any, ...]]],
                 dists: Sequence[Distribution]) -> None:
    """What the kind needs is given ([fixed], [grid] or a distribution), and exactly one drive."""
    if kind in REQUIRED:
        have = set(fixed) | {k for k, _ in grid} | {d.param for d in dists}
        for r in REQUIRED[kind]:
            if r not in have:
                raise ValueError(f"{r}: kind {kind!r} needs it in [fixed] or [grid]")

    if kind in ("predict", "simulate"):
        have = set(fixed) | {k for k, _ in grid}
        if ("profile" in have) == ("freq_hz" in have):
            raise ValueError(f"profile: kind {kind!r} needs exactly one of profile (random) and freq_hz (sine)")

        _check_names(fixed, grid)


def _output(doc: Mapping[str, Any]) -> tuple[tuple[str, ...] | None, list[str]]:
    """[output]: (the variables asked for or None: all, the formats as written)."""
    out = _table(doc, "output")
    extra = sorted(set(out) - {"variables", "formats"})
    if extra:
        raise ValueError(f"output.{extra[0]}: unknown field (known: variables, formats)")
    variables = out.get("variables")
    if variables is not None:
        if not isinstance(variables, list) or not variables or not all(isinstance(v, str) for v in variables):
            raise ValueError(f"output.variables must be a non-empty list of names, got {variables!r}")
        if {"status", "error"} & set(variables):
            raise ValueError("output.variables: status and error are always written; do not list them")
        variables = tuple(variables)
    formats = out.get("formats", ["netcdf", "csv"])
    if not isinstance(formats, list) or not formats or any(f not in FORMATS for f in formats):
        raise ValueError(f"output.formats must be a non-empty list from {', '.join(FORMATS)}; got {formats!r}")
    return variables, formats
