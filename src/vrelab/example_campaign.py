"""A simulated shaker campaign written in the formats labs write (physics §4.1): example data and tests.

:func:`write_campaign` simulates the runs of a small campaign on parts whose truth is known
(k2, k3, the rails, a proof-mass resonance) and writes each run the way a lab's equipment
would: the DUTs in LSB, the reference in mV, one file per run in TDMS, CSV, HDF5 or UFF58,
and the manifest that names them. Two parts (``sn1``, ``sn2``) sit on one fixture: every run's
file holds both, recorded against one reference. Each run is one :class:`TestPlan` simulated
once per part with the same seed, so the drive and the reference are the same sample for
sample and the parts differ only by their own nonlinearity.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterator, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from vrelab.campaigns import Mount
    from vrelab.sensor.loader import Sensor
    from vrelab.simulation.plan import PlanFields, TestPlan

# one block of a run's channels: "reference" [mV] and one per part [LSB]
Blocks = Iterator[dict[str, NDArray[np.float64]]]

REFERENCE_MV_PER_G = 10.0  # an IEPE reference accelerometer
DUT_LSB_PER_G = 256000.0  # ADXL355 on ±2 g
BLOCK = 1 << 16
RANDOM_BAND_HZ = (50.0, 500.0)  # the random runs' flat drive
RANDOM_PROFILE = f"flat:{RANDOM_BAND_HZ[0]:g}-{RANDOM_BAND_HZ[1]:g}"  # the same, as a manifest says it


@dataclass(frozen=True)
class Part:
    """One DUT of the fixture: its truth (the cross-coupling coefficients, IEEE 1293's model
    equation, physics §1.6, act only in the runs mounted at an angle)."""

    name: str
    k2_ug_per_g2: float
    k3_ug_per_g3: float
    kip_ug_per_g2: float = 0.0
    kpp_ug_per_g2: float = 0.0
    kio_ug_per_g2: float = 0.0
    koo_ug_per_g2: float = 0.0

    def sensor(self, sensor_file: str | Path) -> Sensor:
        """The part: the campaign's sensor file with this part's coefficients."""
        from vrelab.sensor import load_sensor
        from vrelab.sensor.parameters import with_parameters

        s = load_sensor(str(sensor_file), k2_ug_per_g2=self.k2_ug_per_g2, k3_ug_per_g3=self.k3_ug_per_g3)
        cross = {n: getattr(self, n) for n in ("kip_ug_per_g2", "kpp_ug_per_g2", "kio_ug_per_g2", "koo_ug_per_g2")}
        return with_parameters(s, cross) if any(cross.values()) else s


@dataclass(frozen=True)
class ExampleRun:
    """One run: sine at one frequency (``freq_hz``) or random (``grms`` levels), one orientation."""

    fmt: str  # tdms | csv | h5 | uff (ASCII 58) | uffb (binary 58b) | mf4 | lvm | ide
    static_g: float
    freq_hz: float | None = None
    levels_g: tuple[float, ...] = (0.5, 1.0, 1.5)
    label: str = ""
    # an IEEE 1293 mount-angle run (physics §1.6): the input axis at mount_deg to the vibration in
    # mount_plane, the whole static field [i, p, o] (static_g is then its i component)
    mount_deg: float | None = None
    mount_plane: str = "ip"
    static_vector_g: tuple[float, float, float] | None = None

    @property
    def mount(self) -> Mount | None:
        """The run's :class:`vrelab.campaigns.Mount`, or None for a run along the vibration."""
        from vrelab.campaigns import Mount

        if self.mount_deg is None or self.static_vector_g is None:
            return None
        return Mount(self.mount_deg, self.mount_plane, self.static_vector_g)


