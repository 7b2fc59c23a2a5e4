"""Writes results_67a2c6f.json: a results document in the flat form vrelab wrote up to commit
67a2c6f (each fit's parameters beside its ``model`` key), which tests/test_fit_models.py reads
back with today's code (results files written by earlier versions must still read).

The JSON was written by this script run on commit 67a2c6f:

    mkdir /tmp/67a2c6f && git archive 67a2c6f src | tar -x -C /tmp/67a2c6f
    PYTHONPATH=/tmp/67a2c6f/src python tests/data/results_67a2c6f.py

The levels are exact model values (no noise, u set by hand): a censored rail fit (rails ±2 g at
1 g), a VRC+k4 fit and a sine VRC fit, and a k2-k3 fit from two VRCs.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from vrelab.fits import fit_k2_k3, fit_rail, fit_vrc
from vrelab.models.clipping import censored_mean_shift
from vrelab.results import Conditions, Estimate, LevelResult, VreResult

OUT = Path(__file__).with_name("results_67a2c6f.json")


def main() -> None:
    rms = [0.3, 0.4, 0.5, 0.6, 0.7, 0.8]
    clip = [LevelResult(r, Estimate(float(censored_mean_shift(1.0, r, -2.0, 2.0)), 1e-4, "g")) for r in rms]
    poly = [LevelResult(r, Estimate(200e-6 * r**2 + 30e-6 * r**4, 1e-6, "g")) for r in (0.5, 1.0, 1.5, 2.0)]
    sine = [LevelResult(r, Estimate(150e-6 * r**2 * (1 + 0.01 * (-1) ** i), 2e-6, "g"), freq_hz=100.0)
            for i, r in enumerate((0.5, 1.0, 1.5, 2.0))]
    fits = (fit_rail(clip, 1.0), fit_vrc(poly, with_k4=True), fit_vrc(sine, freq_hz=100.0),
            fit_k2_k3([(1.0, Estimate(130.0, 3.0, "ug/g^2")), (-1.0, Estimate(70.0, 5.0, "ug/g^2"))]))
    res = VreResult("random", Conditions(static_g=1.0, model="measured"), tuple(clip), fits,
                    provenance={"written_by": "tests/data/results_67a2c6f.py on commit 67a2c6f"})
    OUT.write_text(json.dumps(res.to_dict(), indent=1) + "\n")
    assert np.isfinite(fits[0].params["rail_g"].value)


if __name__ == "__main__":
    main()
