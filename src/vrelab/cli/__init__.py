"""The ``vrelab`` command line: argument parsing and printing only.

Each sub-command lives in its own module of this package and exposes
``register(subparsers) -> None``; the parser it adds sets ``func=`` to a callable taking the
parsed ``argparse.Namespace`` and returning an exit status. Modules are found by discovery, so a
new command is a new file. Any ``ValueError`` (bad input, by the library's convention) becomes one
line on stderr and exit status 2, never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import pkgutil
import sys
from typing import Sequence

from vrelab._version import __version__
from vrelab.cli._common import Parser, PrintableStream, UsageError, print_json, printable

__all__ = ["main", "build_parser", "Parser", "UsageError", "print_json"]

# Order in `vrelab --help`; modules not listed come after, alphabetically.
_ORDER = ("model", "profile", "environment", "predict", "simulate", "channels", "analyze", "campaign", "identify", "report", "demo",
          "sweep")


def _command_modules() -> list[str]:
    found = [m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_")]
    return sorted(found, key=lambda n: (_ORDER.index(n) if n in _ORDER else len(_ORDER), n))


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="vrelab",
        description="Vibration rectification error (VRE) of accelerometers: analytic models, "
        "a simulated shaker test, reduction of recorded shaker tests, reports.",
    )
    parser.add_argument("--version", action="version", version=f"vrelab {__version__}")
    parser.add_argument("--debug", action="store_true",
                        help="on an unexpected error, print the whole traceback (for a bug report)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    sub.required = True
    for name in _command_modules():
        importlib.import_module(f"{__name__}.{name}").register(sub)
    return parser


# Exit status of a full disk (or quota) while writing: EX_IOERR of sysexits.h. Not 2: the input
# was fine, and the same command succeeds once there is space.
EXIT_DISK_FULL = 74


class Terminated(KeyboardInterrupt):
    """SIGTERM (a batch scheduler, ``kill``, a container stop): unwinds like Ctrl-C, so worker
    processes are ended and staging folders removed, then exit 143 (128 + 15)."""


def _on_sigterm(signum: int, frame: object) -> None:
    raise Terminated()


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command. Exit status: 0 done, 2 bad input (one line on stderr: a ``ValueError``
    or ``OSError`` names the problem), 1 an unexpected error (one line; ``--debug`` prints the
    traceback), 74 no space left on the device (one line; nothing of the run written), 130
    interrupted (Ctrl-C), 143 terminated (SIGTERM); on both, worker processes are ended and the
    run's staging removed."""
    import signal
    import threading

    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    on_main = threading.current_thread() is threading.main_thread()
    if on_main:
        # SIGINT raises KeyboardInterrupt even when the process started with it ignored (a
        # script's `vrelab ... &`): a `kill -INT` then finished the run and exited 0 with the
        # workers busy (issue 23); now it stops the run, its workers and its staging, exit 130
        before = signal.signal(signal.SIGTERM, _on_sigterm), signal.signal(signal.SIGINT, signal.default_int_handler)
    streams = sys.stdout, sys.stderr
    # every line printed goes out escaped (a channel name with ESC or BEL is text, not a command
    # to the terminal): one wrapper for all, rather than a printable() at each print site
    sys.stdout, sys.stderr = PrintableStream(streams[0]), PrintableStream(streams[1])
    try:
        return _run(argv, debug)
    finally:
        sys.stdout, sys.stderr = streams
        if on_main:
            signal.signal(signal.SIGTERM, before[0])
            signal.signal(signal.SIGINT, before[1])


def _run(argv: list[str], debug: bool) -> int:
    from vrelab._io import DiskFull, is_disk_full

    try:
        parser = build_parser()
        args = parser.parse_args(argv)
        return int(args.func(args) or 0)
    except DiskFull as exc:
        sys.stderr.write(f"vrelab: error: {exc.strerror}\n")
        return EXIT_DISK_FULL
    except BrokenPipeError:
        # The reader went away (`vrelab ... | head`): not an error of ours. Point stdout at
        # devnull so the interpreter's final flush does not complain again.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except (ValueError, OSError) as exc:
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
