"""What the sub-commands share: the parser class, JSON output, the sensor options, list options
and the levels table. Sub-commands import this module and never each other (``_``-prefixed
modules are not discovered as commands)."""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, TextIO, TypeAlias

from vrelab._lists import parse_list

if TYPE_CHECKING:  # the commands import these when they run, not when the parser is built (numpy)
    from vrelab.gum import TypeB
    from vrelab.profiles import Profile
    from vrelab.results import VreResult
    from vrelab.sensor import Sensor


class UsageError(ValueError):
    """A command-line usage problem (unknown option, missing argument)."""


class _Formats:
    """The reader registry's formats as help text, made only when a help is printed (argparse
    expands ``%(formats)s`` from the action's attributes with ``str``): building the parser, which
    every command does, stays free of the readers' imports and the plugins' entry points."""

    def __str__(self) -> str:
        from vrelab.analysis.readers import formats_text

        return formats_text()


FORMATS_TOKEN = "%(formats)s"


def with_formats(action: argparse.Action) -> argparse.Action:
    """Let ``action``'s help say ``%(formats)s``: every registered format with its extensions."""
    action.formats = _Formats()  # type: ignore[attr-defined]
    return action


def expand_formats(text: str | None, width: int = 88) -> str | None:
    """``text`` with ``%(formats)s`` replaced by the registered formats; where the token stands
    alone on a line (a raw description or epilog), wrapped to ``width`` at that line's indent."""
    if not text or FORMATS_TOKEN not in text:
        return text
    import textwrap

    fmts = str(_Formats())
    lines = []
    for line in text.split("\n"):
        if line.strip() == FORMATS_TOKEN:
            pad = line[: len(line) - len(line.lstrip())]
            lines.append(textwrap.fill(fmts, width, initial_indent=pad, subsequent_indent=pad))
        else:
            lines.append(line.replace(FORMATS_TOKEN, fmts))
    return "\n".join(lines)


class Parser(argparse.ArgumentParser):
    """argparse prints usage plus a message and exits 2; we want one line and the same status.
    A description or epilog may say ``%(formats)s`` (:func:`expand_formats`)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise UsageError(f"{self.prog}: error: {message}")

    def format_help(self) -> str:
        saved = self.description, self.epilog
        self.description, self.epilog = expand_formats(self.description), expand_formats(self.epilog)
        try:
            return super().format_help()
        finally:
            self.description, self.epilog = saved


# What build_parser hands each command's register(); argparse's class is generic only in its stub.
Subparsers: TypeAlias = "argparse._SubParsersAction[Parser]"


def print_json(obj: object) -> None:
    """Print exactly one JSON object on stdout (NaN/inf are not JSON: they must be None already)."""
    sys.stdout.write(json.dumps(obj, allow_nan=False) + "\n")


def add_sensor_arguments(p: argparse.ArgumentParser) -> None:
    """The sensor options common to ``predict`` and ``simulate`` (the CLI reference)."""
    p.add_argument("--sensor", required=True, metavar="S", help="preset (adxl355, adxl354, adxl357, ideal) or a sensor file")
    p.add_argument("--range", dest="range_g", type=float, metavar="G",
                   help="measurement range [g], e.g. 2, 4, 8 (default: the sensor's default_range_g: 2, or 10 for the ADXL357)")
    p.add_argument("--axis", metavar="A",
                   help="sensing axis x, y or z (or a channel of an identified sensor file), sets fn and Q "
                   "(default: the sensor's default_axis; x for the ADXL presets)")
    p.add_argument("--odr", dest="odr_hz", type=float, metavar="HZ",
                   help="output data rate [Hz], sets the digital low-pass (default: the sensor's default_odr_hz; "
                   "4000 for the ADXL355 and ADXL357)")
    p.add_argument("--static", dest="static_g", type=float, default=1.0, metavar="G",
                   help="static acceleration along the axis [g] (default 1: axis up in a 1 g field)")
    p.add_argument("--k2", dest="k2_ug_per_g2", type=float, metavar="UG_PER_G2", help="second-order nonlinearity [µg/g²]")
    p.add_argument("--k3", dest="k3_ug_per_g3", type=float, metavar="UG_PER_G3", help="third-order nonlinearity [µg/g³]")
    add_mount_arguments(p)


def add_mount_arguments(p: argparse.ArgumentParser) -> None:
    """``--mount-fn``/``--mount-q``: the PCB or bracket the part sits on (:class:`vrelab.sensor.configs.Mount`)."""
    p.add_argument("--mount-fn", dest="mount_fn_hz", type=float, metavar="HZ",
                   help="resonance of the PCB or bracket the part sits on [Hz] (with --mount-q): its transmissibility "
                   "acts on the vibration (default: the sensor file's, else a rigid mount)")
    p.add_argument("--mount-q", dest="mount_q", type=float, metavar="Q",
                   help="quality factor of that mount resonance (with --mount-fn; PCBs: about 10 to 50)")


def mount_overrides(args: argparse.Namespace) -> dict[str, float]:
    """The mount options as a sensor's user-set values (file keys); both or neither."""
    fn, q = getattr(args, "mount_fn_hz", None), getattr(args, "mount_q", None)
    if (fn is None) != (q is None):
        raise ValueError("--mount-fn and --mount-q go together: give both or neither")
    return {} if fn is None or q is None else {"mount_fn_hz": float(fn), "mount_q": float(q)}


