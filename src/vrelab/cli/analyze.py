"""``vrelab analyze``: reduce a recorded shaker test to VRE per level and fit it (physics §4, the CLI reference).

::

    vrelab analyze FILE --dut CH [--reference CH] [--fs HZ] [--time CH]
                   [--dut-units g|mg|m/s2|mm/s2|lsb|mv|v] [--dut-sensitivity S]
                   [--reference-units ...] [--reference-sensitivity S] [--accept-file-units]
                   [--method auto|random|sine] [--schedule FILE|auto] [--profile P] [--static G]
                   [--rail G] [--band F1:F2] [--settle S] [--kind censored|truncated] [--k4] [--rail-vrc]
                   [--accept-unit-ratio] [--accept-channels] [--accept-method]
                   [--out DIR] [--json] [--progress]

Before any number is made the record is checked (physics §4.2): a DUT/reference vibration ratio
beyond 3 at every level (a units or sensitivity slip), a reference reading a static field while
the DUT reads none (swapped channels), a method the spectra contradict. Each is refused with what
was found; ``--accept-...`` passes it on purpose.

Scaling: the unit the file states for a channel is used when no ``--dut-units`` is given (a
given one that contradicts it is refused unless ``--accept-file-units``; ``vrelab channels FILE``
shows each channel's); integer samples with no unit are counts and need a sensitivity. The
file's raw values become g by dividing by the sensitivity in units per g, e.g.
``--dut-units lsb --dut-sensitivity 256000`` (ADXL355 on ±2 g) and ``--reference-units mv
--reference-sensitivity 10`` (a 10 mV/g IEPE reference).

``--json`` prints :meth:`vrelab.results.VreResult.to_dict`. ``--out DIR`` writes
``results.json``, ``levels.csv``, ``envelope.csv`` (per 0.1 s window: time, reference rms,
reference band rms, DUT mean, segment label) and, for the random method, ``psd_levels.csv``
(reference PSD per level) and with a profile ``psd.csv`` (highest level against the profile):
all of them or none.
"""

from __future__ import annotations

import argparse
import csv
import math
import shlex
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable, Iterator, Mapping, Sequence

import numpy as np

from vrelab import _io
from vrelab import _validate as V
from vrelab.analysis.options import ACCEPTABLE, BudgetOptions, FitOptions, ReductionOptions
from vrelab.cli._common import (
    Subparsers,
    add_budget_arguments,
    positive_list,
    print_json,
    print_levels,
    typeb_from_args,
    with_formats,
)
from vrelab.models.kinds import DEFAULT_CLIP_KIND, KINDS
from vrelab.record import DEFAULT_SETTLE_S
from vrelab.results import channels_to_dict

if TYPE_CHECKING:
    from vrelab.analysis.pipeline import Reduction
    from vrelab.profiles import Profile
    from vrelab.results import VreResult


def _band(text: str) -> tuple[float, float]:
    parts = text.replace("-", ":").split(":") if ":" in text or text.count("-") == 1 else [text]
    if len(parts) != 2:
        raise ValueError(f"--band must be F1:F2 in Hz, got {text!r}")
    try:
        f1, f2 = float(parts[0]), float(parts[1])
    except ValueError:
        raise ValueError(f"--band must be F1:F2 in Hz, got {text!r}") from None
    if not (0 < f1 < f2 and math.isfinite(f2)):
        raise ValueError(f"--band must satisfy 0 < F1 < F2, got {text!r}")
    return f1, f2