def mount_run(fmt: str, deg: float, plane: str, freq_hz: float, levels_g: tuple[float, ...], up: float = 1.0,
              label: str = "") -> ExampleRun:
    """A sine run mounted at ``deg`` in ``plane`` on a vertical shaker: gravity along the
    vibration (``up`` = +1: the vibration's direction points up, the part reads +1 g along it)."""
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    c, s = (0.0 if abs(c) < 1e-15 else c), (0.0 if abs(s) < 1e-15 else s)
    g = (up * c, up * s, 0.0) if plane == "ip" else (up * c, 0.0, up * s)
    return ExampleRun(fmt, g[0], freq_hz, levels_g, label or f"{plane.upper()} {deg:+g}°, {freq_hz:g} Hz",
                      mount_deg=deg, mount_plane=plane, static_vector_g=g)


@dataclass(frozen=True)
class CampaignTruth:
    """What the example campaign was simulated with (the tests hold the reduction to it)."""

    sensor: str  # a sensor TOML (without k2/k3: set per part)
    parts: tuple[Part, ...]
    fn_hz: float
    q: float
    rail_g: float
    runs: tuple[ExampleRun, ...] = field(default_factory=tuple)
    name: str | None = None  # the manifest's name and header (None: the shipped example's)


# The example part: a ±2 g MEMS axis with a low resonance (so a sine sweep shows it), rails at
# ±2.048 g at its output, a little noise; no ODR filter (the record is the internal rate).
EXAMPLE_SENSOR = """\
schema = 1
name = "example-part"
description = "example part for vrelab's shipped campaign: ±2 g, resonance 1.2 kHz (Q 4), rails ±2.048 g"
source = "vrelab.example_campaign (simulated)"
default_range_g = 2
default_axis = "z"
full_scale_g = 2.048
clip_position = "output"
fn_hz = 1200.0
q = 4.0
noise_ug_per_rthz = 25.0
k2_ug_per_g2 = 0.0
k3_ug_per_g3 = 0.0
"""


def example_truth() -> CampaignTruth:
    """The shipped example: two parts; sine at 80 Hz and 300 Hz at +1 g and -1 g, at 1000 Hz
    near the resonance at +1 g, one random run 50-500 Hz at +1 g, and 1500 Hz above the
    resonance at -1 g (so that the identification sees both flanks: fn and Q); in TDMS, CSV,
    UFF58 (ASCII and binary) and HDF5. Sine levels stay clear of the rails (peak + 1 g < 2.048 g at the
    output, the resonance's gain included); the random run reaches them (the rail fit)."""
    runs = (
        ExampleRun("tdms", 1.0, 80.0, (0.2, 0.4, 0.6), label="Z up, 80 Hz"),
        ExampleRun("csv", -1.0, 80.0, (0.2, 0.4, 0.6), label="Z down, 80 Hz"),
        ExampleRun("uff", 1.0, 300.0, (0.2, 0.4, 0.6), label="Z up, 300 Hz"),
        ExampleRun("uffb", -1.0, 300.0, (0.2, 0.4, 0.6), label="Z down, 300 Hz"),
        ExampleRun("uffb", 1.0, 1000.0, (0.1, 0.15, 0.2), label="Z up, 1000 Hz"),
        ExampleRun("h5", 1.0, None, (0.3, 0.5, 0.7, 0.9), label="Z up, random 50-500 Hz"),
        ExampleRun("uffb", -1.0, 1500.0, (0.1, 0.17, 0.24), label="Z down, 1500 Hz"),
    )
    parts = (Part("sn1", 2000.0, 300.0), Part("sn2", -1500.0, 200.0))
    return CampaignTruth(EXAMPLE_SENSOR, parts, 1200.0, 4.0, 2.048, runs)


