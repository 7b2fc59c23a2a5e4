"""The sensor signal chain: stages, chains of stages, sensor descriptions and presets.

``stages`` holds the building blocks (resonance, nonlinearity, over-range, rails, filters,
decimation, quantisation, noise), ``chain`` streams blocks through an ordered tuple of them, and
``loader`` turns a sensor description (a preset TOML under ``presets/`` or a user file with the
same schema) into a :class:`Sensor` that builds its chain.
"""

from vrelab.sensor.chain import ChainRun, ChainStats, SensorChain
from vrelab.sensor.stages import (
    AnalogLowPass,
    AntiAlias,
    Clip,
    Decimate,
    Drift,
    HighPass,
    LowPass,
    Noise,
    Offset,
    OverRange,
    Polynomial,
    Quantize,
    Resonator,
    Stage,
    StageBase,
)

__all__ = [
    "AnalogLowPass",
    "AntiAlias",
    "ChainRun",
    "ChainStats",
    "Clip",
    "Decimate",
    "HighPass",
    "LowPass",
    "Noise",
    "Offset",
    "Drift",
    "OverRange",
    "Polynomial",
    "Quantize",
    "Resonator",
    "SensorChain",
    "Stage",
    "StageBase",
]

from vrelab.sensor.loader import Sensor, list_presets, load_sensor  # noqa: E402

__all__ += ["Sensor", "list_presets", "load_sensor"]