def register(subparsers: Subparsers) -> None:
    p = subparsers.add_parser(
        "analyze",
        help="reduce a recorded shaker test (a lab file of any format its --help lists) to VRE per level and fit it",
        description="Reduce a recorded shaker test to VRE per level (offset shift under vibration minus the "
        "bracketing vibration-off baselines, with batch-means uncertainties) and fit VRC and, for random "
        "vibration, the effective rail of the clipping model.",
    )
    with_formats(p.add_argument("file", metavar="FILE", help="recorded test, one of the formats read (by magic bytes, "
                                "else by extension): %(formats)s"))
    p.add_argument("--dut", required=True, metavar="CH[,CH...]",
                   help="DUT channel(s) (column, dataset path, group/channel, index, UFF id1 or NODE:DIR); several "
                   "(x,y,z or several parts) are each reduced against the one reference")
    p.add_argument("--reference", metavar="CH", help="reference accelerometer channel (default: levels from the DUT)")
    p.add_argument("--fs", type=float, metavar="HZ", help="sample rate when the file has none and no time column")
    p.add_argument("--time", metavar="CH", help="time column in s (default: a column named time/t/time_s)")
    for who in ("dut", "reference"):
        p.add_argument(f"--{who}-units", metavar="U",
                       help="raw units: g, mg, m/s2, mm/s2, lsb, mv, v (default: the unit the file states, else g)")
    p.add_argument("--dut-sensitivity", metavar="S[,S...]",
                   help="units per g (LSB/g, mV/g, V/g); one for all DUTs or one per DUT")
    p.add_argument("--reference-sensitivity", type=float, metavar="S", help="units per g (mV/g, V/g, LSB/g)")
    p.add_argument("--method", choices=("auto", "random", "sine"), default="auto",
                   help="auto (default): each level as its reference spectrum shows it, one line = sine, broad = "
                   "random; an explicit method the data contradict is refused")
    p.add_argument("--accept-unit-ratio", action="store_true",
                   help="accept a DUT/reference rms ratio beyond 3 at every level (physics §4.2: a units slip otherwise)")
    p.add_argument("--accept-channels", action="store_true",
                   help="accept a reference reading a static field while the DUT reads none (swapped channels otherwise)")
    p.add_argument("--accept-file-units", action="store_true",
                   help="use --dut-units/--reference-units even where they contradict the unit the file states")
    p.add_argument("--accept-method", action="store_true", help="reduce with --method even where the data show the other")
    p.add_argument("--schedule", metavar="FILE", help="schedule CSV (start_s,end_s,nominal_rms_g[,freq_hz]) or 'auto'")
    p.add_argument("--profile", metavar="P", help="random profile (file, F:P,... or flat:F1-F2): band and PSD check")
    p.add_argument("--static", type=float, metavar="G",
                   help="static field along the DUT axis for the fits (default: each DUT's baseline mean)")
    p.add_argument("--rail", type=float, metavar="G", help="DUT samples at or beyond ±G count as saturated")
    p.add_argument("--band", type=_band, metavar="F1:F2", help="test band in Hz (default: profile's, or 50:2000)")
    p.add_argument("--settle", type=float, default=DEFAULT_SETTLE_S, metavar="S",
                   help=f"settling time trimmed at each segment edge [s] (default {DEFAULT_SETTLE_S:g})")
    p.add_argument("--kind", choices=KINDS, default=DEFAULT_CLIP_KIND, help="clipping model of the rail fit")
    p.add_argument("--k4", action="store_true", help="add a rms⁴ term to the VRC fit")
    p.add_argument("--rail-vrc", action="store_true", help="fit the rail jointly with a VRC·rms² term")
    add_budget_arguments(p, limit=True)
    p.add_argument("--out", metavar="DIR", help="write results.json, levels.csv, envelope.csv, PSDs")
    p.add_argument("--json", action="store_true", help="print the result as one JSON object")
    p.add_argument("--progress", action="store_true", help="progress bar on stderr even when it is not a terminal")
    p.add_argument("--triaxial", action="store_true",
                   help="a triaxial reference: --reference X,Y,Z names its x, y, z channels and --dut one to three "
                   "DUT axes (x,y,z in order, or AXIS=CH: x=ch3,z=ch5), each reduced against its own reference axis; "
                   "levels are the reference's total rms, with each axis's and the measured cross-spectrum")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from vrelab.analysis.readers import Scale, open_record
    from vrelab.cli._common import input_paths
    from vrelab.record import Schedule

    inputs = input_paths(args.file, args.schedule, args.profile)
    if args.out:  # refused before the record is read, not after
        _io.check_output(args.out, inputs)
    if args.triaxial:
        from vrelab.cli._analyze_triaxial import run_triaxial

        return run_triaxial(args, inputs, _command_line(args))
    duts = [d.strip() for d in args.dut.split(",")]
    if any(not d for d in duts):
        raise ValueError(f"--dut {args.dut!r}: an empty channel name")
    sens: list[float | None] = ([*positive_list(args.dut_sensitivity, "--dut-sensitivity")]
                                if args.dut_sensitivity else [None])
    if len(sens) not in (1, len(duts)):
        raise ValueError(f"--dut-sensitivity: give one value or one per DUT ({len(duts)}), got {len(sens)}")
    # no unit and no sensitivity given: None, the unit the file states (else g) is used
    scales = [Scale.parse(args.dut_units, s, "--dut") if args.dut_units or s is not None else None
              for s in (sens * len(duts) if len(sens) == 1 else sens)]
    ref_scale = (Scale.parse(args.reference_units, args.reference_sensitivity, "--reference")
                 if args.reference_units or args.reference_sensitivity is not None else None)
    profile = None
    if args.profile:
        from vrelab.profiles import parse_profile

        profile = parse_profile(args.profile)
    path = Path(args.file)
    several = len(duts) > 1
    if several and not args.reference:
        raise ValueError("several DUT channels need --reference: their levels and segments come from it")
    dut_arg = duts if several else duts[0]
    dut_scale = dict(zip(duts, scales)) if several else scales[0]
    # The provenance's SHA-256 of the file (the only hash this command takes) runs in a thread
    # while the record is reduced: hashlib and file reads release the GIL, so on two cores it
    # costs CPU but no wall time; the result waits for it when it reads its provenance.
    digest = _sha256_in_thread(path)
    record = open_record(path, dut_arg, args.reference, args.fs, dut_scale, ref_scale, args.time,
                         accept_file_units=args.accept_file_units)
    # The reduction's BLAS runs on one thread as every command's does (vrelab.cli.main's default
    # unless the user sets OPENBLAS_NUM_THREADS...): its solves are small, and OpenBLAS's second
    # thread only spins (the 2 h record of bench/bench_analyze_hdf5.py: 0.4 s less CPU, the same bits)
    with record:
        schedule = None
        if args.schedule and args.schedule != "auto":
            schedule = Schedule.read_csv(args.schedule)
        elif args.schedule == "auto":
            record.schedule = None
        progress = bool(args.progress or (sys.stderr.isatty() and record.n_samples > 10_000_000))
        provenance = _Provenance({
            "input_file": path.name,
            "input_sha256": digest,
            "command": _command_line(args),
        })
        options = ReductionOptions(
            band_hz=args.band,
            settle_s=args.settle,
            rail_g=args.rail,
            profile=profile,
            accept=frozenset(name for name in ACCEPTABLE if getattr(args, "accept_" + name.replace("-", "_"))),
            progress=progress,
            psd=bool(args.out),
        )
        fit = FitOptions(
            static_g=None if args.static is None else V.acceleration("--static", args.static),
            clip_kind=args.kind,
            k4=args.k4,
            rail_with_vrc=args.rail_vrc,
        )
        budget = BudgetOptions(typeb_from_args(args), args.limit)
        if several:
            from vrelab.analysis.pipeline import analyze_channels

            reduced = analyze_channels(record, None, args.method, schedule, options=options, fit=fit, budget=budget,
                                       provenance=provenance)
        else:
            from vrelab.analysis.pipeline import analyze_full

            reduced = [(duts[0], *analyze_full(record, args.method, schedule, options=options, fit=fit, budget=budget,
                                               provenance=provenance))]
    doc = channels_to_dict([(n, r) for n, r, _ in reduced], provenance) if several else reduced[0][1].to_dict()
    if args.out:
        _write_out(Path(args.out), reduced, doc, profile, several, inputs)
    if args.json:
        print_json(doc)
    else:
        for name, result, _ in reduced:
            _print_summary(result, path, name if several else None)
        if args.out:
            print(f"wrote {args.out}/results.json, levels.csv" + (" and a folder per channel" if several
                                                                  else ", envelope.csv"))
    return 0