def mount_truth() -> CampaignTruth:
    """A simulated IEEE 1293 mount-angle campaign (physics §1.6): one part with known k2, k3, Kip,
    Kpp, Kio, Koo; 80 Hz sine runs along the vibration at +1 g and -1 g, and at +45°, -45° and
    90° in the IP and the IO plane on a vertical shaker (gravity along the vibration). The part
    has no resonance and rails at ±8 g (no level reaches them), a little noise."""
    sensor = """\
schema = 1
name = "mount-part"
description = "part for vrelab's simulated mount-angle campaign: ±8 g rails, no resonance, a little noise"
source = "vrelab.example_campaign (simulated)"
default_range_g = 8
default_axis = "z"
clip_position = "output"
noise_ug_per_rthz = 5.0
k2_ug_per_g2 = 0.0
k3_ug_per_g3 = 0.0
"""
    lv = (0.3, 0.6, 0.9)
    runs = (ExampleRun("csv", 1.0, 80.0, lv, label="0°, up, 80 Hz"),
            ExampleRun("csv", -1.0, 80.0, lv, label="0°, down, 80 Hz"),
            *(mount_run("csv", deg, plane, 80.0, lv) for plane in ("ip", "io") for deg in (45.0, -45.0, 90.0)))
    part = Part("sn1", 2000.0, 300.0, kip_ug_per_g2=500.0, kpp_ug_per_g2=-300.0, kio_ug_per_g2=-400.0,
                koo_ug_per_g2=200.0)
    return CampaignTruth(sensor, (part,), math.inf, 1.0, 8.0, runs, name="simulated mount-angle campaign, part sn1")


class MountedSensor:
    """A sensor axis mounted at an angle on the shaker, as a :class:`TestPlan` simulates it.

    Every attribute is the sensor's, but its chain is the triaxial chain
    (:func:`vrelab.triaxial.chain.triaxial_chain`: the front end on each component, the model
    equation's cross-coupling terms) fed ``a = d·x + g`` for the record's drive x along the
    shaker: ``d`` the vibration's direction and ``g`` the static field, both in the part's
    frame (x, y, z). The plan's ``static_g`` must be ``g``'s component along the input axis
    (what the record adds to the drive, taken off again here)."""

    def __init__(self, sensor: Any, mount: Mount) -> None:
        i, p, o = sensor.triad
        self._sensor = sensor
        self._d = np.zeros(3)
        self._g = np.zeros(3)
        for k, j in enumerate((i, p, o)):
            self._d[j] = mount.direction[k]
            self._g[j] = mount.static_g[k]
        self.static_g = float(mount.static_g[0])

    def __getattr__(self, name: str) -> Any:
        return getattr(self._sensor, name)

    def chain(self, fs_hz: float) -> Any:
        from vrelab.triaxial.chain import triaxial_chain

        return _MountedChain(triaxial_chain(self._sensor, fs_hz), _Feed(self._d, self._g, self.static_g))


