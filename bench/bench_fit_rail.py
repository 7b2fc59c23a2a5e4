"""Benchmark: the rail fit's departure scan, fast (``vrelab._rail_scan``) against a full fit per candidate.

Run: ``.venv/bin/python bench/run_all.py fit_rail`` or ``.venv/bin/python bench/bench_fit_rail.py``.

``vrelab.fits.fit_rail`` on the levels ``vrelab analyze`` gives it for the issue 29 record (the
2 h, 120 random levels of ``bench/bench_analyze_hdf5.py``, written there on first use), and on
a seeded level set of 40 levels that leaves the clipping model (a departure), timed in CPU in
this process (best of rounds, after a warm-up) as ``fit_rail`` runs it and with no candidate
cleared (every candidate's full fit: the scan before issue 29). Prints both, their ratio, how
many candidates needed their full fit, and whether both gave the same result (they must).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent


def record_levels(hours: float = 2.0) -> tuple[list[Any], float]:
    """The levels and static field ``vrelab analyze --method random`` fits the rail to."""
    sys.path.insert(0, str(HERE))
    import bench_analyze_hdf5 as B

    import vrelab.fits as fits
    from vrelab.cli import main as cli

    path = B.make_record(hours, 4000.0)
    seen: list[tuple[list[Any], float]] = []
    fit_rail = fits.fit_rail

    def spy(levels: Any, static_g: float, *args: Any, **kw: Any) -> Any:
        seen.append((list(levels), static_g))
        return fit_rail(levels, static_g, *args, **kw)

    fits.fit_rail = spy  # type: ignore[assignment]
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            cli(["analyze", str(path), "--dut", "dut", "--reference", "reference", "--method", "random", "--json"])
    finally:
        fits.fit_rail = fit_rail  # type: ignore[assignment]
    return seen[0]


def departing_levels(n: int = 40, seed: int = 29) -> tuple[list[Any], float]:
    """±2.2 g rails on a 1 g field, 0.3-2 g rms, u 0.3 % + 20 µg; from 1.5 g rms on the levels read
    60 % of the clipping shift (over-range protection): a departure there."""
    from vrelab import Estimate, LevelResult
    from vrelab.models.clipping import censored_mean_shift

    rms = np.linspace(0.3, 2.0, n)
    y = np.asarray(censored_mean_shift(1.0, rms, -2.2, 2.2))
    u = 0.003 * np.abs(y) + 2e-5
    y = np.where(rms >= 1.5, 0.6 * y, y) + np.random.default_rng(seed).standard_normal(n) * u
    return [LevelResult(rms_g=float(r), vre=Estimate(float(v), float(e))) for r, v, e in zip(rms, y, u)], 1.0


def _time(levels: list[Any], g0: float, full: bool, repeat: int) -> tuple[float, dict[str, Any]]:
    from _paired import best_time

    from vrelab import _rail_scan as rail_scan
    from vrelab.fits import fit_rail

    fast = rail_scan.cleared_candidates
    if full:
        rail_scan.cleared_candidates = lambda rms, *a: np.zeros(len(rms), dtype=bool)  # type: ignore[assignment]
    try:
        t = best_time(lambda: fit_rail(levels, g0), 1, repeat, clock=time.process_time)
        return t, fit_rail(levels, g0).to_dict()
    finally:
        rail_scan.cleared_candidates = fast  # type: ignore[assignment]


def main(repeat: int = 3) -> dict[str, Any]:
    """Print and return, per level set, the CPU seconds of both scans and their ratio."""
    sys.path.insert(0, str(HERE))
    from vrelab import _rail_scan as rail_scan
    from vrelab.fits import DEPARTURE_SIGMA, DEPARTURE_SIGMA_LONE

    out: dict[str, Any] = {}
    for name, (levels, g0) in (("2 h record, 120 levels", record_levels()), ("40 levels, a departure", departing_levels())):
        t_fast, r_fast = _time(levels, g0, False, repeat)
        t_full, r_full = _time(levels, g0, True, repeat)
        srt = sorted(levels, key=lambda lv: lv.rms_g)
        rms, y, u = (np.array([f(lv) for lv in srt]) for f in (lambda lv: lv.rms_g, lambda lv: lv.vre.value,
                                                                 lambda lv: lv.vre.u))
        cleared = rail_scan.cleared_candidates(rms, y, u, g0, 2, DEPARTURE_SIGMA, DEPARTURE_SIGMA_LONE)
        d = r_full["departure_rms_g"]
        end = len(levels) if d is None else r_full["n_points"] + 1  # the candidates the scan reaches
        fitted = int(np.count_nonzero(~cleared[2:end])) + (d is None)  # (+ the fit of all levels)
        print(f"{name:24s} fast {1e3 * t_fast:7.1f} ms CPU   full fits {1e3 * t_full:7.1f} ms CPU   "
              f"ratio {t_fast / t_full:.3f}   full fits {fitted} of {end - 2 + (d is None)}   "
              f"departure {d}   same result: {r_fast == r_full}")
        out[name] = {"fast_s": t_fast, "full_s": t_full, "ratio": t_fast / t_full, "fitted": fitted,
                     "same": r_fast == r_full}
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    main(ap.parse_args().repeat)
