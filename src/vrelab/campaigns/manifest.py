"""A campaign's manifest (physics §4.1): its runs, read and validated whole before anything is
reduced (:func:`read_manifest`), and the checks of a run against its record."""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Mapping, Sequence, cast

from vrelab import _validate as V
from vrelab._io import sha256_file
from vrelab._load import toml_loads
from vrelab.gum import (
    TYPE_B_KEYS,
)

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
# IEEE 1293's mount planes (physics §1.6): the input axis i tilted toward the pendulous axis p, or
# toward the output axis o (the triad of vrelab.sensor.Sensor.triad).
MOUNT_PLANES = ("ip", "io")


@dataclass(frozen=True)
class Mount:
    """How one DUT channel sits in an IEEE 1293 mount-angle run (physics §1.6, §4.1).

    The part's input axis i is at ``deg`` to the vibration, tilted in the ``plane`` "ip" (toward
    its pendulous axis p) or "io" (toward its output axis o): the vibration's direction in the
    part's triad (i, p, o) is ``(cos φ, sin φ, 0)`` or ``(cos φ, 0, sin φ)``
    (:func:`vrelab.triaxial.direction`). ``static_g`` is the whole static field in that triad
    [g]: along the vibration on a vertical shaker, across it on a slip table (:func:`_mount`
    refuses anything else, and a static field given by its input-axis component only).

    Examples
    --------
    A DUT tilted 45° in its IP plane on a vertical shaker, the static field along the vibration
    (1 g split between its input and pendulous axes):

    >>> import math
    >>> from vrelab.campaigns.manifest import Mount
    >>> c = math.cos(math.radians(45.0))
    >>> mount = Mount(45.0, "ip", (c, c, 0.0))
    >>> mount.deg, mount.plane, [round(g, 4) for g in mount.static_g]
    (45.0, 'ip', [0.7071, 0.7071, 0.0])
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
    """One run of a campaign, validated: paths absolute, one static field per DUT channel.

    Examples
    --------
    >>> from vrelab.campaigns.manifest import read_manifest
    >>> run = read_manifest("examples/campaign/one-run.toml").runs[0]
    >>> run.index, run.label, dict(run.dut), run.dut_units
    (1, '01_z_up_80hz.tdms', {'sn1': 'shaker/sn1_z'}, 'lsb')
    """

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
    """A campaign manifest, validated (:func:`read_manifest`).

    Examples
    --------
    >>> from vrelab.campaigns.manifest import read_manifest
    >>> manifest = read_manifest("examples/campaign/one-run.toml")
    >>> type(manifest).__name__, manifest.runs[0].file.name
    ('Manifest', '01_z_up_80hz.tdms')
    """

    path: Path
    name: str
    runs: tuple[Run, ...]
    description: str = ""
    # campaign channel -> the sensor file (or preset) its DUT is, when the manifest's `sensor` key
    # names one: the units check then holds each run to that sensor's response (physics §4.1)
    sensors: Mapping[str, Sensor] = field(default_factory=dict, compare=False)

    @property
    def channels(self) -> tuple[str, ...]:
        """Every campaign channel, in order of first appearance."""
        return tuple(dict.fromkeys(c for r in self.runs for c in r.dut))


# --------------------------------------------------------------------------- the manifest


def read_manifest(path: str | Path, check_files: bool = True) -> Manifest:
    """Read and validate a campaign manifest (physics §4.1); paths are relative to it.

    With ``check_files`` each run's file is opened (its header only where the format allows)
    to check that the channels exist. Every problem is one ``ValueError`` line naming the run
    and the key.

    Examples
    --------
    A manifest of one run (``examples/campaign/one-run.toml``; the example campaign's whole
    manifest is ``examples/campaign/campaign.toml``):

    >>> from vrelab.campaigns.manifest import read_manifest
    >>> manifest = read_manifest("examples/campaign/one-run.toml")
    >>> manifest.name, len(manifest.runs), dict(manifest.runs[0].static_g)
    ('sn1, z up, 80 Hz', 1, {'sn1': 1.0})
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


def _toml_type(value: object) -> str:
    """What a TOML value is, in TOML's words (a table, an array, ...), for a refusal."""
    kinds = ((bool, "boolean"), (dict, "table"), (list, "array"), (int, "integer"), (float, "float"), (str, "string"))
    return next((name for t, name in kinds if isinstance(value, t)), type(value).__name__)


def _sensors(manifest: Path, value: object, channels: Sequence[str]) -> dict[str, Sensor]:
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


def _run(manifest: Path, index: int, d: object) -> Run:
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
        run_scales(run)  # units and sensitivities agree
    except ValueError as exc:
        msg = str(exc)
        raise ValueError(msg if msg.startswith(manifest.name) else f"{where}: {msg}") from None
    _check_reference(run)
    return run


def _scalar_static(where: str, value: object) -> object:
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


def _plane(where: str, key: str, value: object) -> str:
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


def _per_channel_value(where: str, key: str, value: object, dut: Mapping[str, str],
                       parse: Callable[[str, str, object], str]) -> dict[str, str]:
    """A value for all the run's DUT channels, or a table name -> value covering each."""
    if isinstance(value, dict):
        _covers_the_channels(where, key, value, dut)
        return {c: parse(where, f"{key}.{c}", value[c]) for c in dut}
    x = parse(where, key, value)
    return {c: x for c in dut}