def input_paths(*values: object) -> list[Path]:
    """The files and folders a run reads, among option values (a record, a manifest, a sensor
    or profile given as a path; ``adxl355`` or ``flat:20-2000`` name none): its output folder
    must not hold them (:func:`vrelab._io.check_output`). A manifest contributes its runs' files."""
    from vrelab._io import existing_paths

    found: list[object] = []
    for v in values:
        if hasattr(v, "runs") and hasattr(v, "path"):  # a campaign.Manifest
            found += [v.path] + [x for r in v.runs for x in (r.file, r.schedule, r.profile)]
        elif isinstance(v, str) and "+" in v:  # a profile with tones ("P+sine:..."): its profile part
            from vrelab.profiles import split_tones  # (the profiles package: only where one may be)

            found += [v, split_tones(v)[0].strip()]
        elif isinstance(v, str):
            found += [v, v.strip()]
        else:
            found.append(v)
    return existing_paths(found)


def sensor_from_args(args: argparse.Namespace) -> Sensor:
    from vrelab import _validate as V
    from vrelab.sensor import load_sensor

    V.acceleration("--static", args.static_g)
    return load_sensor(
        args.sensor,
        range_g=args.range_g,
        axis=args.axis,
        odr_hz=args.odr_hz,
        k2_ug_per_g2=args.k2_ug_per_g2,
        k3_ug_per_g3=args.k3_ug_per_g3,
        overrides=mount_overrides(args),
    )


def positive_list(text: str, name: str) -> list[float]:
    """A LIST option whose values must all be > 0 (levels, frequencies)."""
    values = parse_list(text, name)
    for x in values:
        if not x > 0:
            raise ValueError(f"{name}: values must be > 0, got {x:g}")
    return values


def profile_table(profile: Profile) -> str:
    """A profile as text: name, source, grms, its breakpoint table with slopes and, for
    sine-on-random, its tones (``vrelab profile`` and ``vrelab environment show``)."""
    lo, hi = profile.band
    tones = getattr(profile, "tones", ())
    head = (f"random {lo:g}–{hi:g} Hz" if not tones else f"sine-on-random {lo:g}–{hi:g} Hz") + f", {profile.grms:.3g} g rms"
    lines = [f"{profile.name}: {head}" if profile.name else head]
    if profile.source:
        lines.append(f"source: {profile.source}")
    lines.append(f"grms: {profile.grms:.6g} g" + (" (random and tones)" if tones else ""))
    from vrelab.profiles import SineOnRandom  # loaded already: the profile is one of its classes

    random = profile.random if isinstance(profile, SineOnRandom) else profile
    if tones:
        lines.append(f"random part: {random.grms:.6g} g rms")
    lines.append(f"{'f_hz':>10}  {'psd_g2_per_hz':>14}  {'slope to next':>14}")
    slopes = list(random.slopes_db_per_oct) + [None]
    for (f, p), s in zip(random.breakpoints, slopes):
        slope = f"{s:+.2f} dB/oct" if s is not None else ""
        lines.append(f"{f:>10.6g}  {p:>14.6g}  {slope:>14}")
    if tones:
        lines.append(f"{'tone_hz':>10}  {'peak_g':>14}  {'rms_g':>14}")
        for t in tones:
            lines.append(f"{t.freq_hz:>10.6g}  {t.peak_g:>14.6g}  {t.rms_g:>14.6g}")
    return "\n".join(lines)