class _Pending:
    """A value computed in a daemon thread; :meth:`get` waits for it (and raises what it raised)."""

    def __init__(self, fn: Callable[[], Any]) -> None:
        import threading

        self._box: dict[str, Any] = {}
        self._thread = threading.Thread(target=self._work, args=(fn,), name="vrelab-sha256", daemon=True)
        self._thread.start()

    def _work(self, fn: Callable[[], Any]) -> None:
        try:
            self._box["value"] = fn()
        except BaseException as exc:  # handed to the reader, in its thread
            self._box["error"] = exc

    def get(self) -> Any:
        self._thread.join()
        if "error" in self._box:
            raise self._box["error"]
        return self._box["value"]


def _sha256_in_thread(path: Path) -> _Pending:
    # remembered under the file's identity: a second analysis of an unchanged file does not
    # hash it again (vrelab._digests: a changed file never carries an old digest)
    from vrelab._digests import file_sha256

    return _Pending(lambda: file_sha256(path))


class _Provenance(Mapping[str, Any]):
    """A provenance mapping whose :class:`_Pending` values are waited for when read (the
    reduction reads its provenance once, at its end); the keys keep their order."""

    def __init__(self, items: dict[str, Any]) -> None:
        self._items = items

    def __getitem__(self, key: str) -> Any:
        value = self._items[key]
        if isinstance(value, _Pending):
            value = self._items[key] = value.get()
        return value

    def __iter__(self) -> Iterator[str]:
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)


