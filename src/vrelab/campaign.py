"""Campaigns: every run of one shaker test, from a TOML manifest (SPEC 4.1).

A lab's test is many files: one per run (frequency, orientation, level block), each holding
several DUT channels (a 3-axis part, several parts on one fixture) and a reference. The
manifest names them; :func:`read_manifest` validates it whole before anything is read (an
unknown key, a missing file or channel, a channel without its static field, one file channel
named twice, one recording used twice for a DUT or at two static fields, a DUT that is the
reference: one line naming the run(s) and the key); a static field the DUT's own vibration-off
reading contradicts refuses the campaign when that run's record is read (:func:`check_static`);
:func:`run_campaign` reduces every run (in parallel with ``workers``; a run that fails is kept
as failed with its error, the others go on) and :func:`combine` gives per channel:

* ``vrc_by_freq``: the VRC of every sine frequency at every orientation;
* ``k2`` and ``k3`` per frequency measured at two orientations or more
  (``VRC(g0) = k2 + 3·k3·g0``, :func:`vrelab.fits.fit_k2_k3`), combined over those
  frequencies by their covariance-weighted mean (:func:`vrelab.fits.combine_fits`); k2 alone
  from a frequency measured only at g0 = 0 (where VRC = k2); null with the reason otherwise;
* the effective ``rail`` from every random run (weighted mean);
* ``vrc_by_mount``: the apparent VRC of every sine run mounted at an angle (IEEE 1293's
  procedure for the cross-coupling coefficients, SPEC 1.6: ``mount_deg``, ``mount_plane`` ip|io
  and the whole static field ``static_g = [i, p, o]``, :class:`Mount`), kept out of the above
  and fitted by :func:`vrelab.identify.fit_cross_coupling`.

Data flow: manifest -> :class:`Run` -> record (:func:`vrelab.analysis.readers.open_record`,
several DUTs) -> :func:`vrelab.analysis.pipeline.analyze_channels` -> per-run results ->
:func:`combine` -> the campaign document (``results.json``) and folder.
"""

from __future__ import annotations

import math
import shutil
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Mapping, Sequence, cast

from vrelab import _validate as V
from vrelab._format import finite_or_none
from vrelab._io import sha256_file
from vrelab._load import toml_loads
from vrelab._version import __version__
from vrelab.gum import (
    TYPE_B_KEYS,
    common_sensitivity_terms,
    weighted_mean,
    weighted_mean_chi2,
)
from vrelab.results import Estimate, FitResult, K2K3Model, K2Model, VreResult, group_by_frequency

if TYPE_CHECKING:
    from vrelab.analysis.plausibility import MethodRequest
    from vrelab.sensor import Sensor

RUN_KEYS = (
    "file", "dut", "reference", "method", "static_g", "label", "fs_hz", "time", "dut_units",
    "dut_sensitivity", "reference_units", "reference_sensitivity", "schedule", "profile", "band",
    "settle_s", "rail_g", "u_reference_pct", "u_dut_pct", "u_static_g", "u_thermal_g", "mount_deg", "mount_plane",
)  # fmt: skip
BUDGET_KEYS = TYPE_B_KEYS  # a run's declared Type B budget (vrelab.gum)
TOP_KEYS = ("name", "description", "sensor", "defaults", "run")
# Orientations closer than this [g] are the same orientation (a fixture's alignment error).
SAME_ORIENTATION_G = 0.1
# IEEE 1293's mount planes (SPEC 1.6): the input axis i tilted toward the pendulous axis p, or
# toward the output axis o (the triad of vrelab.sensor.Sensor.triad).
MOUNT_PLANES = ("ip", "io")


@dataclass(frozen=True)
class Mount:
    """How one DUT channel sits in an IEEE 1293 mount-angle run (SPEC 1.6, 4.1).

    The part's input axis i is at ``deg`` to the vibration, tilted in the ``plane`` "ip" (toward
    its pendulous axis p) or "io" (toward its output axis o): the vibration's direction in the
    part's triad (i, p, o) is ``(cos φ, sin φ, 0)`` or ``(cos φ, 0, sin φ)``
    (:func:`vrelab.triaxial.direction`). ``static_g`` is the whole static field in that triad
    [g]: along the vibration on a vertical shaker, across it on a slip table (:func:`_mount`
    refuses anything else, and a static field given by its input-axis component only).
    """

    deg: float
    plane: str  # "ip" | "io"
    static_g: tuple[float, float, float]  # [i, p, o]

    @property
    def direction(self) -> tuple[float, float, float]:
        """The vibration's unit direction in (i, p, o)."""
        c, s = math.cos(math.radians(self.deg)), math.sin(math.radians(self.deg))
        c, s = (0.0 if abs(c) < 1e-15 else c), (0.0 if abs(s) < 1e-15 else s)  # cos 90° is 6e-17, not 0
        return (c, s, 0.0) if self.plane == "ip" else (c, 0.0, s)

    @property
    def tilted(self) -> bool:
        """The input axis is off the vibration (φ not 0° or 180°): the run sees the cross terms."""
        return abs(math.sin(math.radians(self.deg))) > 1e-9

    @property
    def shaker(self) -> str:
        """"vertical" (gravity along the vibration) or "slip table" (across it)."""
        along = sum(g * d for g, d in zip(self.static_g, self.direction))
        return "vertical" if abs(along) > SAME_ORIENTATION_G else "slip table"

    def to_dict(self) -> dict[str, Any]:
        return {"mount_deg": self.deg, "mount_plane": self.plane, "static_vector_g": list(self.static_g),
                "shaker": self.shaker}


