"""The file names of a results folder (their owner is :mod:`vrelab.folder`, which re-exports
them; they live in this leaf module so that :mod:`vrelab._io`, which folder itself writes
through, can read them without an import cycle)."""

from __future__ import annotations

RESULTS = "results.json"
LEVELS = "levels.csv"
PREDICTION = "prediction.json"
RECORD = "record.h5"
ENVELOPE = "envelope.csv"
PSD = "psd.csv"
PSD_LEVELS = "psd_levels.csv"
SWEEP_RESULT = "result.nc"
REPORT = "report.html"
SUMMARY = "summary.json"
IDENTIFICATION = "identification.json"
IDENTIFIED_SENSOR = "sensor.toml"

# The sweep's files (their writer, vrelab.sweep, owns the names; listed here for the rule below).
SWEEP_FILES = ("result.csv", "result.zarr", "sweep.json", "checkpoint.jsonl", "checkpoint.quarantine.jsonl")
# Every file name vrelab writes into an output folder, at any depth. A folder written before
# the marker listed its entries is taken as vrelab's only when it holds nothing but these
# (vrelab._io.check_output): a user's folder that merely holds a report.html is refused.
KNOWN_NAMES = frozenset({RESULTS, LEVELS, PREDICTION, RECORD, ENVELOPE, PSD, PSD_LEVELS, SWEEP_RESULT, REPORT,
                         SUMMARY, IDENTIFICATION, IDENTIFIED_SENSOR, ".vrelab-output", *SWEEP_FILES})
# ... of which one at the top says "a vrelab folder"; a sub-folder of these names is taken whole.
RESULT_FILES = (RESULTS, SWEEP_RESULT, IDENTIFICATION, SUMMARY, PREDICTION, "sweep.json", "checkpoint.jsonl")
OPAQUE_DIRS = ("result.zarr",)
