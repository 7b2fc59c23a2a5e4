"""Identification's 2f cross-check (SPEC 6.1) on the shipped example campaign: each sine run's VRC
from the 2f line agrees with the simulator's truth, as the DC estimate does.

Split from tests/test_identify.py so that pytest-xdist's loadfile runs this identification of the
example beside that file's, not after it (that file's run was the suite's critical path).
"""

from __future__ import annotations

import json
from pathlib import Path

from vrelab.cli import main
from vrelab.example_campaign import example_truth, vrc_truth

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "campaign" / "campaign.toml"


def test_2f_cross_check_on_the_example_campaign(tmp_path: Path) -> None:
    """The shipped example: each sine run's VRC from the 2f line agrees with the truth
    (k2 + 3·k3·g0)·|H(f)|² of vrelab.example_campaign.example_truth within 3u, as the DC
    estimate does."""
    out = tmp_path / "ident"
    assert main(["identify", str(EXAMPLE), "--out", str(out), "--json"]) == 0
    doc = json.loads((out / "identification.json").read_text())
    truth = example_truth()
    parts = {p.name: p for p in truth.parts}
    n = 0
    for ch in doc["channels"]:
        for x in ch["cross_check_2f"]:
            want = vrc_truth(truth, parts[ch["channel"]], x["freq_hz"], x["static_g"])
            e = x["vrc_2f_ug_per_g2"]
            assert abs(e["value"] - want) <= 3 * e["u"], (ch["channel"], x)
            n += 1
    assert n == 12  # six sine runs, two parts