@dataclass(frozen=True)
class Run:
    """One run of a campaign, validated: paths absolute, one static field per DUT channel."""

    index: int  # 1-based, in manifest order
    file: Path
    dut: Mapping[str, str]  # campaign channel name -> the file's channel
    static_g: Mapping[str, float]
    label: str
    reference: str | None = None
    method: MethodRequest = "auto"
    fs_hz: float | None = None
    time: str | None = None
    dut_units: str | None = None  # None: the unit the file states, else g
    dut_sensitivity: Mapping[str, float | None] = field(default_factory=dict)
    reference_units: str | None = None
    reference_sensitivity: float | None = None
    schedule: Path | None = None
    profile: str | None = None
    band: tuple[float, float] | None = None
    settle_s: float | None = None
    rail_g: float | None = None
    budget: Mapping[str, float] = field(default_factory=dict)
    mount: Mapping[str, Mount] = field(default_factory=dict)  # channel -> its mount (mount-angle runs only)

    @property
    def where(self) -> str:
        return f"run {self.index} ({self.label!r})"


@dataclass(frozen=True)
class Manifest:
    """A campaign manifest, validated (:func:`read_manifest`)."""

    path: Path
    name: str
    runs: tuple[Run, ...]
    description: str = ""
    # campaign channel -> the sensor file (or preset) its DUT is, when the manifest's `sensor` key
    # names one: the units check then holds each run to that sensor's response (SPEC 4.1)
    sensors: Mapping[str, Sensor] = field(default_factory=dict, compare=False)

    @property
    def channels(self) -> tuple[str, ...]:
        """Every campaign channel, in order of first appearance."""
        return tuple(dict.fromkeys(c for r in self.runs for c in r.dut))


# --------------------------------------------------------------------------- the manifest


def read_manifest(path: str | Path, check_files: bool = True) -> Manifest:
    """Read and validate a campaign manifest (SPEC 4.1); paths are relative to it.

    With ``check_files`` each run's file is opened (its header only where the format allows)
    to check that the channels exist. Every problem is one ``ValueError`` line naming the run
    and the key.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"campaign manifest not found: {path}")
    try:
        doc = toml_loads(path.read_text(encoding="utf-8"), path.name)
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path.name}: not valid TOML ({exc})") from None
    for key in doc:
        if key not in TOP_KEYS:
            raise ValueError(f"{path.name}: unknown key {key!r} (top level keys: {', '.join(TOP_KEYS)})")
    defaults = doc.get("defaults", {})
    if not isinstance(defaults, dict):
        raise ValueError(f"{path.name}: [defaults] must be a table")
    for key in defaults:
        if key not in RUN_KEYS or key == "file":
            raise ValueError(f"{path.name}: [defaults]: unknown key {key!r} (run keys: {', '.join(RUN_KEYS[1:])})")
    runs_doc = doc.get("run")
    if not isinstance(runs_doc, list) or not runs_doc:
        raise ValueError(f"{path.name}: no [[run]] table: a campaign needs one run at least")
    runs = tuple(_run(path, i, {**defaults, **r} if isinstance(r, dict) else r) for i, r in enumerate(runs_doc, 1))
    name = doc.get("name", path.stem)
    if not isinstance(name, str) or not name.strip():
        raise ValueError(f"{path.name}: name must be a non-empty string")
    description = doc.get("description", "")
    if not isinstance(description, str):
        raise ValueError(f"{path.name}: description must be a string, got a {_toml_type(description)}")
    channels = tuple(dict.fromkeys(c for r in runs for c in r.dut))
    m = Manifest(path.resolve(), name.strip(), runs, description, _sensors(path, doc.get("sensor"), channels))
    if check_files:
        listings: dict[Path, _Names] = {}  # a file's channel names are read once, however many runs use it
        for run in runs:
            _check_channels(run, listings)
        check_records(runs)
    return m


def _toml_type(value: Any) -> str:
    """What a TOML value is, in TOML's words (a table, an array, ...), for a refusal."""
    kinds = ((bool, "boolean"), (dict, "table"), (list, "array"), (int, "integer"), (float, "float"), (str, "string"))
    return next((name for t, name in kinds if isinstance(value, t)), type(value).__name__)


def _sensors(manifest: Path, value: Any, channels: Sequence[str]) -> dict[str, Sensor]:
    """The manifest's ``sensor`` key: a preset name or a sensor file (relative to the manifest)
    for every DUT channel, or a table channel -> one; each channel's axis is the file's axis of
    its name when the file has one (an identified file, ``vrelab identify``), else its default."""
    if value is None:
        return {}
    from vrelab.sensor import load_sensor

    where = f"{manifest.name}: sensor"
    if isinstance(value, dict):
        for c in value:
            if c not in channels:
                raise ValueError(f"{where}: {c!r} is not a DUT channel of the campaign ({', '.join(channels)})")
        specs = dict(value)
    elif isinstance(value, str):
        specs = {c: value for c in channels}
    else:
        raise ValueError(f"{where} must be a preset name or a sensor file, or a table channel = one; "
                         f"got a {_toml_type(value)}")
    out: dict[str, Sensor] = {}
    for c, spec in specs.items():
        if not isinstance(spec, str) or not spec.strip():
            raise ValueError(f"{where}: {c!r} must be a preset name or a sensor file")
        p = Path(spec) if Path(spec).is_absolute() else manifest.parent / spec
        text = str(p.resolve()) if p.is_file() else spec.strip()
        try:
            s = load_sensor(text)
            if c in s.axes and c != s.axis:
                s = load_sensor(text, axis=c)
        except ValueError as exc:
            raise ValueError(f"{where}: {c!r}: {exc}") from None
        out[c] = s
    return out