@dataclass(frozen=True)
class _Feed:
    """The record's scalar input (drive + g0, as SimulatedRecord feeds a chain) as the triaxial
    acceleration ``d·drive + g`` (3, n)."""

    d: NDArray[np.float64]
    g: NDArray[np.float64]
    g0: float

    def __call__(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        drive = np.asarray(x, dtype=np.float64) - self.g0  # the record adds the static along i: the drive alone
        return self.d[:, None] * drive[None, :] + self.g[:, None]


@dataclass
class _MountedChain:
    chain: Any
    feed: _Feed

    def fs_out_hz(self, fs_hz: float) -> float:
        return float(self.chain.fs_out_hz(fs_hz))

    def start(self, fs_hz: float, seed: int | np.random.SeedSequence) -> _MountedRun:
        return _MountedRun(self.chain.start(fs_hz, seed), self.feed)


@dataclass
class _MountedRun:
    run: Any
    feed: _Feed

    def process(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.asarray(self.run.process(self.feed(x)))

    @property
    def stats(self) -> Any:
        return self.run.stats


def _plan(sensor: Any, run: ExampleRun, seed: int, seconds: float, settle_s: float | None = None) -> TestPlan:
    """The run's TestPlan: sine at its frequency, or random flat over RANDOM_BAND_HZ; a run
    mounted at an angle through the part's triaxial chain (:class:`MountedSensor`).

    ``sensor``: a Sensor or a triaxial one (both stand in as the plan's sensor by its attributes
    and ``chain``; typed Any until the triaxial sensor and TestPlan share a Protocol)."""
    from vrelab.profiles import RandomProfile
    from vrelab.simulation.plan import TestPlan

    if run.mount is not None:
        sensor = MountedSensor(sensor, run.mount)

    # the rate rule's rate (vrelab.rates): at a lower rate the discretised resonance departs from
    # H(f) near fn (at 4 kHz, |H(1 kHz)|² comes out 7 % high)
    kw: PlanFields = {"static_g": run.static_g, "seconds": seconds, "baseline_s": seconds, "seed": seed,
                       "settle_s": settle_s}
    if run.freq_hz is None:
        return TestPlan.random(sensor, RandomProfile.flat(*RANDOM_BAND_HZ), run.levels_g, **kw)
    return TestPlan.sine(sensor, [run.freq_hz], run.levels_g, **kw)


def simulate_run(truth: CampaignTruth, run: ExampleRun, seed: int, seconds: float,
                 sensor_file: Path) -> tuple[float, int, Blocks]:
    """(fs, n, blocks) of one run: ``reference`` [mV] and one channel per part [LSB]."""
    records = [_plan(p.sensor(sensor_file), run, seed, seconds).record() for p in truth.parts]
    first = records[0]

    def blocks() -> Blocks:
        streams = [r.blocks(BLOCK, ["reference", "dut"]) for r in records]
        for parts in zip(*streams):
            out = {"reference": parts[0]["reference"] * REFERENCE_MV_PER_G}
            for p, b in zip(truth.parts, parts):
                out[p.name] = np.round(b["dut"] * DUT_LSB_PER_G)
            yield out

    return float(first.fs_hz), int(first.n_samples), blocks()


def write_campaign(folder: str | Path, truth: CampaignTruth | None = None, seconds: float = 2.0,
                   seed: int = 2026) -> Path:
    """Simulate the campaign and write ``folder/campaign.toml``, ``folder/runs/*`` and
    ``folder/sensor.toml`` (the part without its k2/k3). Returns the manifest's path."""
    truth = truth or example_truth()
    folder = Path(folder)
    (folder / "runs").mkdir(parents=True, exist_ok=True)
    sensor_file = folder / "sensor.toml"
    sensor_file.write_text(truth.sensor, encoding="utf-8")
    entries = []
    for i, run in enumerate(truth.runs, 1):
        fs, n, blocks = simulate_run(truth, run, seed + i, seconds, sensor_file)
        path = folder / _run_file(i, run)
        names = _WRITERS[run.fmt](path, fs, n, blocks, [p.name for p in truth.parts])
        entries.append((path.relative_to(folder), names, run))
    manifest = folder / "campaign.toml"
    manifest.write_text(_manifest_text(truth, entries), encoding="utf-8")
    return manifest


def _run_file(index: int, run: ExampleRun) -> str:
    """The run's file, relative to the manifest: ``runs/01_z_up_80hz.tdms``."""
    kind = f"{run.freq_hz:g}hz" if run.freq_hz else "random"
    orient = "up" if run.static_g > 0 else "down"
    ext = {"uffb": "uff"}.get(run.fmt, run.fmt)
    if run.mount is not None:
        return f"runs/{index:02d}_{run.mount_plane}{run.mount_deg:+g}_{kind}.{ext}"
    return f"runs/{index:02d}_z_{orient}_{kind}.{ext}"


def ensure_campaign(folder: str | Path, truth: CampaignTruth | None = None, seconds: float = 2.0,
                    seed: int = 2026) -> Path:
    """The campaign in ``folder`` as :func:`write_campaign` writes it, writing only what is missing.

    The shipped example's recordings are not committed (17 MB) but generated on first use
    (``make examples``, ``python examples/make_campaign.py``, the test suite): if any run file is
    missing, the whole campaign is simulated into a temporary folder inside ``folder`` (same
    seed, same files) and the missing files are moved in, each by one rename, so a file is there
    whole or not at all. Files present (the committed manifest and sensor file, a user's edits)
    are left as they are. Returns the manifest's path."""
    import os
    import shutil
    import tempfile

    truth = truth or example_truth()
    folder = Path(folder)
    wanted = ["campaign.toml", "sensor.toml", *(_run_file(i, run) for i, run in enumerate(truth.runs, 1))]
    if all((folder / f).is_file() for f in wanted):
        return folder / "campaign.toml"
    (folder / "runs").mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".campaign-", dir=folder))
    try:
        write_campaign(tmp, truth, seconds, seed)
        for f in wanted:
            if not (folder / f).is_file():
                os.replace(tmp / f, folder / f)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return folder / "campaign.toml"