def _path(manifest: Path, where: str, key: str, value: object) -> Path:
    if not isinstance(value, str) or not value.strip():
        raise ValueError(f"{where}: {key} must be a path (relative to the manifest)")
    p = Path(value)
    p = p if p.is_absolute() else manifest.parent / p
    if not p.is_file():
        raise ValueError(f"{where}: {key} {value!r} not found ({p})")
    return p.resolve()


def _duts(where: str, value: object) -> dict[str, str]:
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


def _per_channel(where: str, key: str, value: object, dut: Mapping[str, str], required: bool,
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


def _number(where: str, key: str, value: object, positive: bool) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"{where}: {key} must be a finite number, got {value!r}")
    if positive and value <= 0:
        raise ValueError(f"{where}: {key} must be > 0, got {value!r}")
    if not positive and key in ("settle_s", *BUDGET_KEYS) and value < 0:
        raise ValueError(f"{where}: {key} must be >= 0, got {value!r}")
    return float(value)


def _opt_str(where: str, key: str, value: object) -> str | None:
    if value is None:
        return None
    if not isinstance(value, str) or not value.strip():
        raise ValueError(f"{where}: {key} must be a non-empty string")
    return value.strip()


def _choice(where: str, key: str, value: object, options: Sequence[str]) -> str:
    if value not in options:
        raise ValueError(f"{where}: {key} must be one of {', '.join(options)}, got {value!r}")
    return str(value)


def _profile(manifest: Path, where: str, value: object) -> str | None:
    if value is None:
        return None
    if not isinstance(value, str) or not value.strip():
        raise ValueError(f"{where}: profile must be a string (a file, a name, F:P,... or flat:F1-F2)")
    p = manifest.parent / value
    text = str(p.resolve()) if p.is_file() else value
    from vrelab.profiles import parse_profile

    parse_profile(text)  # validated now, parsed again where used (a string crosses processes)
    return text


def _band(where: str, value: object) -> tuple[float, float] | None:
    if value is None:
        return None
    if (not isinstance(value, list) or len(value) != 2
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
            or not all(math.isfinite(v) for v in value) or not 0 < value[0] < value[1]):
        raise ValueError(f"{where}: band must be [F1, F2] in Hz, finite, with 0 < F1 < F2, got {value!r}")
    return float(value[0]), float(value[1])


def run_scales(run: Run) -> tuple[dict[str, Any], Any]:
    """A run's scales: per DUT channel and for the reference (None: the file's own unit).

    Examples
    --------
    >>> from vrelab.campaigns.manifest import read_manifest, run_scales
    >>> dut_scales, reference_scale = run_scales(read_manifest("examples/campaign/one-run.toml").runs[0])
    >>> dut_scales["sn1"].sensitivity, reference_scale.units
    (256000.0, 'mv')
    """
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

    Examples
    --------
    >>> from vrelab.campaigns.manifest import check_records, read_manifest
    >>> run = read_manifest("examples/campaign/one-run.toml").runs[0]
    >>> check_records([run])
    >>> check_records([run, run])
    Traceback (most recent call last):
        ...
    ValueError: run 1 ('01_z_up_80hz.tdms') and run 1 ('01_z_up_80hz.tdms') are the same file 01_z_up_80hz.tdms, both for DUT 'sn1': its VRC would be counted twice (list each recording once)
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
    campaign is refused (not the run kept as failed).

    Examples
    --------
    Raised by :func:`check_static` (a ``ValueError``: the CLI prints its one line):

    >>> from vrelab.campaigns.manifest import ManifestContradiction, check_static, read_manifest
    >>> try:
    ...     check_static(read_manifest("examples/campaign/one-run.toml").runs[0], "sn1", -1.0)
    ... except ManifestContradiction as error:
    ...     print(type(error).__name__, isinstance(error, ValueError))
    ManifestContradiction True
    """


def check_static(run: Run, channel: str, baseline_g: float | None) -> None:
    """Refuse a declared ``static_g`` the DUT's own vibration-off reading (``baseline_g`` [g],
    the mean of its baselines) contradicts (see the constants above); called after the record is
    read and before any of its numbers is kept.

    Examples
    --------
    The example campaign's 80 Hz run declares +1 g (axis up): a vibration-off reading of +1 g
    agrees with it, one of -1 g (the part mounted the other way, or the manifest wrong)
    contradicts it and is refused:

    >>> from vrelab.campaigns.manifest import check_static, read_manifest
    >>> run = read_manifest("examples/campaign/one-run.toml").runs[0]
    >>> check_static(run, "sn1", 1.0)
    >>> check_static(run, "sn1", -1.0)
    Traceback (most recent call last):
        ...
    vrelab.campaigns.manifest.ManifestContradiction: run 1 ('01_z_up_80hz.tdms'): static_g of 'sn1' is declared +1 g, but the DUT's own vibration-off reading is -1.000 g: fix static_g (or the DUT's units/sensitivity)
    """
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
