"""Plots and the self-contained HTML report, laid out as a test report.

:mod:`vrelab.report.plots` draws figures from results and records (matplotlib, Agg, no pyplot);
:mod:`vrelab.report.interactive` translates each drawn figure into its plotly twin (zoom, pan,
hover; plotly.js embedded once per file); :mod:`vrelab.report.html` renders figures and tables
into one HTML file (:func:`~vrelab.report.html.write_report`) inside the test-report frame of
:mod:`vrelab.report.testreport` (item, equipment, conditions, procedure, results, decisions,
approval), filled from an optional metadata TOML (:mod:`vrelab.report.metadata`);
:mod:`vrelab.report.campaign` and :mod:`vrelab.report.sweep` build a campaign's and a sweep's
sections. :func:`report_dir` reads a results folder (:func:`vrelab.folder.read_folder`) and
writes its report. Imports go one way: ``plots`` <- ``interactive`` <- ``html`` <- ``testreport``
(called from ``html`` at render time) and ``campaign``, ``sweep`` <- this package.
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

from vrelab.folder import ResultsFolder, read_folder
from vrelab.report.html import (
    ReportFigure,
    ReportSection,
    report_result_dir,
    write_report,
)
from vrelab.report.metadata import ReportMetadata, load_metadata

__all__ = ["ReportFigure", "ReportMetadata", "ReportSection", "load_metadata", "report_dir", "write_report"]


def report_dir(
    folder: str | Path,
    argv: Sequence[str] | None = None,
    title: str | None = None,
    metadata: ReportMetadata | str | Path | None = None,
) -> Path:
    """Write ``folder/report.html`` for a results folder: a simulate/analyze/demo result
    (:func:`vrelab.report.html.report_result_dir`), several channels of one file, a campaign
    (:func:`vrelab.report.campaign.report_campaign_dir`) or a sweep
    (:func:`vrelab.report.sweep.report_sweep_dir`, which needs the ``sweep`` extra).

    ``metadata`` is a :class:`~vrelab.report.metadata.ReportMetadata` or the path of its TOML
    file (:func:`~vrelab.report.metadata.load_metadata`), read and validated before anything is
    written; a bad file is a one-line ``ValueError``.
    """
    from vrelab import _io
    from vrelab.folder import REPORT

    meta = load_metadata(metadata) if isinstance(metadata, (str, Path)) else metadata
    rf = read_folder(folder)
    _io.claim_file(rf.path, REPORT)  # a report.html vrelab did not write is refused, not overwritten
    path = _write(rf, argv, title, meta)
    _io.note_written(rf.path, [REPORT])  # the folder stays vrelab's: a later run may replace it
    return path


def _write(rf: ResultsFolder, argv: Sequence[str] | None, title: str | None, meta: ReportMetadata | None) -> Path:
    if rf.kind == "channels":
        from vrelab.report.html import report_channels_dir

        return report_channels_dir(rf, argv, title, meta)
    if rf.kind == "campaign":
        from vrelab.report.campaign import report_campaign_dir

        return report_campaign_dir(rf, argv, title, meta)
    if rf.kind == "identification":
        from vrelab.report.identify import report_identification_dir

        return report_identification_dir(rf, argv, title, meta)
    if rf.kind == "sweep":
        from vrelab.report.sweep import report_sweep_dir

        return report_sweep_dir(rf.path, argv, title, meta)
    return report_result_dir(rf, argv, title, meta)