def _manifest_text(truth: CampaignTruth, entries: Sequence[tuple[Path, Mapping[str, str], ExampleRun]]) -> str:
    head = [
        "# A simulated shaker campaign (vrelab.example_campaign; its recordings are generated by",
        "# `make examples` or `python examples/make_campaign.py`). Two parts on one fixture, z along the shaker.",
        'name = "example parts sn1, sn2: ±2 g, z axis"',
    ] if truth.name is None else [
        "# A simulated IEEE 1293 mount-angle campaign (vrelab.example_campaign): the input axis at 0°, ±45° and",
        "# 90° to the vibration in the IP and IO planes, on a vertical shaker (gravity along the vibration).",
        f'name = "{truth.name}"',
    ]
    lines = [
        *head,
        "[defaults]",
        'reference_units = "mv"',
        f"reference_sensitivity = {REFERENCE_MV_PER_G:g}   # mV/g",
        'dut_units = "lsb"',
        f"dut_sensitivity = {DUT_LSB_PER_G:g}   # LSB/g",
        "",
    ]
    for path, names, run in entries:
        parts = [p.name for p in truth.parts]
        same = all(names[p] == p for p in parts)
        duts = ("[" + ", ".join(f'"{p}"' for p in parts) + "]" if same
                else "{" + ", ".join(f'{p} = "{names[p]}"' for p in parts) + "}")
        lines += [
            "[[run]]",
            f'file = "{path.as_posix()}"',
            f'label = "{run.label}"',
            f'reference = "{names["reference"]}"',
            f"dut = {duts}",
            *([f"static_g = {run.static_g:g}"] if run.mount is None else [
                f"mount_deg = {run.mount_deg:g}", f'mount_plane = "{run.mount_plane}"',
                "static_g = [" + ", ".join(f"{x:.9g}" for x in run.mount.static_g) + "]   # i, p, o: a vertical shaker"]),
            *([f'profile = "{RANDOM_PROFILE}"   # what the controller ran'] if run.freq_hz is None else []),
            "",
        ]
    return "\n".join(lines)


# --------------------------------------------------------------------------- writers
# Each writer takes (path, fs, n, blocks, part names) and returns campaign name -> file channel
# (with "reference"); each uses its format's own library writer.


def _write_tdms(path: Path, fs: float, n: int, blocks: Blocks, parts: Sequence[str]) -> dict[str, str]:
    from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

    props = {"wf_increment": 1.0 / fs, "wf_start_offset": 0.0}
    with TdmsWriter(str(path)) as w:
        w.write_segment([RootObject({"title": "vrelab example run"}), GroupObject("shaker")])
        for b in blocks:
            objs = [ChannelObject("shaker", "ref", b["reference"], {**props, "unit_string": "mV"})]
            objs += [ChannelObject("shaker", f"{p}_z", b[p].astype(np.int32), {**props, "unit_string": "LSB"})
                     for p in parts]
            w.write_segment(objs)
    return {"reference": "shaker/ref", **{p: f"shaker/{p}_z" for p in parts}}