def _write_out(out: Path, reduced: Sequence[tuple[str, VreResult, Reduction]], doc: dict[str, Any],
               profile: Profile | None, several: bool, inputs: Iterable[str | Path] = ()) -> None:
    from vrelab import folder  # here: a run without --out writes no folder

    with _io.output_dir(out, inputs=inputs) as stage:
        if several:
            subs = folder.write_channels(stage, [(n, r) for n, r, _ in reduced], doc)
            targets = [(subs[n], red) for n, _, red in reduced]
        else:
            folder.write_result(stage, reduced[0][1])
            targets = [(stage, reduced[0][2])]
        for sub, red in targets:
            _write_envelope(sub / folder.ENVELOPE, red)
            if red.method == "random" and red.psd:
                _write_psds(sub, red, profile)


def _command_line(args: argparse.Namespace) -> str:
    """The command as typed, rebuilt from the parsed options (main() may be called with argv)."""
    parts = ["vrelab", "analyze", args.file]
    for key, value in vars(args).items():
        if key in ("file", "func", "command") or value is None or value is False:
            continue
        if key in ("dut_units", "reference_units") and value == "g":
            continue
        if (key, value) in (("settle", DEFAULT_SETTLE_S), ("method", "auto"), ("kind", DEFAULT_CLIP_KIND)) or (
                key.startswith("u_") and value == 0.0):
            continue
        opt = "--" + key.replace("_", "-")
        if value is True:
            parts.append(opt)
        elif key == "band":
            parts += [opt, f"{value[0]:g}:{value[1]:g}"]
        else:
            parts += [opt, str(value)]
    return shlex.join(parts)


def _write_envelope(path: Path, red: Reduction) -> None:
    from vrelab.analysis.segmentation import segments_to_labels

    st = red.stats
    lab = segments_to_labels(st, red.schedule)
    names = np.array(["", "off"] + [f"level {i}" for i in range(1, int(lab.max(initial=0)) + 1)], dtype=object)
    text = names[lab + 1]
    t = st.times_s
    env = st.envelope()
    band = st.band_rms()
    mean = st.dut_mean()
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t_s", "reference_rms_g", "reference_band_rms_g", "dut_mean_g", "n_samples", "segment"])
        for i in range(st.n_windows):
            w.writerow([f"{t[i]:.6g}", f"{env[i]:.9g}", f"{band[i]:.9g}", f"{mean[i]:.12g}", int(st.count[i]), text[i]])


def _write_psds(stage: Path, red: Reduction, profile: Profile | None) -> None:
    from vrelab import folder

    with open(stage / folder.PSD_LEVELS, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["level", "rms_g", "freq_hz", "psd_g2_per_hz"])
        for i, ((f, p), lv) in enumerate(zip(red.psd, red.levels), start=1):
            for fk, pk in zip(f, p):
                w.writerow([i, f"{lv.rms_g:.6g}", f"{fk:.6g}", f"{pk:.6g}"])
    if profile is None:
        return
    i = int(np.argmax([lv.rms_g for lv in red.levels]))
    f, p = red.psd[i]
    if not len(f):
        return
    prof = profile.scaled_to(red.levels[i].rms_g)
    with np.errstate(all="ignore"):
        pp = np.asarray(prof.psd(f), dtype=float)
    with open(stage / folder.PSD, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["freq_hz", "psd_measured_g2_per_hz", "psd_profile_g2_per_hz"])
        for fk, pk, qk in zip(f, p, pp):
            w.writerow([f"{fk:.6g}", f"{pk:.6g}", "" if not np.isfinite(qk) else f"{qk:.6g}"])


def _print_summary(result: VreResult, path: Path, channel: str | None = None) -> None:
    print(f"{path.name}{f' channel {channel}' if channel else ''}: {result.method} method, {len(result.levels)} level(s)")
    print_levels(result)
    if result.noise is not None:
        print(result.noise)