def _run(manifest: Path, index: int, d: Any) -> Run:
    where = f"{manifest.name}: run {index}"
    if not isinstance(d, dict):
        raise ValueError(f"{where}: must be a table")
    label = d.get("label")
    if label is not None:
        if not isinstance(label, str):
            raise ValueError(f"{where}: label must be a string")
        where = f"{manifest.name}: run {index} ({label!r})"
    for key in d:
        if key not in RUN_KEYS:
            raise ValueError(f"{where}: unknown key {key!r} (run keys: {', '.join(RUN_KEYS)})")
    if "file" not in d:
        raise ValueError(f"{where}: key 'file' missing")
    file = _path(manifest, where, "file", d["file"])
    label = label or file.name
    dut = _duts(where, d.get("dut"))
    mount = _mount(where, d, dut)
    # a mount-angle run's static field along the input axis is its vector's i component
    static = ({c: m.static_g[0] for c, m in mount.items()} if mount
              else _per_channel(where, "static_g", _scalar_static(where, d.get("static_g")), dut, required=True))
    sens = _per_channel(where, "dut_sensitivity", d.get("dut_sensitivity"), dut, required=False, positive=True)
    try:
        run = Run(
            index=index, file=file, dut=dut, label=label,
            static_g={k: V.acceleration(f"static_g.{k}", v) for k, v in static.items()},
            reference=_opt_str(where, "reference", d.get("reference")),
            method=cast("MethodRequest", _choice(where, "method", d.get("method", "auto"), ("auto", "random", "sine"))),
            fs_hz=_number(where, "fs_hz", d.get("fs_hz"), positive=True),
            time=_opt_str(where, "time", d.get("time")),
            dut_units=None if d.get("dut_units") is None else str(d["dut_units"]),
            dut_sensitivity=sens,
            reference_units=None if d.get("reference_units") is None else str(d["reference_units"]),
            reference_sensitivity=_number(where, "reference_sensitivity", d.get("reference_sensitivity"), positive=True),
            schedule=_path(manifest, where, "schedule", d["schedule"]) if "schedule" in d else None,
            profile=_profile(manifest, where, d.get("profile")),
            band=_band(where, d.get("band")),
            settle_s=_number(where, "settle_s", d.get("settle_s"), positive=False),
            rail_g=_number(where, "rail_g", d.get("rail_g"), positive=True),
            budget={k: _number(where, k, d[k], positive=False) for k in BUDGET_KEYS if k in d},  # type: ignore[misc]
            mount=mount,
        )  # fmt: skip
        _scales(run)  # units and sensitivities agree
    except ValueError as exc:
        msg = str(exc)
        raise ValueError(msg if msg.startswith(manifest.name) else f"{where}: {msg}") from None
    _check_reference(run)
    return run


def _scalar_static(where: str, value: Any) -> Any:
    if isinstance(value, list) or (isinstance(value, dict) and any(isinstance(v, list) for v in value.values())):
        raise ValueError(f"{where}: static_g {value!r} is a vector: a static field [i, p, o] belongs to a mount-angle "
                         "run (with mount_deg and mount_plane); otherwise give the static field along the input axis, "
                         "a number")
    return value


def _mount(where: str, d: Mapping[str, Any], dut: Mapping[str, str]) -> dict[str, Mount]:
    """The run's IEEE 1293 mount per DUT channel (``mount_deg``, ``mount_plane`` and ``static_g``
    as the vector [i, p, o]: each a value for all or a table per channel); {} without the keys.

    The static vector is the whole static field in the part's triad: a number (its input-axis
    component) leaves where gravity points ambiguous and is refused, and so is a vector neither
    along the vibration (a vertical shaker) nor across it (a slip table) within
    ``SAME_ORIENTATION_G``, or whose size is not 1 g within it (a part at rest)."""
    deg_raw, plane_raw = d.get("mount_deg"), d.get("mount_plane")
    if deg_raw is None and plane_raw is None:
        return {}
    if plane_raw is None:
        raise ValueError(f"{where}: mount_deg without mount_plane: give the plane the input axis is tilted in, "
                         "ip (toward the pendulous axis) or io (toward the output axis)")
    if deg_raw is None:
        raise ValueError(f"{where}: mount_plane without mount_deg: give the angle of the DUT's input axis to the "
                         "vibration in degrees (mount_deg = 45)")
    degs = _per_channel(where, "mount_deg", deg_raw, dut, required=True)
    planes = _per_channel_value(where, "mount_plane", plane_raw, dut, _plane)
    raw = d.get("static_g")
    if raw is None:
        raise ValueError(f"{where}: key 'static_g' missing: give the whole static field [i, p, o] of "
                         f"{', '.join(dut)} (a vector for all, or a table per channel)")
    if isinstance(raw, dict):
        _covers_the_channels(where, "static_g", raw, dut)
    out: dict[str, Mount] = {}
    for c in dut:
        deg, plane = degs[c], planes[c]
        assert deg is not None
        V.mount_angle(f"{where}: mount_deg of {c!r}", deg)
        probe = Mount(deg, plane, (1.0, 0.0, 0.0))
        di, dp, do = probe.direction
        hint = (f"on a vertical shaker gravity lies along the vibration, ±[{di:.4g}, {dp:.4g}, {do:.4g}]; on a slip "
                f"table across it (e.g. [0, 0, 1] for the IP plane)")
        vec = raw.get(c) if isinstance(raw, dict) else raw
        if not isinstance(vec, list):
            raise ValueError(f"{where}: static_g of {c!r} must be the whole static field [i, p, o] in g in a mount-angle "
                             f"run (a number gives its input-axis component only: where gravity points is ambiguous): {hint}")
        if len(vec) != 3 or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vec):
            raise ValueError(f"{where}: static_g of {c!r} must be three numbers [i, p, o] in g, got {vec!r}")
        g = tuple(V.acceleration(f"static_g.{c}", v) for v in vec)
        size = math.sqrt(sum(x * x for x in g))
        if abs(size - 1.0) > SAME_ORIENTATION_G:
            raise ValueError(f"{where}: static_g of {c!r} {vec!r} is {size:.3g} g in size: a part at rest sees 1 g "
                             "(give the whole static field [i, p, o])")
        along = g[0] * di + g[1] * dp + g[2] * do
        across = math.sqrt(max(size * size - along * along, 0.0))
        if abs(along) > SAME_ORIENTATION_G and across > SAME_ORIENTATION_G:
            raise ValueError(f"{where}: static_g of {c!r} {vec!r} is neither along the vibration nor across it at "
                             f"{deg:g}° in the {plane.upper()} plane ({along:+.3g} g along it, {across:.3g} g across): "
                             f"{hint}; check mount_deg and static_g")
        out[c] = Mount(deg, plane, (g[0], g[1], g[2]))
    return out


