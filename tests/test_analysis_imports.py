"""What the random-method analysis imports (issue 29): not ``scipy.stats``.

``import scipy.stats`` costs about a second of CPU (it builds every distribution's docstring),
more than the rest of the reduction's own work on a 2 h record besides the first pass; the
quantiles the analysis needs (χ² for a level's scatter check, Student's t and the normal for
the coverage factor) are scipy.special's functions, which scipy.stats itself calls. Checked by
the modules a fresh interpreter holds after the analysis, not by a time
(``bench/bench_analyze_hdf5.py`` times it).
"""

from __future__ import annotations

import subprocess
import sys

# A random-method analysis of a short in-memory record: four levels between vibration-off
# stretches, the DUT clipped at ±1.5 g (the rail fit runs), every level's budget (coverage factor)
_RUN = """
import sys
import numpy as np
from vrelab.analysis.pipeline import analyze_full
from vrelab.record import ArrayRecord, Schedule, Segment

fs, rng = 1000.0, np.random.default_rng(7)
segs, t = [], 0.0
for level in (0.3, 0.6, 1.0, 1.5):
    segs += [Segment(t, t + 6.0, 0.0), Segment(t + 6.0, t + 18.0, level)]
    t += 18.0
segs.append(Segment(t, t + 6.0, 0.0))
n = int((t + 6.0) * fs)
time = np.arange(n) / fs
rms = np.zeros(n)
for s in segs:
    rms[(time >= s.start_s) & (time < s.end_s)] = s.nominal_rms_g
ref = rng.standard_normal(n) * rms
dut = np.clip(1.0 + ref + 1e-4 * rng.standard_normal(n), -1.5, 1.5)
result, _ = analyze_full(ArrayRecord({"reference": ref, "dut": dut}, fs), "random", Schedule(tuple(segs)))
assert len(result.levels) == 4 and result.fits, result
print("scipy.stats" in sys.modules)
"""


def test_random_analysis_does_not_import_scipy_stats():
    done = subprocess.run([sys.executable, "-c", _RUN], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip() == "False", "the random-method analysis imported scipy.stats"
