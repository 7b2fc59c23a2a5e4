"""Identification's 2f cross-check (physics §6.1): the apparent VRC from the DUT's 2f line beside the
one from its DC shift."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Sequence

import numpy as np

from vrelab._format import finite_or_none
from vrelab.identification.observation import Check2f, Observation
from vrelab.results import Estimate

if TYPE_CHECKING:
    from vrelab.sensor.loader import Sensor


def _post_filter_gain(base: Sensor | None, f_hz: float) -> float:
    """|H(f)| of the linear stages after the proof mass (anti-alias, low-pass, high-pass: every
    output response but the resonance) relative to DC: what they do to the 2f line that they
    do not do to the mean shift. 1 without a base sensor or without filters; NaN where the
    chain blocks DC (a high-pass: no DC reference)."""
    if base is None:
        return 1.0
    f = np.array([0.0, float(f_hz)])
    post = np.abs(base.response(f, "output") / base.response(f, "proof-mass"))
    return float(post[1] / post[0]) if post[0] > 0 else math.nan


def cross_check_2f(obs: Sequence[Observation], base: Sensor | None = None) -> list[Check2f]:
    """Per sine run whose levels carry a 2f estimate: the apparent VRC from the DUT's 2f line
    (less the reference's own) beside the one from the DC shift, both ``(k2 + 3·k3·g0)·|H|²``
    for a cubic polynomial on the proof mass (physics §6.1): x = A·cos θ gives
    ``k·x² = k·A²/2 + k·A²/2·cos 2θ``, the same coefficient at DC and at 2f. Immune to drift,
    so a disagreement beyond the uncertainties points at a drifting baseline or at filters
    after the nonlinearity that attenuate 2f (the DC is untouched by them). The base sensor's
    own output filters are known: the 2f VRC is divided by their gain at 2f relative to DC
    (:func:`_post_filter_gain`; 0.30 at 600 Hz on an ADXL355 at 4 kHz ODR), and the gain is
    reported beside it.

    Examples
    --------
    Runs without a 2f line in their levels give no check (an empty list):

    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> from vrelab.identification.check2f import cross_check_2f
    >>> cross_check_2f(obs)
    []
    """
    from vrelab.fits import fit_vrc
    from vrelab.results import LevelResult

    out: list[Check2f] = []
    for ob in obs:
        if ob.method != "sine" or ob.freq_hz is None or not ob.harmonic_g or not any(h is not None for h in ob.harmonic_g):
            continue
        pairs = [(r, h) for r, h in zip(ob.rms_g, ob.harmonic_g) if h is not None]
        two_f = fit_vrc([LevelResult(float(r), Estimate(h[0], h[1])) for r, h in pairs])
        dc = fit_vrc([LevelResult(float(r), Estimate(float(v), float(u))) for r, v, u in zip(ob.rms_g, ob.vre_g, ob.u_g)])
        a, b = two_f.params["vrc_ug_per_g2"], dc.params["vrc_ug_per_g2"]
        gain = _post_filter_gain(base, 2 * float(ob.freq_hz))
        if not gain > 0:
            continue  # a chain that blocks DC or 2f: nothing to compare
        a = Estimate(a.value / gain, a.u / gain)
        z = (a.value - b.value) / math.hypot(a.u, b.u) if math.hypot(a.u, b.u) > 0 else math.nan
        out.append({"run": ob.run, "label": ob.label, "freq_hz": ob.freq_hz, "static_g": ob.static_g,
                    "vrc_2f_ug_per_g2": {"value": a.value, "u": a.u}, "vrc_dc_ug_per_g2": {"value": b.value, "u": b.u},
                    "filter_gain_2f": gain,
                    "difference_sigma": finite_or_none(z), "agree": bool(abs(z) <= 3) if math.isfinite(z) else None})
    return out
