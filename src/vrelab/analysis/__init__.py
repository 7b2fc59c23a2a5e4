"""Analysis of recorded shaker tests (physics §4): readers, segmentation, VRE per level.

``open_record`` reads lab files (CSV, NPY/NPZ, HDF5, TDMS, WAV, MAT) as a streaming
:class:`~vrelab.record.Record`; ``reduce_record`` turns a record into VRE per level with honest
uncertainties; ``analyze`` adds the fits (:mod:`vrelab.fits`) and returns a
:class:`~vrelab.results.VreResult`. What a user sets: ``ReductionOptions`` (band, settling,
rail, profile, ...), ``FitOptions`` (static field, clipping model, ...), ``BudgetOptions``
(Type B terms, a decision limit), passed as ``options=``, ``fit=``, ``budget=``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from vrelab._lazy import lazy_getattr

if TYPE_CHECKING:
    from vrelab.analysis.options import BudgetOptions as BudgetOptions
    from vrelab.analysis.options import FitOptions as FitOptions
    from vrelab.analysis.options import ReductionOptions as ReductionOptions
    from vrelab.analysis.pipeline import Given as Given
    from vrelab.analysis.pipeline import analyze as analyze
    from vrelab.analysis.pipeline import analyze_channels as analyze_channels
    from vrelab.analysis.pipeline import analyze_full as analyze_full
    from vrelab.analysis.pipeline import reduce as reduce
    from vrelab.analysis.pipeline import reduce_record as reduce_record
    from vrelab.analysis.readers import open_record as open_record

# name -> module, imported on first use: the pipeline brings scipy, the readers h5py, pyarrow,
# npTDMS...; a leaf (``vrelab.analysis.options`` for the command line's choices) brings neither
_LAZY: dict[str, str] = {
    "analyze": "vrelab.analysis.pipeline",
    "analyze_full": "vrelab.analysis.pipeline",
    "analyze_channels": "vrelab.analysis.pipeline",
    "reduce": "vrelab.analysis.pipeline",
    "reduce_record": "vrelab.analysis.pipeline",
    "open_record": "vrelab.analysis.readers",
    "ReductionOptions": "vrelab.analysis.options",
    "FitOptions": "vrelab.analysis.options",
    "BudgetOptions": "vrelab.analysis.options",
    "Given": "vrelab.analysis.pipeline",
}

__all__ = list(_LAZY)


__getattr__ = lazy_getattr(__name__, _LAZY, globals())
