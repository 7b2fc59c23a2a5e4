"""Identification of a 10-run campaign against the reduction of the same campaign.

Issue 11's bar: identifying a 10-run campaign (after reduction) takes at most 10 s on 2 cores.
Both times are measured here in one run, the identification's beside the reduction's (ratios,
not absolute times, compare across machines).

    python bench/bench_identify.py [--seconds S] [--workers N]

The campaign (two parts, eight sine runs through the 1.2 kHz resonance at +1 g and -1 g, two
random runs into the rails) is simulated once into bench/out/identify-<seconds>s.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

OUT = Path(__file__).resolve().parent / "out"


def build(seconds: float) -> Path:
    from vrelab.example_campaign import ExampleRun, example_truth, write_campaign

    folder = OUT / f"identify-{seconds:g}s"
    manifest = folder / "campaign.toml"
    if manifest.is_file():
        return manifest
    base = example_truth()
    sine = (0.2, 0.4, 0.6)
    mid = (0.15, 0.3, 0.45)  # peaks clear of the rails through |H(600 Hz)| = 1.3
    near = (0.08, 0.12, 0.16)
    runs = (
        ExampleRun("h5", 1.0, 80.0, sine, "up 80"), ExampleRun("h5", -1.0, 80.0, sine, "down 80"),
        ExampleRun("h5", 1.0, 600.0, mid, "up 600"), ExampleRun("h5", -1.0, 600.0, mid, "down 600"),
        ExampleRun("h5", 1.0, 1000.0, near, "up 1000"), ExampleRun("h5", -1.0, 1000.0, near, "down 1000"),
        ExampleRun("h5", 1.0, 1500.0, (0.1, 0.17, 0.24), "up 1500"),
        ExampleRun("h5", -1.0, 1500.0, (0.1, 0.17, 0.24), "down 1500"),
        ExampleRun("h5", 1.0, None, (0.3, 0.5, 0.7, 0.9), "random up"),
        ExampleRun("h5", -1.0, None, (0.3, 0.5, 0.7, 0.9), "random down"),
    )  # fmt: skip
    truth = type(base)(base.sensor, base.parts, base.fn_hz, base.q, base.rail_g, runs)
    return write_campaign(folder, truth, seconds=seconds)


def main() -> None:
    from vrelab.campaigns import campaign_doc, combine, read_manifest, run_campaign
    from vrelab.identification import IdentifyOptions, identify

    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=2.0, help="each level and baseline [s]")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    manifest = build(args.seconds)
    m = read_manifest(manifest)
    t0 = time.perf_counter()
    results = run_campaign(m, args.workers)
    doc = campaign_doc(m, results, combine(results, m.channels))
    reduce_s = time.perf_counter() - t0
    times = {}
    for w in (1, args.workers):
        t0 = time.perf_counter()
        ident = identify(doc, "ideal", options=IdentifyOptions(workers=w))
        times[w] = time.perf_counter() - t0
    n_levels = sum(len(c["levels"]) for r in doc["runs"] for c in r["channels"])
    print(f"campaign: {len(m.runs)} runs, {len(m.channels)} channels, {n_levels} channel-levels")
    print(f"reduction, {args.workers} workers          {reduce_s:7.2f} s   1.00")
    for w, t in times.items():
        bar = "   (bar: 10 s)" if w == args.workers else ""
        print(f"identification, {w} worker(s)     {t:7.2f} s   {t / reduce_s:4.2f}x{bar}")
    for c in ident.channels:
        got = ", ".join(f"{n} {e.value:.4g}±{e.u:.2g}" for n, e in c.parameters.items() if e is not None)
        print(f"  {c.channel}: {got}")


if __name__ == "__main__":
    main()
