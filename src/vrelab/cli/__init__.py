"""The ``vrelab`` command line: argument parsing and printing only.

Each sub-command lives in its own module of this package and exposes
``register(subparsers) -> None``; the parser it adds sets ``func=`` to a callable taking the
parsed ``argparse.Namespace`` and returning an exit status. A new command is a new module and
its line in :data:`COMMANDS`. Any ``ValueError`` (bad input, by the library's convention)
becomes one line on stderr and exit status 2, never a traceback.

Start-up: a run imports the module of the command it runs and no other. ``vrelab --help``
lists every command from :data:`COMMANDS` (each a name and the line ``register`` gives it:
tests/test_cli_startup.py holds the two the same) and imports none of them; the modules put
their heavy imports (numpy, scipy, the readers, the report) inside the functions that run.
:func:`build_parser` with no argument registers every command in full (the CLI reference,
docs/cli.rst, and the tests read that one).
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from typing import Any, Collection, Sequence

from vrelab.cli._common import Parser, PrintableStream, UsageError, print_json, printable

__all__ = ["main", "build_parser", "COMMANDS", "Parser", "UsageError", "print_json"]

# Every command (its module vrelab.cli.NAME) with its line in `vrelab --help`, in that order.
COMMANDS: dict[str, str] = {
    "model": "analytic VRE models: clipping at the rails, polynomial nonlinearity",
    "profile": "show a random vibration profile: grms and breakpoints",
    "environment": "the named vibration environments (standards' profiles) with their sources",
    "sensor": "the parts library: presets with their datasheet facts, assumptions and VRE statements",
    "predict": "analytic VRE of a sensor in a sine or random vibration, with shares by mechanism",
    "compare": "rank parts, ranges and output rates against a VRE or tilt budget in a vibration environment",
    "simulate": "simulated shaker test of a sensor (random or sine method), reduced like a lab record",
    "channels": "list a recorded file's channels: the names --dut/--reference take, rates, units",
    "analyze": "reduce a recorded shaker test (a lab file of any format its --help lists) to VRE per level and fit it",
    "campaign": "reduce every run of a shaker campaign (a TOML manifest): VRC by frequency, k2/k3, rail per channel",
    "identify": "identify each channel's VRE model (k2, k3, fn, Q, rails, over-range) from a campaign: a sensor file",
    "report": "write DIR/report.html from a simulate/analyze or sweep output folder",
    "demo": "the article's ADXL355 case study, simulated, with its report",
    "sweep": "parameter sweep or Monte Carlo lot from a TOML file (serial, processes or Dask)",
}


class _Version(argparse.Action):
    """``--version``: the installed version (``importlib.metadata``), read only when asked."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS, **kwargs: Any) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS,
                         help="show program's version number and exit", **kwargs)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: str | Sequence[Any] | None,
                 option_string: str | None = None) -> None:
        from vrelab._version import __version__

        sys.stdout.write(f"vrelab {__version__}\n")  # stdout, as argparse's own version action
        parser.exit()


