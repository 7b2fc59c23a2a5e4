"""Beyond one axis (physics §1.6): triaxial vibration and the IEEE 1293 cross-coupling terms.

* :mod:`~vrelab.triaxial.profile`: :class:`TriaxialProfile` (random vibration along x, y and z
  as a 3×3 cross-spectral density matrix), :class:`TriaxialSine` (a sine along a direction),
  :func:`direction` (the unit vector of an IEEE 1293 mount angle);
* :mod:`~vrelab.triaxial.files`: triaxial TOML files and the command-line forms
  (``PROFILE@dir=X,Y,Z``, ``PROFILE@z45x``);
* :mod:`~vrelab.triaxial.recording`: the measured cross-spectral density of a triaxial record;
* :mod:`~vrelab.triaxial.chain`: one DUT axis's signal chain under a triaxial acceleration
  (IEEE 1293's model equation);
* :mod:`~vrelab.triaxial.synthesis`: the MIMO drive of a prescribed cross-spectral density;
* :mod:`~vrelab.prediction.triaxial`: :func:`predict_triaxial`, the analytic VRE by mechanism,
  cross terms included;
* :mod:`~vrelab.triaxial.simulate`: the simulated triaxial shaker test (called as
  :func:`vrelab.simulate`; :func:`simulate_triaxial` its deprecated alias);
* :mod:`~vrelab.triaxial.analyze`: a triaxial record reduced per axis (called as
  :func:`vrelab.analyze`; :func:`analyze_triaxial` its deprecated alias);
* :mod:`~vrelab.triaxial.result`: :class:`~vrelab.triaxial.result.TriaxialPart`, what a triaxial
  test or analysis adds to its DUT axes in the one result, :class:`~vrelab.results.VreResult`
  (``TriaxialTest`` and ``TriaxialAnalysis``, the former result classes, its deprecated aliases).

The profile's names are imported with the package; the others on first use (the modules behind
them bring scipy and the simulator), as :mod:`vrelab` does.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from vrelab._lazy import lazy_getattr
from vrelab.triaxial.profile import AXES, PairCoherence, TriaxialProfile, TriaxialSine, direction

if TYPE_CHECKING:
    from vrelab.prediction.triaxial import TriaxialLevelPrediction as TriaxialLevelPrediction
    from vrelab.prediction.triaxial import TriaxialPrediction as TriaxialPrediction
    from vrelab.prediction.triaxial import predict_triaxial as predict_triaxial
    from vrelab.triaxial.analyze import analyze_triaxial as analyze_triaxial
    from vrelab.triaxial.chain import CROSS_TERMS as CROSS_TERMS
    from vrelab.triaxial.chain import TriaxialChain as TriaxialChain
    from vrelab.triaxial.chain import TriaxialPolynomial as TriaxialPolynomial
    from vrelab.triaxial.chain import triaxial_chain as triaxial_chain
    from vrelab.triaxial.files import parse_triaxial as parse_triaxial
    from vrelab.triaxial.files import read_triaxial as read_triaxial
    from vrelab.triaxial.files import write_triaxial as write_triaxial
    from vrelab.triaxial.recording import MeasuredCsd as MeasuredCsd
    from vrelab.triaxial.recording import measure_csd as measure_csd
    from vrelab.triaxial.recording import read_recording_profile as read_recording_profile
    from vrelab.triaxial.simulate import simulate_triaxial as simulate_triaxial
    from vrelab.triaxial.synthesis import triaxial_random_signal as triaxial_random_signal

# name -> module, imported on first use
_LAZY: dict[str, str] = {
    "read_triaxial": "vrelab.triaxial.files",
    "write_triaxial": "vrelab.triaxial.files",
    "parse_triaxial": "vrelab.triaxial.files",
    "MeasuredCsd": "vrelab.triaxial.recording",
    "measure_csd": "vrelab.triaxial.recording",
    "read_recording_profile": "vrelab.triaxial.recording",
    "CROSS_TERMS": "vrelab.triaxial.chain",
    "TriaxialPolynomial": "vrelab.triaxial.chain",
    "TriaxialChain": "vrelab.triaxial.chain",
    "triaxial_chain": "vrelab.triaxial.chain",
    "triaxial_random_signal": "vrelab.triaxial.synthesis",
    "predict_triaxial": "vrelab.prediction.triaxial",
    "TriaxialPrediction": "vrelab.prediction.triaxial",
    "TriaxialLevelPrediction": "vrelab.prediction.triaxial",
    "simulate_triaxial": "vrelab.triaxial.simulate",
    "analyze_triaxial": "vrelab.triaxial.analyze",
}

__all__ = ["AXES", "PairCoherence", "TriaxialProfile", "TriaxialSine", "direction", *_LAZY]


_lazy = lazy_getattr(__name__, _LAZY, globals())


def __getattr__(name: str) -> object:
    """The names of ``_LAZY`` on first use; the former result classes ``TriaxialTest`` and
    ``TriaxialAnalysis`` (deprecated, one release: :mod:`vrelab.triaxial.result`) from their
    modules, whose import of them warns each time."""
    if name in ("TriaxialTest", "TriaxialAnalysis"):
        import importlib

        module = "vrelab.triaxial.simulate" if name == "TriaxialTest" else "vrelab.triaxial.analyze"
        return getattr(importlib.import_module(module), name)
    return _lazy(name)


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
