"""Run every benchmark: each ``bench/bench_*.py`` module's ``main()``, in name order.

Usage: ``python bench/run_all.py [NAME_SUBSTRING ...]`` (``make bench`` runs them all). A
benchmark that fails is reported and the others still run; the exit status is 1 if any failed.
"""

from __future__ import annotations

import importlib.util
import sys
import time
import traceback
from pathlib import Path

HERE = Path(__file__).resolve().parent


def _load(path: Path):
    spec = importlib.util.spec_from_file_location(path.stem, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def main(argv: list[str] | None = None) -> int:
    wanted = sys.argv[1:] if argv is None else argv
    failed = []
    for path in sorted(HERE.glob("bench_*.py")):
        if wanted and not any(w in path.stem for w in wanted):
            continue
        print(f"=== {path.stem}", flush=True)
        t0 = time.perf_counter()
        argv0 = sys.argv
        sys.argv = [str(path)]  # a benchmark parses its own options: give it none of ours
        try:
            _load(path).main()
        except Exception:  # report and go on: one broken benchmark must not hide the others
            traceback.print_exc()
            failed.append(path.stem)
        finally:
            sys.argv = argv0
        print(f"=== {path.stem}: {time.perf_counter() - t0:.1f} s", flush=True)
    if failed:
        print(f"failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
