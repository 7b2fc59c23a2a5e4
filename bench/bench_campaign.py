"""Campaign reduction against the time its readers' libraries take to read the same files alone.

Issue 10's bar: a campaign of ~11 files and ~250 MB (6 UFF58, 4 sine files in TDMS/CSV/HDF5,
one random HDF5) reduces in at most 2x the time pyuff, npTDMS, pyarrow and h5py take to read
every channel of those files. Both are timed here in the same run (ratios, not absolute times).

    python bench/bench_campaign.py [--seconds S] [--workers N]

The campaign is simulated once into bench/out/campaign-<seconds>s (kept for the next run).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

OUT = Path(__file__).resolve().parent / "out"


def build(seconds: float) -> Path:
    from vrelab.example_campaign import ExampleRun, example_truth, write_campaign

    folder = OUT / f"campaign-{seconds:g}s"
    manifest = folder / "campaign.toml"
    if manifest.is_file():
        return manifest
    base = example_truth()
    sine = (0.2, 0.4, 0.6)
    runs = (
        ExampleRun("uff", 1.0, 80.0, sine, "uff up 80"), ExampleRun("uffb", -1.0, 80.0, sine, "uffb down 80"),
        ExampleRun("uff", 1.0, 160.0, sine, "uff up 160"), ExampleRun("uffb", -1.0, 160.0, sine, "uffb down 160"),
        ExampleRun("uffb", 1.0, 300.0, sine, "uffb up 300"), ExampleRun("uffb", -1.0, 300.0, sine, "uffb down 300"),
        ExampleRun("tdms", 1.0, 600.0, sine, "tdms up 600"), ExampleRun("csv", -1.0, 600.0, sine, "csv down 600"),
        ExampleRun("h5", 1.0, 900.0, (0.1, 0.15, 0.2), "h5 up 900"), ExampleRun("tdms", -1.0, 900.0, (0.1, 0.15, 0.2),
                                                                               "tdms down 900"),
        ExampleRun("h5", 1.0, None, (0.3, 0.5, 0.7, 0.9), "h5 random"),
    )  # fmt: skip
    truth = type(base)(base.sensor, base.parts, base.fn_hz, base.q, base.rail_g, runs)
    return write_campaign(folder, truth, seconds=seconds)


def read_alone(manifest: Path) -> float:
    """Every channel of every run file read whole by its own library (what a script would do)."""
    import h5py
    import numpy as np
    import pyuff
    from nptdms import TdmsFile
    from pyarrow import csv as pacsv

    t0 = time.perf_counter()
    for f in sorted((manifest.parent / "runs").iterdir()):
        if f.suffix == ".uff":
            for d in pyuff.UFF(str(f)).read_sets():
                np.asarray(d["data"], dtype=float)
        elif f.suffix == ".tdms":
            for g in TdmsFile.read(str(f)).groups():
                for ch in g.channels():
                    ch[:]
        elif f.suffix == ".csv":
            pacsv.read_csv(f)
        elif f.suffix == ".h5":
            with h5py.File(f) as h:
                for k in h:
                    h[k][()]
    return time.perf_counter() - t0


def reduce_campaign(manifest: Path, workers: int) -> tuple[float, int]:
    from vrelab.analysis.readers.uff import _indexed
    from vrelab.campaigns import combine, read_manifest, run_campaign

    _indexed.cache_clear()  # as a fresh process would: no index of a UFF file kept from the last run
    t0 = time.perf_counter()
    m = read_manifest(manifest)
    results = run_campaign(m, workers)
    combine(results, m.channels)
    return time.perf_counter() - t0, sum(1 for r in results if not r.ok)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=18.0, help="each level and baseline [s] (18: ~250 MB)")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    t0 = time.perf_counter()
    manifest = build(args.seconds)
    files = sorted((manifest.parent / "runs").iterdir())
    size = sum(f.stat().st_size for f in files) / 1e6
    print(f"campaign: {len(files)} files, {size:.0f} MB (built or found in {time.perf_counter() - t0:.1f} s)")
    reduce_campaign(manifest, 1)  # warm the page cache and the imports for both timings
    alone = min(read_alone(manifest) for _ in range(2))
    one, failed = reduce_campaign(manifest, 1)
    many, _ = reduce_campaign(manifest, args.workers)
    print(f"read by the libraries alone        {alone:7.2f} s   1.00")
    print(f"campaign reduced, 1 process        {one:7.2f} s   {one / alone:4.2f}x   (bar: 2x)")
    print(f"campaign reduced, {args.workers} workers        {many:7.2f} s   {many / alone:4.2f}x")
    if failed:
        print(f"{failed} run(s) failed")


if __name__ == "__main__":
    main()
