"""Identification (SPEC 6.1) recovers drawn parts honestly: over 24 parts drawn (k2, k3, fn, Q,
rails), each campaign simulated in the time domain and identified, the pulls
(estimate - truth)/u neither optimistic, inflated nor biased, and a null fn or Q carries a bound
that holds the truth.

Split from tests/test_identify.py (whose parts, designs and drawing it uses) so that pytest-xdist's
loadfile gives this, the file's heaviest test (24 simulated campaigns identified), its own worker
slot instead of lengthening that file's run, the suite's critical path.
"""

from __future__ import annotations

import statistics
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from test_identify import _design, _draw, _part
from vrelab.example_campaign import campaign_document
from vrelab.identification import identify
from vrelab.sensor import load_sensor

NAMES = {"k2": "k2_ug_per_g2", "k3": "k3_ug_per_g3", "fn": "fn_hz", "q": "q"}


def _recover(seed: int) -> dict[str, float | None]:
    """Pulls (estimate - truth)/u of one drawn part's identification."""
    t = _draw(seed)
    with tempfile.TemporaryDirectory() as d:
        sensor = load_sensor(str(_part(t, Path(d))))
        doc = campaign_document(sensor, _design(t), seed=seed, seconds=2.0, settle_s=0.2)
    ch = identify(doc, "ideal").channels[0]
    truth = {NAMES[k]: t[k] for k in NAMES} | {"rail_low_g": -t["rail"], "rail_high_g": t["rail"]}
    for n in ("fn_hz", "q"):  # a resonance parameter left null carries a bound, and the bound holds the truth
        if ch.parameters[n] is None:
            assert _bound_holds(ch.reasons[n], truth[n]), (seed, n, truth[n], ch.reasons[n])
    return {n: None if ch.parameters[n] is None else (ch.parameters[n].value - v) / ch.parameters[n].u
            for n, v in truth.items()}


def _bound_holds(reason: str, truth: float) -> bool:
    """Whether the bound a null fn or Q's reason gives ("... bound Q to Q > 4.99 (...", "... bound
    fn to 934.6-1329 Hz (...") holds ``truth``."""
    text = reason.split(" bound ")[1].split(" to ", 1)[1].split(" (")[0].replace(" Hz", "")
    if " > " in text:
        return truth > float(text.split(" > ")[1])
    if " < " in text:
        return truth < float(text.split(" < ")[1])
    if " anywhere in " in text:
        return True
    lo, hi = (float(x) for x in text.split("-"))
    return lo <= truth <= hi


# ~107 s of CPU over two processes (measured: 93.5 s user + 13.6 s sys); at load average 18 on 2
# cores it ran 854 s and the suite's 600 s timeout failed it at 67a2c6f: a hang guard, 1200 s.
@pytest.mark.slow
@pytest.mark.timeout(1200)
def test_recovery_pulls_over_simulated_campaigns() -> None:
    """24 parts drawn (k2, k3, fn, Q, rails), each campaign simulated and identified: for each
    parameter the pulls (estimate - truth)/u have a standard deviation between 0.7 and 1.4 (the
    uncertainties are neither optimistic nor inflated) and a mean within 0.6 of 0 (no bias).
    The design reaches fn and the rails, so each parameter is determined in at least 22 of the
    24 campaigns, Q in at least 18: a campaign whose sine runs do not bound Q from above (its
    profile likelihood flat toward large Q: issue 18) leaves it null with a lower bound, and that
    bound holds the truth (checked in _recover), a bound rather than a confident number."""
    with ProcessPoolExecutor(max_workers=2) as pool:
        pulls = list(pool.map(_recover, range(24)))
    for name in pulls[0]:
        values = [p[name] for p in pulls if p[name] is not None]
        assert len(values) >= (18 if name == "q" else 22), f"{name} determined in {len(values)} of 24 campaigns only"
        sd = statistics.pstdev(values)
        mean = statistics.fmean(values)
        assert 0.7 <= sd <= 1.4, f"{name}: pulls sd {sd:.2f} (mean {mean:+.2f}): {np.round(values, 2)}"
        assert abs(mean) <= 0.6, f"{name}: pulls mean {mean:+.2f} (sd {sd:.2f})"
