"""Generate the example campaign's recordings (examples/campaign/runs/) from the simulator.

    python examples/make_campaign.py            # write what is missing (what `make examples` runs)
    python examples/make_campaign.py --force    # simulate and write the whole campaign again
    python examples/make_campaign.py FOLDER     # the campaign in another folder

The recordings (17 MB) are not committed: they are generated on first use, by this script, by
`make examples` (which `make demo`, `make test` and `make docs` run) or by the test suite. Same
seed, same files: the numbers the README quotes come from them.

Two simulated parts (sn1, sn2) on one fixture, their truth in
vrelab.example_campaign.example_truth(): k2, k3, rails ±2.048 g, a resonance at 1.2 kHz (Q 4).
Seven runs written as a lab's equipment would: TDMS, CSV, UFF58 (ASCII and binary 58b), HDF5,
the DUTs in LSB and the reference in mV, and the manifest campaign.toml.

The parts' chain (campaign/sensor.toml) has no ODR filter and full scale ±2.048 g: identify them on
a base that matches it, `vrelab identify CAMP --base-sensor ideal --range 2.048` (a base with
output filters, such as the ADXL355 preset, would carry its low-pass into the identified file).
"""

import argparse
import shutil
from pathlib import Path

from vrelab.example_campaign import ensure_campaign

parser = argparse.ArgumentParser(description="generate the example campaign's recordings")
parser.add_argument("folder", nargs="?", type=Path, default=Path(__file__).parent / "campaign")
parser.add_argument("--force", action="store_true", help="write the whole campaign again (manifest included)")
args = parser.parse_args()
if args.force and args.folder.exists():
    shutil.rmtree(args.folder)
print(ensure_campaign(args.folder))
