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
    vrelab.simulate_triaxial(sensor, tri, [1.0], static_g=(0, 0, 1), seconds=4, seed=1)

Every name is imported on first use (``__version__`` too: ``importlib.metadata`` alone costs
more than the rest), so ``import vrelab`` imports no numpy and costs a few tens of ms beyond
the interpreter's own start (``python bench/bench_startup.py``); the modules behind
``predict``, ``identify`` and ``campaign`` take 1 to 3 s more, scipy mostly.
"""

# Design: ``campaign`` and ``identify`` (``predict`` too, before it became a plain function) are both submodules of this package and the
# front door's verbs. The import system binds ``vrelab.predict`` to the submodule whenever it is
# first imported (``import vrelab.predict``, ``from vrelab.predict import X``, or any vrelab
# module importing it), and ``import vrelab.predict as m`` reads that attribute back, as do
# ``mock.patch("vrelab.predict.x")`` and the tests' ``monkeypatch.setattr(vrelab.predict, ...)``.
# Binding the function to that name instead (eagerly, at package import) would break all three
# and cost 1 to 3 s at every ``import vrelab`` (the CLI's too). So the name stays the module,
# in every import order, and the module is made callable: calling ``vrelab.predict(...)``
# calls ``vrelab.predict.predict(...)`` (``vrelab.identify(...)``: ``vrelab.identify.identify``;
# ``vrelab.campaign(...)``: :func:`vrelab._api.campaign`), looked up at each call so a patch of
# the function is followed. The class of the submodule is set when it is read through this
# package (``_Package.__getattribute__``), which every access by name does, whatever imported
# it first; module ``__class__`` assignment is the documented way to customise a module
# (Python reference, "Customizing module attribute access"). Static checkers see the functions
# (the ``TYPE_CHECKING`` imports below). tests/test_front_door.py runs each order in a fresh
# interpreter.

from __future__ import annotations

import importlib
import sys
from types import ModuleType
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from vrelab._api import analyze as analyze
    from vrelab._api import campaign as campaign
    from vrelab._api import simulate as simulate
    from vrelab._version import __version__ as __version__
    from vrelab.gum import TypeB as TypeB
    from vrelab.identify import Identification as Identification
    from vrelab.identify import identify as identify
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

# name -> (module, attribute), imported on first use
_LAZY: dict[str, tuple[str, str]] = {
    "__version__": ("vrelab._version", "__version__"),  # importlib.metadata: 20 ms, for who asks
    "load_sensor": ("vrelab.sensor", "load_sensor"),
    "parse_profile": ("vrelab.profiles", "parse_profile"),
    "simulate": ("vrelab._api", "simulate"),
    "analyze": ("vrelab._api", "analyze"),
    "Sensor": ("vrelab.sensor", "Sensor"),
    "RandomProfile": ("vrelab.profiles", "RandomProfile"),
    "SineOnRandom": ("vrelab.profiles", "SineOnRandom"),
    "SineProfile": ("vrelab.profiles", "SineProfile"),
    "predict": ("vrelab.prediction", "predict"),  # a plain function (its module: vrelab.prediction)
    "Prediction": ("vrelab.prediction", "Prediction"),
    "LevelPrediction": ("vrelab.prediction", "LevelPrediction"),
    "VreResult": ("vrelab.results", "VreResult"),
    "LevelResult": ("vrelab.results", "LevelResult"),
    "FitResult": ("vrelab.results", "FitResult"),
    "Estimate": ("vrelab.results", "Estimate"),
    "Conditions": ("vrelab.results", "Conditions"),
    "Identification": ("vrelab.identify", "Identification"),
    "TypeB": ("vrelab.gum", "TypeB"),
    "TriaxialProfile": ("vrelab.triaxial.profile", "TriaxialProfile"),
    "TriaxialSine": ("vrelab.triaxial.profile", "TriaxialSine"),
    "predict_triaxial": ("vrelab.prediction", "predict_triaxial"),
    "simulate_triaxial": ("vrelab.triaxial.simulate", "simulate_triaxial"),
}
# submodule name -> (module, function) that calling the submodule calls
_VERBS: dict[str, tuple[str, str]] = {
    "campaign": ("vrelab._api", "campaign"),
    "identify": ("vrelab.identify", "identify"),
}

__all__ = [*_LAZY, *_VERBS]


class _CallableModule(ModuleType):
    """A submodule that is also its verb: ``vrelab.predict(...)`` is ``vrelab.predict.predict(...)``."""

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        module, function = _VERBS[self.__name__.rpartition(".")[2]]
        return getattr(importlib.import_module(module), function)(*args, **kwargs)


class _Package(ModuleType):
    def __getattribute__(self, name: str) -> Any:
        value = super().__getattribute__(name)
        if name in _VERBS and type(value) is ModuleType:
            value.__class__ = _CallableModule
        return value

    def __getattr__(self, name: str) -> Any:
        if name in _VERBS:
            importlib.import_module(f"{__name__}.{name}")  # binds the attribute; read it back
            return getattr(self, name)
        if name in _LAZY:
            module, attribute = _LAZY[name]
            value = getattr(importlib.import_module(module), attribute)
            setattr(self, name, value)
            return value
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

    def __dir__(self) -> list[str]:
        return sorted({*super().__dir__(), *__all__})


sys.modules[__name__].__class__ = _Package
