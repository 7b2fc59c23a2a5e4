"""The analytic VRE of a sensor in a vibration environment, without simulating it.

:func:`predict` (:mod:`~vrelab.prediction.front`) is the one front door: a vibration along any
direction of the part's frame, a static field as a scalar or a vector, one result type.

* :mod:`~vrelab.prediction.single`: the sensor's stages walked in signal order, each one's mean
  shift summed (physics §1.1-1.3);
* :mod:`~vrelab.prediction.triaxial`: one axis under a triaxial vibration, IEEE 1293's cross
  terms beside the sensed vibration's mechanisms (physics §1.6);
* :mod:`~vrelab.prediction.propagation`: the parameters' uncertainties carried to the VRE
  (physics §6.1);
* :mod:`~vrelab.prediction.results`: :class:`Prediction`, :class:`LevelPrediction`;
* :mod:`~vrelab.prediction.checks`: how a level is judged (its bound against its u).

Names are imported on first use (the triaxial module brings scipy), as :mod:`vrelab` does.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from vrelab._lazy import lazy_getattr

if TYPE_CHECKING:
    from vrelab.prediction.checks import MODEL_SOURCE as MODEL_SOURCE
    from vrelab.prediction.checks import cancellation as cancellation
    from vrelab.prediction.checks import judged as judged
    from vrelab.prediction.checks import tilt_note as tilt_note
    from vrelab.prediction.front import predict as predict
    from vrelab.prediction.propagation import CURVED_SOURCE as CURVED_SOURCE
    from vrelab.prediction.propagation import IDENTIFIED as IDENTIFIED
    from vrelab.prediction.propagation import Propagation as Propagation
    from vrelab.prediction.propagation import propagation as propagation
    from vrelab.prediction.propagation import unstated_check as unstated_check
    from vrelab.prediction.results import LevelPrediction as LevelPrediction
    from vrelab.prediction.results import Prediction as Prediction
    from vrelab.prediction.single import memoryless_level as memoryless_level
    from vrelab.prediction.single import propagated_u as propagated_u
    from vrelab.prediction.triaxial import CROSS_SHARES as CROSS_SHARES
    from vrelab.prediction.triaxial import TriaxialLevelPrediction as TriaxialLevelPrediction
    from vrelab.prediction.triaxial import TriaxialPrediction as TriaxialPrediction
    from vrelab.prediction.triaxial import predict_triaxial as predict_triaxial

# name -> module, imported on first use
_LAZY: dict[str, str] = {
    "predict": "vrelab.prediction.front",
    "Prediction": "vrelab.prediction.results",
    "LevelPrediction": "vrelab.prediction.results",
    "memoryless_level": "vrelab.prediction.single",
    "propagation": "vrelab.prediction.propagation",
    "propagated_u": "vrelab.prediction.single",
    "unstated_check": "vrelab.prediction.propagation",
    "Propagation": "vrelab.prediction.propagation",
    "CURVED_SOURCE": "vrelab.prediction.propagation",
    "IDENTIFIED": "vrelab.prediction.propagation",
    "MODEL_SOURCE": "vrelab.prediction.checks",
    "judged": "vrelab.prediction.checks",
    "tilt_note": "vrelab.prediction.checks",
    "cancellation": "vrelab.prediction.checks",
    "predict_triaxial": "vrelab.prediction.triaxial",
    "TriaxialPrediction": "vrelab.prediction.triaxial",
    "TriaxialLevelPrediction": "vrelab.prediction.triaxial",
    "CROSS_SHARES": "vrelab.prediction.triaxial",
}

__all__ = [*_LAZY]

__getattr__ = lazy_getattr(__name__, _LAZY, globals())


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