def _write_csv(path: Path, fs: float, n: int, blocks: Blocks, parts: Sequence[str]) -> dict[str, str]:
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["time_s", "ref_mV", *parts])
        i = 0
        for b in blocks:
            m = len(b["reference"])
            t = (i + np.arange(m)) / fs
            cols = [t, b["reference"], *[b[p] for p in parts]]
            fh.writelines(",".join(row) + "\n" for row in zip(
                *[[f"{x:.9g}" for x in cols[0]], [f"{x:.7g}" for x in cols[1]], *[[f"{int(x)}" for x in c] for c in cols[2:]]]
            ))
            i += m
    return {"reference": "ref_mV", **{p: p for p in parts}}


def _write_h5(path: Path, fs: float, n: int, blocks: Blocks, parts: Sequence[str]) -> dict[str, str]:
    import h5py

    with h5py.File(path, "w") as f:
        f.attrs["fs_hz"] = fs
        ds = {c: f.create_dataset(c, shape=(n,), dtype="f8" if c == "reference" else "i4") for c in ["reference", *parts]}
        i = 0
        for b in blocks:
            m = len(b["reference"])
            for c, d in ds.items():
                d[i : i + m] = b[c]
            i += m
    return {"reference": "reference", **{p: p for p in parts}}


def _write_uff(path: Path, fs: float, n: int, blocks: Blocks, parts: Sequence[str],
               binary: int = 0) -> dict[str, str]:
    """UFF58 ASCII time records, as a vibration controller exports them: one record per channel,
    the reference at node 1 (+Z), the parts at nodes 101, 201, ... (+Z). pyuff writes whole
    records, so the run is held in memory here (a few MB for the example)."""
    import pyuff

    data: dict[str, list[NDArray[np.float64]]] = {c: [] for c in ["reference", *parts]}
    for b in blocks:
        for c in data:
            data[c].append(np.asarray(b[c], dtype=float))
    nodes = {"reference": 1, **{p: 101 + 100 * i for i, p in enumerate(parts)}}
    units = {"reference": "mV", **{p: "LSB" for p in parts}}
    sets = []
    for c, chunks in data.items():
        y = np.concatenate(chunks)
        d = pyuff.prepare_58(
            binary=binary, id1=f"{c} {units[c]}", id2="vrelab example", func_type=1, rsp_ent_name=c,
            rsp_node=nodes[c], rsp_dir=3, ref_ent_name="NONE", ref_node=0, ref_dir=0, ord_data_type=2,
            abscissa_spacing=1, abscissa_min=0.0, abscissa_inc=1.0 / fs, abscissa_spec_data_type=17,
            ordinate_spec_data_type=12, orddenom_spec_data_type=0, z_axis_spec_data_type=0,
            data=y, x=np.arange(len(y)) / fs, return_full_dict=True,
        )  # fmt: skip
        # the fields left unset (function id, unit exponents, labels) as exporters write them
        defaults = {"id3": "NONE", "id4": "NONE", "id5": "NONE", "func_id": 1, "ver_num": 0, "load_case_id": 0,
                    "z_axis_value": 0.0, "abscissa_axis_units_lab": "s", "ordinate_axis_units_lab": units[c],
                    "orddenom_axis_units_lab": "NONE", "z_axis_axis_units_lab": "NONE"}
        sets.append({k: (defaults.get(k, 0) if v is None else v) for k, v in d.items()})
    if path.exists():
        path.unlink()
    uff = pyuff.UFF(str(path))
    uff.write_sets(sets, mode="add")
    return {"reference": f"{nodes['reference']}:+Z", **{p: f"{nodes[p]}:+Z" for p in parts}}


