"""Plots and the self-contained HTML report.

:mod:`vrelab.report.plots` draws figures from results and records (matplotlib, Agg, no pyplot);
:mod:`vrelab.report.html` renders them with tables into one HTML file
(:func:`~vrelab.report.html.write_report`, :func:`~vrelab.report.html.report_dir`).
"""

from vrelab.report.html import ReportFigure, ReportSection, report_dir, write_report

__all__ = ["ReportFigure", "ReportSection", "report_dir", "write_report"]
