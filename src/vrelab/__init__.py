"""vrelab: vibration rectification error (VRE) of accelerometers.

Data flow, one module boundary per arrow::

    profiles -> synthesis -> sensor (chain of stages) -> record -> analysis -> fits -> report

``vrelab.models`` holds the pure analytic physics used at every step.

The front door (``import vrelab`` is enough)::

    sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z")
    profile = vrelab.parse_profile("flat:50-2000")
    vrelab.predict(sensor, profile, [1.0, 2.5], static_g=1.0)        # analytic, with shares
    vrelab.simulate(sensor, profile, [1.0, 2.5], seconds=4, seed=1)  # a simulated shaker test
    vrelab.analyze("run.h5", dut="dut", reference="ref")            # a recorded one
    doc = vrelab.campaign("campaign.toml")                          # every run of a manifest
    vrelab.identify(doc, base_spec="ideal", range_g=2.048)          # each channel's model
    tri = vrelab.TriaxialProfile.along(profile, (1, 0, 1))          # the same at 45° in x-z
    vrelab.predict(sensor, tri, [1.0], static_g=(0, 0, 1))          # the IEEE 1293 cross terms too
    vrelab.simulate(sensor, tri, [1.0], static_g=(0, 0, 1), seconds=4, seed=1)   # one simulate for both

Every name is imported on first use (``__version__`` too: ``importlib.metadata`` alone costs
more than the rest), so ``import vrelab`` imports no numpy and costs a few tens of ms beyond
the interpreter's own start (``python bench/bench_startup.py``); the modules behind
``predict``, ``identify`` and ``campaign`` take 1 to 3 s more, scipy mostly.
"""

# Design: ``predict``, ``campaign`` and ``identify`` are plain functions; their modules have
# their own names (``vrelab.prediction``, ``vrelab.campaigns``, ``vrelab.identification``), so
# no submodule import can rebind the front door's verbs. Every name is a PEP 562 module
# ``__getattr__`` entry (vrelab._lazy, the rule of every lazy package here): ``import vrelab``
# pays for none of them. Static checkers see them through the ``TYPE_CHECKING`` imports below;
# tests/test_front_door.py runs each import order in a fresh interpreter.

from __future__ import annotations

from typing import TYPE_CHECKING

from vrelab._lazy import lazy_getattr

if TYPE_CHECKING:
    from vrelab._api import analyze as analyze
    from vrelab._api import campaign as campaign
    from vrelab._api import simulate as simulate
    from vrelab._version import __version__ as __version__
    from vrelab.comparison import Comparison as Comparison
    from vrelab.comparison import compare as compare
    from vrelab.gum import TypeB as TypeB
    from vrelab.identification import Identification as Identification
    from vrelab.identification import identify as identify
    from vrelab.prediction import LevelPrediction as LevelPrediction
    from vrelab.prediction import Prediction as Prediction
    from vrelab.prediction import predict as predict
    from vrelab.prediction import predict_triaxial as predict_triaxial
    from vrelab.profiles import RandomProfile as RandomProfile
    from vrelab.profiles import SineOnRandom as SineOnRandom
    from vrelab.profiles import SineProfile as SineProfile
    from vrelab.profiles import parse_profile as parse_profile
    from vrelab.results import Conditions as Conditions
    from vrelab.results import Estimate as Estimate
    from vrelab.results import FitResult as FitResult
    from vrelab.results import LevelResult as LevelResult
    from vrelab.results import VreResult as VreResult
    from vrelab.sensor import Sensor as Sensor
    from vrelab.sensor import load_sensor as load_sensor
    from vrelab.triaxial import TriaxialProfile as TriaxialProfile
    from vrelab.triaxial import TriaxialSine as TriaxialSine
    from vrelab.triaxial.simulate import simulate_triaxial as simulate_triaxial

# name -> the module it is imported from on first use
_LAZY: dict[str, str] = {
    "__version__": "vrelab._version",  # importlib.metadata: 20 ms, for who asks
    "load_sensor": "vrelab.sensor",
    "parse_profile": "vrelab.profiles",
    "simulate": "vrelab._api",
    "analyze": "vrelab._api",
    "campaign": "vrelab._api",  # a plain function: the package is vrelab.campaigns
    "Sensor": "vrelab.sensor",
    "RandomProfile": "vrelab.profiles",
    "SineOnRandom": "vrelab.profiles",
    "SineProfile": "vrelab.profiles",
    "predict": "vrelab.prediction",  # a plain function (its module: vrelab.prediction)
    "Prediction": "vrelab.prediction",
    "LevelPrediction": "vrelab.prediction",
    "VreResult": "vrelab.results",
    "LevelResult": "vrelab.results",
    "FitResult": "vrelab.results",
    "Estimate": "vrelab.results",
    "Conditions": "vrelab.results",
    "Identification": "vrelab.identification",
    "identify": "vrelab.identification",
    "TypeB": "vrelab.gum",
    "TriaxialProfile": "vrelab.triaxial.profile",
    "TriaxialSine": "vrelab.triaxial.profile",
    "predict_triaxial": "vrelab.prediction",
    "simulate_triaxial": "vrelab.triaxial.simulate",
    "compare": "vrelab.comparison",  # a plain function (its package: vrelab.comparison)
    "Comparison": "vrelab.comparison",
}

__all__ = list(_LAZY)
__getattr__ = lazy_getattr(__name__, _LAZY, globals())


def __dir__() -> list[str]:
    """The public names only, not the package's own imports."""
    return sorted(__all__)
