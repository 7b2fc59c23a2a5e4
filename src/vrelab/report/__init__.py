"""Plots and the self-contained HTML report.

:mod:`vrelab.report.plots` draws figures from results and records (matplotlib, Agg, no pyplot);
:mod:`vrelab.report.html` renders them with tables into one HTML file
(:func:`~vrelab.report.html.write_report`); :mod:`vrelab.report.sweep` builds a sweep's section
from its Dataset. :func:`report_dir` reads a results folder (:func:`vrelab.folder.read_folder`)
and writes its report. Imports go one way: ``plots`` <- ``html`` <- ``sweep`` <- this package.
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

from vrelab.folder import read_folder
from vrelab.report.html import (
    ReportFigure,
    ReportSection,
    report_result_dir,
    write_report,
)

__all__ = ["ReportFigure", "ReportSection", "report_dir", "write_report"]


def report_dir(folder: str | Path, argv: Sequence[str] | None = None, title: str | None = None) -> Path:
    """Write ``folder/report.html`` for a results folder: a simulate/analyze/demo result
    (:func:`vrelab.report.html.report_result_dir`) or a sweep
    (:func:`vrelab.report.sweep.report_sweep_dir`, which needs the ``sweep`` extra)."""
    rf = read_folder(folder)
    if rf.kind == "channels":
        from vrelab.report.html import report_channels_dir

        return report_channels_dir(rf, argv, title)
    if rf.kind == "campaign":
        from vrelab.report.campaign import report_campaign_dir

        return report_campaign_dir(rf, argv, title)
    if rf.kind == "identification":
        from vrelab.report.identify import report_identification_dir

        return report_identification_dir(rf, argv, title)
    if rf.kind == "sweep":
        from vrelab.report.sweep import report_sweep_dir

        return report_sweep_dir(rf.path, argv, title)
    return report_result_dir(rf, argv, title)
