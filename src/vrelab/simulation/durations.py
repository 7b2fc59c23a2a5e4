"""The durations of a simulated test's segments by default [s]: one owner for the test plan
(:class:`vrelab.simulation.plan.TestPlan`), the shaker, ``vrelab simulate``, the triaxial test,
the demo and the sweep. A module of its own, importing nothing, so that the command line's
``--help`` reads it without numpy.

Each vibration level lasts ``DEFAULT_LEVEL_S``, sine and random alike: what ``vrelab simulate``
has always run and documented (``run_sine_test`` once defaulted to 2 s, so the command line's
``--freq`` and the API ran different tests). Each vibration-off baseline lasts
``DEFAULT_BASELINE_S``.
"""

from __future__ import annotations

DEFAULT_LEVEL_S = 4.0
DEFAULT_BASELINE_S = 2.0