def _plane(where: str, key: str, value: Any) -> str:
    if not isinstance(value, str) or value.strip().lower() not in MOUNT_PLANES:
        raise ValueError(f"{where}: {key} must be ip (the input axis tilted toward the pendulous axis) or io "
                         f"(toward the output axis), got {value!r}")
    return value.strip().lower()


def _covers_the_channels(where: str, key: str, table: Mapping[str, Any], dut: Mapping[str, str]) -> None:
    """A per-channel table names the run's DUT channels, each of them and no other."""
    for c in table:
        if c not in dut:
            raise ValueError(f"{where}: {key}: {c!r} is not a DUT channel of the run ({', '.join(dut)})")
    missing = [c for c in dut if c not in table]
    if missing:
        raise ValueError(f"{where}: {key}: no value for channel {missing[0]!r}")


def _per_channel_value(where: str, key: str, value: Any, dut: Mapping[str, str],
                       parse: Callable[[str, str, Any], str]) -> dict[str, str]:
    """A value for all the run's DUT channels, or a table name -> value covering each."""
    if isinstance(value, dict):
        _covers_the_channels(where, key, value, dut)
        return {c: parse(where, f"{key}.{c}", value[c]) for c in dut}
    x = parse(where, key, value)
    return {c: x for c in dut}


def _path(manifest: Path, where: str, key: str, value: Any) -> Path:
    if not isinstance(value, str) or not value.strip():
        raise ValueError(f"{where}: {key} must be a path (relative to the manifest)")
    p = Path(value)
    p = p if p.is_absolute() else manifest.parent / p
    if not p.is_file():
        raise ValueError(f"{where}: {key} {value!r} not found ({p})")
    return p.resolve()


def _duts(where: str, value: Any) -> dict[str, str]:
    if value is None:
        raise ValueError(f"{where}: key 'dut' missing (the DUT channels along the shaker axis)")
    if isinstance(value, str):
        value = [value]
    if isinstance(value, list):
        pairs = [(v, v) for v in value]
    elif isinstance(value, dict):
        pairs = list(value.items())
    else:
        raise ValueError(f"{where}: dut must be a channel, a list of channels or a table name = channel")
    out: dict[str, str] = {}
    seen: dict[str, str] = {}
    for name, ch in pairs:
        if not isinstance(ch, str) or not ch.strip() or not str(name).strip():
            raise ValueError(f"{where}: dut {name!r}: give a channel name of the file")
        if name in out:
            raise ValueError(f"{where}: dut: channel {name!r} named twice")
        if ch.strip() in seen:
            raise ValueError(f"{where}: dut: the file's channel {ch!r} given twice ({seen[ch.strip()]!r} and {name!r})")
        seen[ch.strip()] = name
        out[str(name).strip()] = ch.strip()
    if not out:
        raise ValueError(f"{where}: dut: no channel")
    return out


def _per_channel(where: str, key: str, value: Any, dut: Mapping[str, str], required: bool,
                 positive: bool = False) -> dict[str, float | None]:
    """A number for all the run's DUT channels, or a table name -> number covering each."""
    if value is None:
        if required:
            raise ValueError(f"{where}: key {key!r} missing: give the static field of "
                             f"{', '.join(dut)} (a number for all, or a table per channel)")
        return {c: None for c in dut}
    if isinstance(value, dict):
        for c in value:
            if c not in dut:
                raise ValueError(f"{where}: {key}: {c!r} is not a DUT channel of the run ({', '.join(dut)})")
        missing = [c for c in dut if c not in value]
        if missing and required:
            raise ValueError(f"{where}: {key}: no value for channel {missing[0]!r}")
        return {c: (_number(where, f"{key}.{c}", value[c], positive) if c in value else None) for c in dut}
    x = _number(where, key, value, positive)
    return {c: x for c in dut}


def _number(where: str, key: str, value: Any, positive: bool) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"{where}: {key} must be a finite number, got {value!r}")
    if positive and value <= 0:
        raise ValueError(f"{where}: {key} must be > 0, got {value!r}")
    if not positive and key in ("settle_s", *BUDGET_KEYS) and value < 0:
        raise ValueError(f"{where}: {key} must be >= 0, got {value!r}")
    return float(value)


def _opt_str(where: str, key: str, value: Any) -> str | None:
    if value is None:
        return None
    if not isinstance(value, str) or not value.strip():
        raise ValueError(f"{where}: {key} must be a non-empty string")
    return value.strip()


def _choice(where: str, key: str, value: Any, options: Sequence[str]) -> str:
    if value not in options:
        raise ValueError(f"{where}: {key} must be one of {', '.join(options)}, got {value!r}")
    return str(value)


def _profile(manifest: Path, where: str, value: Any) -> str | None:
    if value is None:
        return None
    if not isinstance(value, str) or not value.strip():
        raise ValueError(f"{where}: profile must be a string (a file, a name, F:P,... or flat:F1-F2)")
    p = manifest.parent / value
    text = str(p.resolve()) if p.is_file() else value
    from vrelab.profiles import parse_profile

    parse_profile(text)  # validated now, parsed again where used (a string crosses processes)
    return text


def _band(where: str, value: Any) -> tuple[float, float] | None:
    if value is None:
        return None
    if (not isinstance(value, list) or len(value) != 2
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
            or not all(math.isfinite(v) for v in value) or not 0 < value[0] < value[1]):
        raise ValueError(f"{where}: band must be [F1, F2] in Hz, finite, with 0 < F1 < F2, got {value!r}")
    return float(value[0]), float(value[1])


def _scales(run: Run) -> tuple[dict[str, Any], Any]:
    from vrelab.analysis.readers import Scale

    # neither a unit nor a sensitivity: None, the unit the file states (else g) is used
    dut = {c: Scale.parse(run.dut_units, run.dut_sensitivity.get(c), f"dut {c}")
           if run.dut_units is not None or run.dut_sensitivity.get(c) is not None else None for c in run.dut}
    ref = (Scale.parse(run.reference_units, run.reference_sensitivity, "reference")
           if run.reference_units is not None or run.reference_sensitivity is not None else None)
    return dut, ref