def _collect(blocks: Blocks, names: Sequence[str]) -> dict[str, NDArray[np.float64]]:
    chunks: dict[str, list[NDArray[np.float64]]] = {c: [] for c in names}
    for b in blocks:
        for c in names:
            chunks[c].append(np.asarray(b[c], dtype=float))
    return {c: np.concatenate(v) for c, v in chunks.items()}


def _write_mdf(path: Path, fs: float, n: int, blocks: Blocks, parts: Sequence[str]) -> dict[str, str]:
    """ASAM MDF 4.10 through asammdf (a data logger's file): the DUTs as int32 counts with a
    linear conversion to LSB (identity here: the manifest scales LSB to g), the reference in mV.
    asammdf appends whole signals: the run is held in memory here."""
    from asammdf import MDF, Signal

    data = _collect(blocks, ["reference", *parts])
    t = np.arange(n) / fs
    mdf = MDF(version="4.10")
    mdf.append([Signal(data["reference"], t, name="ref", unit="mV")]
               + [Signal(data[p].astype(np.int32), t, name=f"{p}_z", unit="LSB") for p in parts])
    mdf.save(str(path), overwrite=True)
    mdf.close()
    return {"reference": "ref", **{p: f"{p}_z" for p in parts}}


def _write_lvm(path: Path, fs: float, n: int, blocks: Blocks, parts: Sequence[str]) -> dict[str, str]:
    """LabVIEW measurement file (LVM), NI's layout: file header, segment header, X_Value column."""
    names = ["reference", *parts]
    cols = ["ref", *[f"{p}_z" for p in parts]]
    k = len(cols)
    head = ["LabVIEW Measurement\t", "Writer_Version\t2", "Reader_Version\t2", "Separator\tTab",
            "Decimal_Separator\t.", "Multi_Headings\tNo", "X_Columns\tOne", "Time_Pref\tRelative",
            "Operator\tvrelab", "Date\t2026/11/24", "Time\t10:00:00", "***End_of_Header***\t", "\t",
            "Channels\t" + str(k) + "\t" * k, "Samples" + "".join(f"\t{n}" for _ in cols) + "\t",
            "X_Dimension" + "\tTime" * k + "\t", "X0" + "\t0" * k + "\t",
            "Delta_X" + "".join(f"\t{1 / fs:.12g}" for _ in cols) + "\t", "***End_of_Header***" + "\t" * k,
            "X_Value\t" + "\t".join(cols) + "\tComment"]
    with open(path, "w", newline="\n") as fh:
        fh.write("\n".join(head) + "\n")
        i = 0
        for b in blocks:
            m = len(b["reference"])
            t = (i + np.arange(m)) / fs
            arr = np.column_stack([t] + [b[c] for c in names])
            np.savetxt(fh, arr, fmt=["%.9g"] + ["%.10g"] * k, delimiter="\t")
            i += m
    return {"reference": "ref", **{p: f"{p}_z" for p in parts}}


def _write_ide(path: Path, fs: float, n: int, blocks: Blocks, parts: Sequence[str]) -> dict[str, str]:
    """enDAQ IDE, encoded with ebmlite (the EBML library idelib reads with) against idelib's
    schema: one channel (ID 8) of float32 sub-channels in blocks stamped in 1/32768 s ticks.
    float32 holds LSB counts of a 20-bit part exactly, and the reference in mV to 7 digits."""
    import ebmlite

    names = ["reference", *parts]
    subs = [{"SubChannelID": i, "SubChannelName": ("ref" if c == "reference" else f"{c}_z"),
             "SubChannelAxisName": "Z", "SubChannelUnitsName": "mV" if c == "reference" else "LSB"}
            for i, c in enumerate(names)]
    props = {"RecordingProperties": {"ChannelList": {"Channel": [
        {"ChannelID": 8, "ChannelName": "vrelab", "ChannelFormat": "<" + "f" * len(names), "SubChannel": subs}]}}}
    schema = ebmlite.loadSchema("mide_ide.xml")
    tick = 32768.0 / fs
    with open(path, "wb") as fh:
        fh.write(schema.encodes([props], headers=True))
        i = 0
        for b in blocks:
            data = np.column_stack([b[c] for c in names]).astype("<f4")
            for a in range(0, len(data), 1024):
                z = min(a + 1024, len(data))
                fh.write(schema.encodes([{"ChannelDataBlock": {
                    "ChannelIDRef": 8, "StartTimeCodeAbs": int(round((i + a) * tick)),
                    "EndTimeCodeAbs": int(round((i + z - 1) * tick)), "ChannelDataPayload": data[a:z].tobytes()}}]))
            i += len(data)
    return {"reference": "8.0", **{p: f"8.{k}" for k, p in enumerate(parts, 1)}}