def build_parser(commands: Collection[str] | None = None) -> argparse.ArgumentParser:
    """The ``vrelab`` parser. ``commands``: those registered in full (their modules imported);
    the others are listed by name and help line only. Default: all of them."""
    parser = Parser(
        prog="vrelab",
        description="Vibration rectification error (VRE) of accelerometers: analytic models, "
        "a simulated shaker test, reduction of recorded shaker tests, reports.",
    )
    parser.add_argument("--version", action=_Version)
    parser.add_argument("--debug", action="store_true",
                        help="on an unexpected error, print the whole traceback (for a bug report)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    sub.required = True
    for name, summary in COMMANDS.items():
        if commands is None or name in commands:
            importlib.import_module(f"{__name__}.{name}").register(sub)
        else:
            sub.add_parser(name, help=summary)
    return parser


def command_named(argv: Sequence[str]) -> str | None:
    """The command ``argv`` runs, as argparse will find it: the first argument that is not an
    option (``vrelab``'s own options, ``--debug``, ``--version``, ``--help``, take no value), or
    the one after ``--``. None when there is none; a name that is no command is argparse's to
    refuse, with every command listed."""
    for i, arg in enumerate(argv):
        if arg == "--":
            return argv[i + 1] if i + 1 < len(argv) else None
        if not arg.startswith("-") or arg == "-":
            return arg
    return None


# Exit status of a full disk (or quota) while writing: EX_IOERR of sysexits.h. Not 2: the input
# was fine, and the same command succeeds once there is space.
EXIT_DISK_FULL = 74


class Terminated(KeyboardInterrupt):
    """SIGTERM (a batch scheduler, ``kill``, a container stop): unwinds like Ctrl-C, so worker
    processes are ended and staging folders removed, then exit 143 (128 + 15)."""


def _on_sigterm(signum: int, frame: object) -> None:
    raise Terminated()


# The variables the BLAS libraries numpy and SciPy load (OpenBLAS, MKL, and OpenBLAS's OpenMP
# build) read their thread count from, once, when they load.
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def _one_blas_thread() -> tuple[str, ...]:
    """Default the BLAS of this run to one thread: set :data:`BLAS_THREAD_VARIABLES` to 1 and
    return the names set (for :func:`main` to remove when it returns), or set nothing when the
    user set any of them (theirs wins) or numpy is already imported (a program calling
    :func:`main` owns its BLAS, already loaded).

    OpenBLAS starts a pool of one thread per core when it loads (numpy's and SciPy's each
    bundle one), and each BLAS call wakes the pool, whose threads spin before they sleep again:
    the 2 h record of bench/bench_analyze_hdf5.py cost 0.4 s more CPU with two threads than
    with one, with the same bits. At start-up the pools cost little with OpenBLAS 0.3.31 (about
    0.01 s of CPU per thread, read from /proc/self/task; more threads on more cores). vrelab's
    matrix products are small (a level's n x n forms, a fit's few unknowns, the sine method's
    3-row bases), none worth a second thread; the command's worker processes (campaign,
    identify, sweep) inherit the variables and want one thread each anyway
    (:func:`vrelab._pool.worker_init`)."""
    if "numpy" in sys.modules or any(os.environ.get(name) for name in BLAS_THREAD_VARIABLES):
        return ()
    for name in BLAS_THREAD_VARIABLES:
        os.environ[name] = "1"
    return BLAS_THREAD_VARIABLES


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command. Exit status: 0 done, 2 bad input (one line on stderr: a ``ValueError``
    or ``OSError`` names the problem), 1 an unexpected error (one line; ``--debug`` prints the
    traceback), 74 no space left on the device (one line; nothing of the run written), 130
    interrupted (Ctrl-C), 143 terminated (SIGTERM); on both, worker processes are ended and the
    run's staging removed.

    The BLAS runs on one thread unless ``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS`` or
    ``MKL_NUM_THREADS`` says otherwise (:func:`_one_blas_thread`); the variables are set for
    the run only, and not at all when numpy is already imported."""
    import signal
    import threading

    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    on_main = threading.current_thread() is threading.main_thread()
    if on_main:
        # SIGINT raises KeyboardInterrupt even when the process started with it ignored (a
        # script's `vrelab ... &`): a `kill -INT` then finished the run and exited 0 with the
        # workers busy; now it stops the run, its workers and its staging, exit 130
        before = signal.signal(signal.SIGTERM, _on_sigterm), signal.signal(signal.SIGINT, signal.default_int_handler)
    streams = sys.stdout, sys.stderr
    # every line printed goes out escaped (a channel name with ESC or BEL is text, not a command
    # to the terminal): one wrapper for all, rather than a printable() at each print site
    sys.stdout, sys.stderr = PrintableStream(streams[0]), PrintableStream(streams[1])
    blas = _one_blas_thread()
    try:
        return _run(argv, debug)
    finally:
        sys.stdout, sys.stderr = streams
        for name in blas:
            os.environ.pop(name, None)
        if on_main:
            signal.signal(signal.SIGTERM, before[0])
            signal.signal(signal.SIGINT, before[1])


def _run(argv: list[str], debug: bool) -> int:
    try:
        command = command_named(argv)
        parser = build_parser([command] if command in COMMANDS else ())
        args = parser.parse_args(argv)
        return int(args.func(args) or 0)
    except BrokenPipeError:
        # The reader went away (`vrelab ... | head`): not an error of ours. Point stdout at
        # devnull so the interpreter's final flush does not complain again.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except (ValueError, OSError) as exc:
        from vrelab._io import DiskFull, is_disk_full  # here: a run that succeeds needs neither

        if isinstance(exc, DiskFull):
            sys.stderr.write(f"vrelab: error: {exc.strerror}\n")
            return EXIT_DISK_FULL
        if is_disk_full(exc):
            name = f" writing {exc.filename}" if isinstance(exc, OSError) and exc.filename else ""
            sys.stderr.write(f"vrelab: error: no space left on device{name} (nothing was written; free space and "
                             "run again)\n")
            return EXIT_DISK_FULL
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        if isinstance(exc, OSError) and exc.filename and str(exc.filename) not in msg:
            msg = f"{msg}: {exc.filename}"
        msg = printable(msg)
        prefix = "" if isinstance(exc, UsageError) else "vrelab: error: "
        sys.stderr.write(f"{prefix}{msg}\n")
        return 2
    except Terminated:
        sys.stderr.write("vrelab: terminated\n")
        return 143
    except KeyboardInterrupt:
        sys.stderr.write("vrelab: interrupted\n")
        return 130
    except Exception as exc:  # a bug of ours: one line, the traceback on request
        from vrelab._io import is_disk_full

        if is_disk_full(exc):  # a C library's full disk (HDF5, netCDF) outside an output folder
            sys.stderr.write("vrelab: error: no space left on device (nothing was written; free space and run again)\n")
            return EXIT_DISK_FULL
        if debug:
            import traceback

            traceback.print_exc()
        first = printable(str(exc).splitlines()[0]) if str(exc) else ""
        sys.stderr.write(f"vrelab: internal error: {type(exc).__name__}{': ' + first if first else ''} "
                         "(run again with --debug for the traceback, and please report it)\n")
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