def _check_channels(run: Run, listings: dict[Path, _Names] | None = None) -> None:
    """The run's file is of a known format and holds its channels (its names only: a text
    format is not parsed, a UFF58 file's headers only)."""
    from vrelab.analysis.readers import resolve_channel
    from vrelab.analysis.readers._base import reader_for

    listing = (listings or {}).get(run.file)
    if listing is None:
        try:
            cls = reader_for(run.file)
            names = cls.channel_names(run.file)
        except ValueError as exc:
            raise ValueError(f"{run.where}: file: {exc}") from None
        except Exception as exc:  # a format library's own error on a corrupt file
            raise ValueError(f"{run.where}: file: {run.file.name}: cannot read as {cls.fmt.upper()}: "
                             f"{type(exc).__name__}: {exc}") from None
        listing = _Names(run.file, names)
        if listings is not None:
            listings[run.file] = listing
    found = {}
    for name, ch in run.dut.items():
        try:
            found[name] = resolve_channel(ch, listing, f"DUT {name!r}")  # type: ignore[arg-type]
        except ValueError as exc:
            raise ValueError(f"{run.where}: dut: {exc}") from None
    if run.reference is not None:
        try:
            ref = resolve_channel(run.reference, listing, "reference")  # type: ignore[arg-type]
        except ValueError as exc:
            raise ValueError(f"{run.where}: reference: {exc}") from None
        _check_reference(run, found, ref)


def _check_reference(run: Run, found: Mapping[str, str] | None = None, ref: str | None = None) -> None:
    """No DUT channel is the run's reference (as written, or as the file's names resolve them):
    a DUT reduced against itself reads no VRE at all, and the run would fail only when executed."""
    ref = run.reference if ref is None else ref
    if ref is None:
        return
    for name, ch in (found or run.dut).items():
        if ch == ref:
            raise ValueError(f"{run.where}: dut {name!r} is the reference channel {ref!r}: a DUT is measured "
                             "against another sensor, never against itself")


# Reading as much of each end of a file identifies its content among a campaign's records (the
# header, the first and last samples); files that agree there are hashed whole before being
# called the same (a real check, and a rare one: different recordings differ in their first MiB).
_FINGERPRINT_BYTES = 1 << 20


def _fingerprint(path: Path) -> tuple[int, bytes]:
    """(size, SHA-256 of the first and last MiB): equal for identical files, cheap for large ones."""
    import hashlib

    size = path.stat().st_size
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        h.update(fh.read(_FINGERPRINT_BYTES))
        if size > _FINGERPRINT_BYTES:
            fh.seek(max(_FINGERPRINT_BYTES, size - _FINGERPRINT_BYTES))
            h.update(fh.read(_FINGERPRINT_BYTES))
    return size, h.digest()


def _recordings(runs: Sequence[Run]) -> list[list[Run]]:
    """The runs grouped by recording (two or more per group): files that are the same path once
    resolved, or copies with identical content (size, first and last MiB, then the whole file's
    SHA-256). Linear in the runs: a file is fingerprinted once, never compared pair by pair (a
    manifest of 10 000 runs on one file made 50 million pairs)."""
    by_size: dict[int, dict[Path, list[Run]]] = {}
    for r in runs:
        by_size.setdefault(r.file.stat().st_size, {}).setdefault(r.file, []).append(r)
    groups: list[list[Run]] = []
    for files in by_size.values():
        if len(files) == 1:
            groups += [g for g in files.values() if len(g) > 1]
            continue
        by_print: dict[Any, list[Path]] = {}
        for f in files:
            by_print.setdefault(_fingerprint(f), []).append(f)
        for same_print in by_print.values():
            by_hash: dict[str, list[Path]] = {}
            for f in same_print:
                by_hash.setdefault(sha256_file(f) if len(same_print) > 1 else "", []).append(f)
            for paths in by_hash.values():
                group = sorted((r for f in paths for r in files[f]), key=lambda r: r.index)
                if len(group) > 1:
                    groups.append(group)
    return groups


def _first_shared(group: Sequence[Run]) -> tuple[Run, Run] | None:
    """The first two runs of one recording that share a DUT (by campaign name or by the file's
    channel) and are not each their own part of it (both with a schedule, different ones); in
    manifest order of the later run, then of the earlier. One pass with a table of the first run
    per (channel, schedule): linear in the runs."""
    first: dict[tuple[str, str], Run] = {}  # (name|channel, channel) -> its first run
    first_in: dict[tuple[str, str, Path | None], Run] = {}  # ... with this schedule (None: none)
    for b in group:
        keys = [*(("name", c) for c in b.dut), *(("channel", c) for c in b.dut.values())]
        # a run without a schedule meets every earlier one; with one, those of no or its schedule
        hits = ([first[k] for k in keys if k in first] if b.schedule is None else
                [first_in[k2] for k in keys for k2 in ((*k, None), (*k, b.schedule)) if k2 in first_in])
        if hits:
            return min(hits, key=lambda r: r.index), b
        for k in keys:
            first.setdefault(k, b)
            first_in.setdefault((*k, b.schedule), b)
    return None


