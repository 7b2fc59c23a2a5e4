"""Regenerate the shipped example campaign (examples/campaign/) from the simulator.

    python examples/make_campaign.py [FOLDER]

Two simulated parts (sn1, sn2) on one fixture, their truth in
vrelab.simulation.campaign.example_truth(): k2, k3, rails ±2.048 g, a resonance at 1.2 kHz (Q 4).
Six runs written as a lab's equipment would: TDMS, CSV, UFF58 (ASCII and binary 58b), HDF5,
the DUTs in LSB and the reference in mV, and the manifest campaign.toml. Same seed, same files.

The parts' chain (campaign/sensor.toml) has no ODR filter and full scale ±2.048 g: identify them on
a base that matches it, `vrelab identify CAMP --base-sensor ideal --range 2.048` (a base with
output filters, such as the ADXL355 preset, would carry its low-pass into the identified file).
"""

import shutil
import sys
from pathlib import Path

from vrelab.simulation.campaign import write_campaign

folder = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parent / "campaign"
if folder.exists():
    shutil.rmtree(folder)
print(write_campaign(folder))
