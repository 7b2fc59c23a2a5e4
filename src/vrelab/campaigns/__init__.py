"""Campaigns: every run of one shaker test, from a TOML manifest (physics §4.1).

A lab's test is many files: one per run (frequency, orientation, level block), each holding
several DUT channels (a 3-axis part, several parts on one fixture) and a reference. The
manifest names them; :func:`read_manifest` validates it whole before anything is read (an
unknown key, a missing file or channel, a channel without its static field, one file channel
named twice, one recording used twice for a DUT or at two static fields, a DUT that is the
reference: one line naming the run(s) and the key); a static field the DUT's own vibration-off
reading contradicts refuses the campaign when that run's record is read (:func:`check_static`);
:func:`run_campaign` reduces every run (in parallel with ``workers``; a run that fails is kept
as failed with its error, the others go on) and :func:`combine` gives per channel:

* ``vrc_by_freq``: the VRC of every sine frequency at every orientation;
* ``k2`` and ``k3`` per frequency measured at two orientations or more
  (``VRC(g0) = k2 + 3·k3·g0``, :func:`vrelab.fits.fit_k2_k3`), combined over those
  frequencies by their covariance-weighted mean (:func:`vrelab.fits.combine_fits`); k2 alone
  from a frequency measured only at g0 = 0 (where VRC = k2); null with the reason otherwise;
* the effective ``rail`` from every random run (weighted mean);
* ``vrc_by_mount``: the apparent VRC of every sine run mounted at an angle (IEEE 1293's
  procedure for the cross-coupling coefficients, physics §1.6: ``mount_deg``, ``mount_plane`` ip|io
  and the whole static field ``static_g = [i, p, o]``, :class:`Mount`), kept out of the above
  and fitted by :func:`vrelab.identification.fit_cross_coupling`.

Data flow: manifest -> :class:`Run` -> record (:func:`vrelab.analysis.readers.open_record`,
several DUTs) -> :func:`vrelab.analysis.pipeline.analyze_channels` -> per-run results ->
:func:`combine` -> the campaign document (``results.json``) and folder.
"""

from __future__ import annotations

from vrelab.campaigns.document import campaign_doc, profile_document, write_campaign
from vrelab.campaigns.manifest import (
    BUDGET_KEYS,
    MOUNT_PLANES,
    RUN_KEYS,
    SAME_ORIENTATION_G,
    TOP_KEYS,
    Manifest,
    ManifestContradiction,
    Mount,
    Run,
    check_records,
    check_static,
    read_manifest,
)
from vrelab.campaigns.runs import RunResult, dut_range, judge_units, reduce_run, run_campaign, run_folders
from vrelab.campaigns.summary import K2_CONSISTENCY_P, ChannelSummary, combine

__all__ = [
    "BUDGET_KEYS", "K2_CONSISTENCY_P", "MOUNT_PLANES", "RUN_KEYS", "SAME_ORIENTATION_G", "TOP_KEYS",
    "ChannelSummary", "Manifest", "ManifestContradiction", "Mount", "Run", "RunResult", "campaign_doc",
    "check_records", "check_static", "combine", "dut_range", "judge_units", "profile_document", "read_manifest",
    "reduce_run", "run_campaign", "run_folders", "write_campaign",
]