def check_records(runs: Sequence[Run]) -> None:
    """Refuse a campaign that uses one recording twice for a channel.

    Two runs whose files are one recording (:func:`_recordings`) and that share a DUT (by its
    campaign name or by the file's channel) either count that recording's VRC twice, or, declared
    at two static fields, make k2 and k3 from one orientation as if it were two. Runs on one file
    for different DUTs (parts split into runs), or with different schedules (each its own part of
    a long record), are not refused.
    """
    for group in _recordings(runs):
        pair = _first_shared(group)
        if pair is None:
            continue
        a, b = pair
        how = f"the same file {a.file.name}" if a.file == b.file else f"identical files {a.file.name} and {b.file.name}"
        shared = [c for c in a.dut if c in b.dut]
        same_ch = [ch for ch in a.dut.values() if ch in b.dut.values()]
        both = f"{a.where} and {b.where} are {how}"
        for c in shared:
            ga, gb = a.static_g[c], b.static_g[c]
            if abs(ga - gb) >= SAME_ORIENTATION_G:
                raise ValueError(f"{both}, declared at {ga:+g} g and {gb:+g} g for {c!r}: one recording is one "
                                 "orientation (k2 and k3 need two records)")
        what = f"DUT {shared[0]!r}" if shared else f"the file's channel {same_ch[0]!r}"
        raise ValueError(f"{both}, both for {what}: its VRC would be counted twice (list each recording once)")


# A DUT with a DC response reads its static field at the vibration-off baselines, plus an offset
# of tens of mg at most for a MEMS part. A reading within 0.25 g of ±1 g says the run sat in
# Earth's field along the axis; a declared static_g more than 0.5 g from it (the other sign, or
# 0) is a slip of the manifest that turns k3 = ΔVRC/(3·Δg0) around. A DUT without a DC response
# (piezoelectric, IEPE) reads about 0 and is not judged; nor is a tilted one (|reading| < 0.75 g).
_EARTH_FIELD_WITHIN_G = 0.25
_STATIC_CONTRADICTED_G = 0.5


class ManifestContradiction(ValueError):
    """A run's declared conditions contradicted by its own record: the manifest is wrong, so the
    campaign is refused (not the run kept as failed)."""


def check_static(run: Run, channel: str, baseline_g: float | None) -> None:
    """Refuse a declared ``static_g`` the DUT's own vibration-off reading (``baseline_g`` [g],
    the mean of its baselines) contradicts (see the constants above); called after the record is
    read and before any of its numbers is kept."""
    if baseline_g is None or not math.isfinite(baseline_g):
        return
    g0 = run.static_g[channel]
    if abs(abs(baseline_g) - 1.0) <= _EARTH_FIELD_WITHIN_G and abs(g0 - baseline_g) > _STATIC_CONTRADICTED_G:
        raise ManifestContradiction(
            f"{run.where}: static_g of {channel!r} is declared {g0:+g} g, but the DUT's own vibration-off reading "
            f"is {baseline_g:+.3f} g: fix static_g (or the DUT's units/sensitivity)")


@dataclass(frozen=True)
class _Names:
    """What channel lookup (:func:`vrelab.analysis.readers.resolve_channel`) needs of a source:
    its path and channel names, all of them listed (``unlisted`` 0, nothing more to ``find``)."""

    path: Path
    channels: tuple[str, ...]
    unlisted: int = 0

    def find(self, name: str) -> bool:
        return False


# --------------------------------------------------------------------------- reducing runs


@dataclass
class RunResult:
    """One run reduced (``error`` set when it failed): per channel its result."""

    run: Run
    results: list[tuple[str, VreResult]] = field(default_factory=list)
    error: str | None = None
    folder: str | None = None  # sub-folder of the campaign folder, when written
    # channel -> (kind, frequency, DUT/reference ratio) of each level: the campaign's units check
    unit_probes: dict[str, list[tuple[str | None, float, float]]] = field(default_factory=dict)
    # channel -> the DUT's mean vibration-off reading [g]: the units check's range test
    off_reading_g: dict[str, float | None] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.error is None


def reduce_run(run: Run, out: Path | None = None, progress: bool = False, limit_g: float | None = None) -> RunResult:
    """Reduce one run: its record opened with every DUT, each reduced against the reference
    (:func:`vrelab.analysis.pipeline.analyze_channels`). With ``out`` the run's folder is
    written there (a ``results.json`` of its channels and a sub-folder per channel)."""
    from vrelab.analysis.options import BudgetOptions, ReductionOptions
    from vrelab.analysis.pipeline import analyze_channels
    from vrelab.analysis.readers import open_record
    from vrelab.gum import TypeB
    from vrelab.profiles import parse_profile
    from vrelab.record import DEFAULT_SETTLE_S, Schedule

    dut_scales, ref_scale = _scales(run)
    profile = parse_profile(run.profile) if run.profile else None
    schedule = Schedule.read_csv(run.schedule) if run.schedule else None
    prov = {"input_file": run.file.name, "input_sha256": sha256_file(run.file), "run": run.index, "label": run.label}
    with open_record(run.file, dict(run.dut), run.reference, run.fs_hz, dut_scales, ref_scale, run.time) as rec:
        reduced = analyze_channels(
            rec, None, run.method, schedule, static_g=dict(run.static_g),
            options=ReductionOptions(
                band_hz=run.band, rail_g=run.rail_g, progress=progress, profile=profile,
                settle_s=DEFAULT_SETTLE_S if run.settle_s is None else run.settle_s,
                # the units are judged per channel over all runs (run_campaign), not run by run: a
                # sweep's run at the DUT's resonance has DUT/reference = Q, and is not a slip
                accept=frozenset({"unit-ratio"}),
            ),
            budget=BudgetOptions(TypeB.from_mapping(run.budget) if run.budget else None, limit_g),
            provenance=prov,
        )  # fmt: skip
    for name, _, red in reduced:
        check_static(run, name, red.static_g)
    res = RunResult(run, [(name, result) for name, result, _ in reduced],
                    unit_probes={name: list(red.unit_probes) for name, _, red in reduced},
                    off_reading_g={name: red.static_g for name, _, red in reduced})
    if out is not None:
        from vrelab import folder as F
        from vrelab.results import channels_to_dict

        F.write_channels(out, res.results, channels_to_dict(res.results, prov))
    return res


