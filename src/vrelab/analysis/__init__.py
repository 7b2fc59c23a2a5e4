"""Analysis of recorded shaker tests (SPEC section 4): readers, segmentation, VRE per level.

``open_record`` reads lab files (CSV, NPY/NPZ, HDF5, TDMS, WAV, MAT) as a streaming
:class:`~vrelab.record.Record`; ``reduce_record`` turns a record into VRE per level with honest
uncertainties; ``analyze`` adds the fits (:mod:`vrelab.fits`) and returns a
:class:`~vrelab.results.VreResult`. What a user sets: ``ReductionOptions`` (band, settling,
rail, profile, ...), ``FitOptions`` (static field, clipping model, ...), ``BudgetOptions``
(Type B terms, a decision limit), passed as ``options=``, ``fit=``, ``budget=``.
"""

from typing import Any

from vrelab.analysis.options import BudgetOptions, FitOptions, ReductionOptions
from vrelab.analysis.pipeline import analyze, analyze_channels, analyze_full, reduce, reduce_record

__all__ = [
    "analyze",
    "analyze_full",
    "analyze_channels",
    "reduce",
    "reduce_record",
    "open_record",
    "ReductionOptions",
    "FitOptions",
    "BudgetOptions",
]


def __getattr__(name: str) -> Any:
    # Readers pull in h5py/pyarrow/npTDMS: load them only when asked for.
    if name == "open_record":
        from vrelab.analysis.readers import open_record

        return open_record
    raise AttributeError(name)