def _write_uffb(path: Path, fs: float, n: int, blocks: Blocks, parts: Sequence[str]) -> dict[str, str]:
    """UFF58b: binary records (single precision, as the ASCII ones)."""
    return _write_uff(path, fs, n, blocks, parts, binary=1)


_WRITERS = {"tdms": _write_tdms, "csv": _write_csv, "h5": _write_h5, "uff": _write_uff, "uffb": _write_uffb,
            "mf4": _write_mdf, "lvm": _write_lvm, "ide": _write_ide}


def campaign_document(sensor: Any, runs: Sequence[ExampleRun], seed: int = 0, seconds: float = 2.0,
                      settle_s: float | None = None, channel: str = "dut") -> dict[str, Any]:
    """Simulate a campaign of one part in memory and return its campaign document, the shape
    :func:`vrelab.campaigns.campaign_doc` gives a reduced manifest (``runs`` with each channel's
    levels, the random runs' profile): what :func:`vrelab.identification.identify` reads. Each run is
    one :class:`TestPlan` (seed ``seed·1000 + index``) reduced as a lab file by
    :func:`vrelab.shaker.run_test`; ``fmt`` of the runs is ignored. For planning a campaign
    (would it determine Q?) and for the identification's recovery tests."""
    from vrelab.campaigns import profile_document
    from vrelab.shaker import run_test

    doc: dict[str, Any] = {"kind": "campaign", "name": f"simulated {sensor.name}", "runs": []}
    for i, run in enumerate(runs, 1):
        res = run_test(_plan(sensor, run, seed * 1000 + i, seconds, settle_s))
        d = res.to_dict()
        mount = {} if run.mount is None else run.mount.to_dict()
        doc["runs"].append({
            "index": i, "label": run.label or f"run {i}", "status": "ok", "method": res.method,
            "profile": profile_document(RANDOM_PROFILE) if run.freq_hz is None else None,
            "budget": {}, "channels": [{"channel": channel, "static_g": run.static_g, **mount, "levels": d["levels"],
                                        "fits": d["fits"]}],
        })  # fmt: skip
    return doc


def vrc_truth(truth: CampaignTruth, part: Part, freq_hz: float, static_g: float) -> float:
    """The apparent VRC [µg/g²] of ``part`` at a sine ``freq_hz`` and ``static_g``:
    ``(k2 + 3·k3·g0)·|H(f)|²``, H the proof mass's second-order response (physics §1.3)."""
    r = freq_hz / truth.fn_hz
    h2 = 1.0 / ((1 - r * r) ** 2 + (r / truth.q) ** 2)
    return (part.k2_ug_per_g2 + 3 * part.k3_ug_per_g3 * static_g) * h2


def h2(truth: CampaignTruth, freq_hz: float) -> float:
    r = freq_hz / truth.fn_hz
    return 1.0 / ((1 - r * r) ** 2 + (r / truth.q) ** 2)


__all__ = ["Part", "ExampleRun", "CampaignTruth", "example_truth", "write_campaign", "ensure_campaign",
           "mount_truth", "mount_run", "MountedSensor",
           "campaign_document", "vrc_truth", "h2"]