def _reduce_safely(run: Run, out: Path | None, limit_g: float | None = None) -> RunResult:
    try:
        return reduce_run(run, out, limit_g=limit_g)
    except ManifestContradiction:
        raise  # the manifest is wrong: the whole campaign is refused
    except MemoryError:
        return RunResult(run, error="out of memory")
    except Exception as exc:  # a run's failure is reported with the others kept
        from vrelab._io import is_disk_full

        if is_disk_full(exc):  # not the run's failure: the whole campaign stops, nothing written
            raise OSError(28, "No space left on device") from None
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        if not isinstance(exc, (ValueError, OSError)):
            msg = f"internal error: {type(exc).__name__}: {msg}"
        return RunResult(run, error=msg)


def run_campaign(manifest: Manifest, workers: int = 1, out: Path | None = None,
                 on_done: Callable[[RunResult], None] | None = None, limit_g: float | None = None) -> list[RunResult]:
    """Reduce every run (``workers`` processes; 1: here, in order). A failing run is kept with
    its error; a run whose record contradicts the manifest (:class:`ManifestContradiction`)
    refuses the campaign. With ``out``, run ``i`` is written to ``out/runs/<NN-label>``. Each run's budget
    keys (SPEC 4.3) give its levels and fits their Type B terms; ``limit_g`` decides each level."""
    workers = V.integer("workers", workers, 1)
    subs = run_folders(manifest)
    dests = [None if out is None else out / "runs" / subs[r.index] for r in manifest.runs]
    results: list[RunResult]
    if workers == 1 or len(manifest.runs) == 1:
        results = []
        for run, dest in zip(manifest.runs, dests):
            results.append(_reduce_safely(run, dest, limit_g))
            if on_done:
                on_done(results[-1])
    else:
        from vrelab._pool import worker_pool  # workers die with this process (Ctrl-C, SIGTERM, SIGKILL)

        with worker_pool(min(workers, len(manifest.runs))) as pool:
            futures = [pool.submit(_reduce_safely, run, dest, limit_g) for run, dest in zip(manifest.runs, dests)]
            results = []
            for fut in futures:
                results.append(fut.result())
                if on_done:
                    on_done(results[-1])
    slipped = judge_units(results, manifest.sensors)
    for r, dest in zip(results, dests):
        if dest is not None and r.ok:
            r.folder = f"runs/{dest.name}"
        elif dest is not None and any(r is s for s in slipped) and dest.exists():
            shutil.rmtree(dest)  # written before the campaign's units check refused it
    return results


def dut_range(run: Run, channel: str, sensor: Sensor | None) -> tuple[float | None, str]:
    """The DUT's range [g] and where it comes from: the sensor file's full scale, else the run's
    ``rail_g``, else None (unknown)."""
    if sensor is not None:
        return sensor.full_scale_g, f"the sensor file {sensor.name!r}"
    if run.rail_g is not None:
        return run.rail_g, "the run's rail_g"
    return None, ""


def judge_units(results: Sequence[RunResult], sensors: Mapping[str, Sensor] | None = None) -> list[RunResult]:
    """SPEC 4.1/4.2's units check of every DUT channel over its runs; the runs it refuses are
    failed with the reason (their results dropped) and returned. In order:

    1. a run whose DUT reads, with vibration off, orders of magnitude beyond its range
       (:func:`vrelab.analysis.plausibility.off_reading_slip`);
    2. a run whose DUT/reference ratio departs from what the DUT's response allows at its
       frequency, or from the channel's other runs
       (:func:`vrelab.analysis.plausibility.judge_runs_units`; ``sensors`` gives a channel's
       response, else the stated default);
    3. a slip common to every run of a channel, judged where its response is flat
       (:func:`vrelab.analysis.plausibility.check_units_over_runs`): every run holding it fails.
    """
    from vrelab.analysis.plausibility import check_units_over_runs, judge_runs_units, off_reading_slip

    sensors = sensors or {}
    failed: list[RunResult] = []

    def fail(r: RunResult, msg: str) -> None:
        r.error = msg
        r.results = []
        failed.append(r)

    for r in results:
        if not r.ok:
            continue
        for ch, reading in r.off_reading_g.items():
            msg = off_reading_slip(ch, reading, *dut_range(r.run, ch, sensors.get(ch)))
            if msg is not None:
                fail(r, msg)
                break
    channels = list(dict.fromkeys(ch for r in results for ch in r.unit_probes))
    for ch in channels:
        sensor = sensors.get(ch)
        gain = None if sensor is None else _gain(sensor)
        runs = [(r.run.index, _mount_probes(r.run.mount.get(ch), r.unit_probes[ch]))
                for r in results if r.ok and ch in r.unit_probes]
        refused = judge_runs_units(ch, runs, gain)
        for r in results:
            if r.ok and r.run.index in refused:
                fail(r, refused[r.run.index])
    for ch in channels:
        probes = [p for r in results if r.ok and ch in r.unit_probes
                  for p in _mount_probes(r.run.mount.get(ch), r.unit_probes[ch])]
        msg = check_units_over_runs(ch, probes)
        if msg is None:
            continue
        for r in results:
            if r.ok and ch in r.unit_probes:
                fail(r, msg)
    return failed


def _gain(sensor: Sensor) -> Callable[[float], float]:
    """|H(f)| of the sensor's output (every linear stage: resonance, filters)."""
    return lambda f: float(abs(sensor.response(f)))


# A DUT mounted at φ sees cos φ of the vibration along its input axis: its DUT/reference ratio is
# judged divided by |cos φ| where that is at least this (a 90° run reads the cross-axis feed only).
_MOUNT_PROBE_COS = 0.5


def _mount_probes(mount: Mount | None, probes: Sequence[tuple[str | None, float, float]]
                  ) -> list[tuple[str | None, float, float]]:
    """A run's units probes of one channel as the units check reads them: a mount-angle run's
    DUT/reference ratio divided by its expected |cos φ|; none where |cos φ| < ``_MOUNT_PROBE_COS``."""
    if mount is None:
        return list(probes)
    c = abs(mount.direction[0])
    return [] if c < _MOUNT_PROBE_COS else [(k, f, ratio / c) for k, f, ratio in probes]