def print_levels(result: VreResult) -> None:
    """The levels of a ``VreResult`` as a table, then its fits and warnings (simulate, analyze)."""
    from vrelab._format import format_mg, format_u, format_value, format_value_u

    sine = result.method == "sine"
    budget = any(lv.budget for lv in result.levels)
    decided = any(lv.decision for lv in result.levels)
    # a sine level's drive distortion (physics §4.4): the reference's THD, when the record had a reference
    thd = sine and any(lv.drive is not None for lv in result.levels)
    print(("freq_hz  " if sine else "") + f"{'rms_g':>8}  {'VRE ± u (mg)':>22}  {'VRC ± u (ug/g^2)':>22}"
          + ("   U (mg)     k" if budget else "")
          + ("  decision     " if decided else "") + ("  THD (%)" if thd else "") + "  saturated")
    for lv in result.levels:
        f = f"{lv.freq_hz:7.4g}  " if sine and lv.freq_hz is not None else ("        " if sine else "")
        sat = f"{lv.n_saturated}" + (f" ({', '.join(lv.flags)})" if lv.flags else "")
        more = ""
        if budget:
            more += f"  {format_u(lv.U_vre_g, scale=1e3):>8}  {format_value(lv.k, resolution=0.01):>4}" if lv.U_vre_g is not None and lv.k is not None else " " * 16
        if decided:
            more += f"  {lv.decision or 'undefined':<13}"
        if thd:
            more += f"  {format_value(100 * lv.drive.thd.value, digits=2) if lv.drive is not None else '':>7}"
        vrc = lv.vrc  # VRE / rms² with its u (physics §1.2), beside the VRE
        print(f"{f}{lv.rms_g:8.4g}  {format_mg(lv.vre.value, lv.vre.u):>22}  {format_value_u(vrc.value, vrc.u):>22}"
              f"{more}  {sat}")
    for fit in result.fits:
        at = f" at {fit.freq_hz:.4g} Hz" if fit.freq_hz is not None else ""
        if fit.no_fit_reason is not None:
            print(f"fit {fit.model.name}{at}: no fit: {fit.no_fit_reason}")
            continue
        print(f"fit {fit.model}{at}: " + ", ".join(f"{k} = {v}" for k, v in fit.params.items()))
        if fit.departure_rms_g is not None:
            print(f"  data leave the model from {fit.departure_rms_g:.4g} g rms on")
        for note in fit.notes:
            if note.startswith("a distorted drive"):  # fits.fit_vrc's note on the drive's E[x³] (physics §4.4)
                print(f"  {note}")
    for w in result.warnings:
        print(f"warning: {w}")


def add_budget_arguments(p: argparse.ArgumentParser, limit: bool = False) -> None:
    """The Type B inputs of physics §4.3 (and, with ``limit``, the decision's limit)."""
    g = p.add_argument_group("uncertainty budget (physics §4.3)" + (" and decision" if limit else ""))
    g.add_argument("--u-reference-pct", type=float, default=0.0, metavar="P",
                   help="standard uncertainty of the reference sensitivity [%%] (its calibration)")
    g.add_argument("--u-dut-pct", type=float, default=0.0, metavar="P", help="standard uncertainty of the DUT sensitivity [%%]")
    g.add_argument("--u-static-g", type=float, default=0.0, metavar="G",
                   help="standard uncertainty of the static field [g] (fixture alignment)")
    g.add_argument("--u-thermal-g", type=float, default=0.0, metavar="G",
                   help="standard uncertainty of an offset change during vibration [g] (temperature)")
    if limit:
        g.add_argument("--limit", type=float, metavar="G",
                       help="VRE limit [g] (a datasheet spec): each level pass/fail/indeterminate under guarded "
                       "acceptance (pass when |VRE| + U <= limit, fail when |VRE| - U > limit)")


def typeb_from_args(args: argparse.Namespace) -> TypeB:
    """The :class:`vrelab.gum.TypeB` the budget options declare (it refuses a negative value)."""
    from vrelab.gum import TypeB

    return TypeB(args.u_reference_pct, args.u_dut_pct, args.u_static_g, args.u_thermal_g)


def printable(text: str) -> str:
    """``text`` with control characters written as escapes (``\\x1b``): a channel name or a
    path from a file reaches the terminal as text, never as an escape sequence that moves the
    cursor, retitles the window or hides the rest of the line. Newlines and tabs stay."""
    return _CONTROL.sub(lambda m: m.group().encode("unicode_escape").decode("ascii"), text)


class PrintableStream:
    """A text stream that writes through :func:`printable`: :func:`vrelab.cli.main` puts one over
    stdout and stderr for the command's run, so every line a command prints (a table of a file's
    channel names, a reader's note, a warning a library logs) reaches the terminal escaped, without
    each print site having to remember it."""

    def __init__(self, stream: TextIO) -> None:
        self._stream = stream

    @property
    def raw(self) -> TextIO:
        """The stream underneath (a progress bar's, :func:`vrelab._format.progress_stream`)."""
        return self._stream

    def write(self, text: str) -> int:
        self._stream.write(printable(text))
        return len(text)

    def writelines(self, lines: Iterable[str]) -> None:
        for line in lines:
            self.write(line)

    def __getattr__(self, name: str) -> Any:  # flush, fileno, isatty, encoding...: the stream's own
        return getattr(self._stream, name)


_CONTROL = re.compile(r"[\x00-\x08\x0b-\x1f\x7f-\x9f]")