def run_folders(manifest: Manifest) -> dict[int, str]:
    """Run index -> its sub-folder name, ``NN-<label>``."""
    from vrelab.folder import channel_folder_names

    names = channel_folder_names([f"{r.index:02d}-{r.label}" for r in manifest.runs])
    return {r.index: names[f"{r.index:02d}-{r.label}"] for r in manifest.runs}


# --------------------------------------------------------------------------- combining


@dataclass(frozen=True)
class ChannelSummary:
    """What a campaign gives for one channel (SPEC 4.1, 5.1)."""

    channel: str
    vrc_by_freq: tuple[dict[str, Any], ...]
    k2_k3_by_freq: tuple[FitResult, ...]
    k2: Estimate | None
    k3: Estimate | None
    k2_k3: FitResult | None  # the combined fit (covariance kept), when both are determined
    rail: Estimate | None
    rails_by_run: tuple[dict[str, Any], ...]
    notes: tuple[str, ...]
    # the apparent VRC (VRE/rms²) of every sine run mounted at an angle (IEEE 1293, SPEC 1.6): not
    # the input axis's alone, so kept out of k2, k3 and the rail; vrelab.identify fits the cross terms
    vrc_by_mount: tuple[dict[str, Any], ...] = ()
    # the channel's noise with vibration off in each run (SPEC 4.4: density, bias instability,
    # the Allan deviation's minimum; the whole curve is in the run's own results)
    noise_by_run: tuple[dict[str, Any], ...] = ()

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
    """Per channel: VRC by frequency and orientation, k2/k3, the rail (see the module docstring)."""
    return [_combine_channel(ch, results) for ch in channels]


def _combine_channel(channel: str, results: Sequence[RunResult]) -> ChannelSummary:
    from vrelab.fits import combine_fits, fit_k2_k3

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
                             "not the input axis's alone (cross-coupling, SPEC 1.6): not used for k2, k3 or the rail "
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
            # FitResult.static_shift_g), so k2 and k3 are those of the pure polynomial (SPEC 4.4)
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
            notes.append(f"a distorted drive (SPEC 4.4): each VRC is k2 + 3*k3*(g0 + shift) with the shift its drive's "
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
    at the static fields g0 + shift) carried to its nominal g0 (SPEC 1.2's VRC = k2 + 3·k3·g0),
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
    so the drive's E[x³] adds ``3·k3·cos³φ·s`` to VRE/E[x²] (SPEC 1.6's cross terms are quadratic:
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
    return [f"a distorted drive (SPEC 4.4) on mount-angle run(s) {', '.join(left)}: no k2/k3 fit at their "
            "frequency, so their VRC carries an unknown 3*k3*cos³φ*shift (the fit's static_shift_g)"]


# Below this p-value of the χ² of the per-frequency k2 about their mean, they are said to disagree.
K2_CONSISTENCY_P = 0.05


def _k2_across_frequencies(fits: Sequence[FitResult]) -> list[str]:
    """What the combined k2 is, when it comes from more than one frequency: each frequency measures
    the apparent VRC(f) = k2·|H(f)|² (SPEC 1.3), and |H|² > 1 grows toward the resonance, so the
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


# --------------------------------------------------------------------------- the document


def campaign_doc(manifest: Manifest, results: Sequence[RunResult], summaries: Sequence[ChannelSummary],
                 command: str | None = None) -> dict[str, Any]:
    """The campaign's JSON (SPEC 5.1): ``runs`` and ``channels``."""
    runs = []
    for rr in results:
        r = rr.run
        d: dict[str, Any] = {
            "index": r.index, "file": _rel(r.file, manifest.path.parent), "label": r.label,
            "status": "ok" if rr.ok else "failed", "error": rr.error, "folder": rr.folder,
            "method": rr.results[0][1].method if rr.results else r.method,
            # what identification needs of the run beyond its levels (vrelab.identify): the drive's
            # spectrum shape and the declared Type B budget
            "profile": profile_document(r.profile), "budget": dict(r.budget),
            "channels": [],
        }  # fmt: skip
        for name, res in rr.results:
            rd = res.to_dict()
            d["channels"].append({"channel": name, "static_g": r.static_g[name],
                                  **(r.mount[name].to_dict() if name in r.mount else {}), **{k: rd[k] for k in (
                                      "levels", "fit", "fits", "warnings", "notices", "conditions")},
                                  **({"noise": rd["noise"]} if "noise" in rd else {})})
        runs.append(d)
    n_failed = sum(1 for rr in results if not rr.ok)
    return {
        "kind": "campaign",
        "name": manifest.name,
        "description": manifest.description,
        "runs": runs,
        "channels": [s.to_dict() for s in summaries],
        "n_runs": len(results),
        "n_failed": n_failed,
        "provenance": {
            "vrelab_version": __version__,
            "manifest": manifest.path.name,
            "manifest_sha256": sha256_file(manifest.path),
            **({"command": command} if command else {}),
        },
    }


def profile_document(spec: str | None) -> dict[str, Any] | None:
    """A run's profile as the campaign document keeps it: the spec and the breakpoints (so a
    campaign folder is self-contained: its profile files need not travel with it)."""
    if spec is None:
        return None
    from vrelab.profiles import parse_profile

    return {"spec": spec, **parse_profile(spec).to_dict()}


def _rel(p: Path, base: Path) -> str:
    try:
        return str(p.relative_to(base))
    except ValueError:
        return str(p)


def write_campaign(stage: Path, manifest: Manifest, results: Sequence[RunResult],
                   summaries: Sequence[ChannelSummary], doc: Mapping[str, Any]) -> None:
    """``results.json`` (the document), ``levels.csv`` of every level of every run and channel;
    the run folders were written by :func:`run_campaign`."""
    from vrelab._io import write_json, write_levels_table
    from vrelab.folder import LEVELS, RESULTS

    write_json(stage / RESULTS, dict(doc))
    groups = [({"run": rr.run.index, "label": rr.run.label, "channel": name, "static_g": rr.run.static_g[name],
                "method": res.method}, res)
              for rr in results for name, res in rr.results]
    if groups:
        write_levels_table(stage / LEVELS, groups)
