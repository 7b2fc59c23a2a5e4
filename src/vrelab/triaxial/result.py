"""The triaxial part of a result (physics §1.6): what a triaxial test or analysis adds to its DUT axes.

:func:`vrelab.simulate` and :func:`vrelab.analyze` return one :class:`~vrelab.results.VreResult`
whatever the vibration (issue 31): a triaxial one holds each DUT axis's result (``axes``) and
this part, ``result.triaxial``: the reference's levels as vectors (each level's total and
per-axis rms and cross-spectrum, ``reference_levels``), its channels, the axis the levels were
segmented on and, for a simulation, the vibration, the static vector, the levels asked for
and the simulation's conditions. ``to_dict()`` of such a result is :meth:`TriaxialPart.document`:
the very document ``TriaxialTest.to_dict()`` (a simulation) and ``TriaxialAnalysis.to_dict()``
(an analysis) gave.

:class:`TriaxialTest` and :class:`TriaxialAnalysis`, the former result classes, stay one
release as deprecated aliases: each builds the one result from its former arguments.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, Mapping, Sequence

from vrelab._display import Shown
from vrelab.results import Conditions, Method, VreResult, channels_to_dict
from vrelab.triaxial.profile import AXES

if TYPE_CHECKING:
    from vrelab.triaxial.analyze import TriaxialLevel
    from vrelab.triaxial.profile import TriaxialProfile, TriaxialSine

__all__ = ["TriaxialPart", "LEVEL_TEXT", "ANALYSIS_LEVEL_TEXT"]

# Level definition of a triaxial test (TRIAXIAL.md): the total rms of the vibration vector.
LEVEL_TEXT = "total rms of the triaxial reference, sqrt(rms_x² + rms_y² + rms_z²)"
# ... and how an analysis measures it (vrelab.triaxial.analyze's module docstring)
ANALYSIS_LEVEL_TEXT = (
    "rms_g of every level is the reference's total rms in the test band (at the drive frequency for "
    "a sine): the most moving axis's level (segmenting_axis) times sqrt(Σ m_j / m_axis), m_j the "
    "axes' in-band mean squares by the same windows (sqrt of the sum of the axes' single-axis "
    "levels squared); the same number in every channel's levels; axis_rms_g gives each axis's; "
    "csd.rms_g is the Welch band integral of the reported spectrum, not the level")


@dataclass(frozen=True, eq=False, repr=False)
class TriaxialPart(Shown):
    """What a triaxial test or analysis adds to its DUT axes' results (the module docstring).

    The analysis (every triaxial result): ``reference_levels`` (per level, the reference's total
    and per-axis rms and cross-spectrum), ``reference`` (axis -> channel), ``segmenting_axis``
    (the most moving reference axis, whose levels are made total), ``level_axis`` (DUT axis ->
    the reference axis its reduction read), ``reductions`` (DUT axis -> its
    :class:`~vrelab.analysis.pipeline.Reduction`). A simulation adds ``excitation`` (the
    vibration), ``levels_g`` (the total rms asked for), ``static_g`` (the static vector (gx, gy,
    gz) [g] in the part's frame), ``conditions`` and ``record_path``.

    Examples
    --------
    A simulated triaxial test (flat 50-2000 Hz along 45° in x-z, the ADXL355's z axis upright in
    1 g): the one result, its triaxial part holding the vibration and the reference's levels:

    >>> import vrelab
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> tri = vrelab.TriaxialProfile.along(vrelab.parse_profile("flat:50-2000"), (1, 0, 1))
    >>> test = vrelab.simulate(sensor, tri, [1.0], (0, 0, 1), seconds=2, seed=1)
    >>> type(test).__name__, list(test.axes), test.triaxial.static_g, test.triaxial.segmenting_axis
    ('VreResult', ['z'], (0.0, 0.0, 1.0), 'x')
    >>> print(f"{test.reference_levels[0].rms_g:.2f} g rms total, x {test.reference_levels[0].axis_rms_g[0]:.2f} g")
    1.01 g rms total, x 0.71 g
    """

    reference_levels: tuple[TriaxialLevel, ...] = ()
    reference: Mapping[str, str] = field(default_factory=dict)
    segmenting_axis: str | None = None
    level_axis: Mapping[str, str] = field(default_factory=dict)
    reductions: Mapping[str, Any] = field(default_factory=dict)
    excitation: TriaxialProfile | TriaxialSine | None = None
    levels_g: tuple[float, ...] = ()
    static_g: tuple[float, float, float] | None = None
    conditions: Mapping[str, Any] = field(default_factory=dict)
    record_path: str | None = None
    # the former result classes' attributes, read on this part (deprecated on the result itself)
    FORMER: ClassVar[frozenset[str]] = frozenset({"excitation", "levels_g", "static_g", "record_path", "reference",
                                                  "segmenting_axis", "level_axis"})

    @property
    def simulated(self) -> bool:
        """Whether the part is a simulation's (its vibration known)."""
        return self.excitation is not None

    def display_fields(self) -> list[tuple[str, Any]]:
        if self.excitation is not None:
            return [("excitation", self.excitation.describe()), ("static_g", self.static_g),
                    ("levels_g", self.levels_g)]
        return [("reference", self.reference), ("segmenting_axis", self.segmenting_axis),
                ("reference_levels", self.reference_levels)]

    def document(self, axes: Sequence[tuple[str, VreResult]], method: str,
                 provenance: Mapping[str, Any]) -> dict[str, Any]:
        """The result's ``to_dict()``: each axis's whole :meth:`VreResult.to_dict` as a channel
        (so ``vrelab report`` reads it), and ``triaxial``: a simulation's vibration, levels and
        static vector, or an analysis's reference channels and levels (each level's ``axis_rms_g``
        also in the channels' levels)."""
        if self.excitation is not None:
            chans = [{"channel": a, **r.to_dict()} for a, r in axes]
            return {"kind": "simulation", "method": method, "channels": chans,
                    "triaxial": {"excitation": self.excitation.to_dict(), "level": LEVEL_TEXT,
                                 "levels_g": list(self.levels_g),
                                 "static_vector_g": None if self.static_g is None else list(self.static_g),
                                 "conditions": dict(self.conditions), "record": self.record_path},
                    "provenance": dict(provenance)}
        doc = channels_to_dict(axes, provenance)
        by_time = {(lv.start_s, lv.end_s): lv for lv in self.reference_levels}
        for ch, (name, _) in zip(doc["channels"], axes):
            ch["level_axis"] = self.level_axis[name]
            red = self.reductions.get(name)
            for d, seg in zip(ch["levels"], red.level_segments if red is not None else ()):
                lv = by_time.get((seg.start_s, seg.end_s))
                if lv is not None:
                    d["axis_rms_g"] = dict(zip(AXES, lv.axis_rms_g))
        doc["triaxial"] = {
            "reference_channels": dict(self.reference),
            "segmenting_axis": self.segmenting_axis,
            "level": ANALYSIS_LEVEL_TEXT,
            "levels": [lv.to_dict() for lv in self.reference_levels],
        }
        return doc


# --- the former result classes, one release ---------------------------------------------------


def _deprecated(name: str) -> None:
    warnings.warn(f"{name} is deprecated and will be removed in the next release: vrelab.simulate and "
                  "vrelab.analyze return a VreResult (result.axes, result.triaxial)", DeprecationWarning, stacklevel=3)


def former_class(module: str, name: str) -> type[VreResult]:
    """The former result class ``name`` read from ``module`` (its module ``__getattr__``), with a
    DeprecationWarning pointing at the import."""
    warnings.warn(f"{module}.{name} is deprecated and will be removed in the next release: vrelab.simulate "
                  "and vrelab.analyze return a VreResult (result.axes, result.triaxial)", DeprecationWarning,
                  stacklevel=3)
    return {"TriaxialTest": TriaxialTest, "TriaxialAnalysis": TriaxialAnalysis}[name]


class TriaxialTest(VreResult):
    """Deprecated alias (one release): the :class:`~vrelab.results.VreResult` of a simulated
    triaxial test, built from ``TriaxialTest(method, excitation, levels_g, static_g, axes,
    conditions, record_path=None)`` (``conditions`` the simulation's, now ``triaxial.conditions``)."""

    def __init__(self, method: Method, excitation: TriaxialProfile | TriaxialSine, levels_g: Sequence[float],
                 static_g: Sequence[float], axes: Mapping[str, VreResult], conditions: Mapping[str, Any],
                 record_path: str | None = None) -> None:
        _deprecated("TriaxialTest")
        g = tuple(float(x) for x in static_g)
        part = TriaxialPart(excitation=excitation, levels_g=tuple(levels_g), static_g=(g[0], g[1], g[2]),
                            conditions=dict(conditions), record_path=record_path)
        first = next(iter(axes.values()), None)
        VreResult.__init__(self, method, Conditions(), (), kind="simulation",
                           provenance={} if first is None else dict(first.provenance),
                           axis_results=tuple(axes.items()), triaxial=part)


class TriaxialAnalysis(VreResult):
    """Deprecated alias (one release): the :class:`~vrelab.results.VreResult` of a triaxial
    analysis, built from ``TriaxialAnalysis(channels, levels, reference, segmenting_axis,
    level_axis)``; its ``levels`` (the reference's) are ``reference_levels``."""

    def __init__(self, channels: Sequence[tuple[str, VreResult, Any]], levels: Sequence[TriaxialLevel],
                 reference: Mapping[str, str], segmenting_axis: str, level_axis: Mapping[str, str]) -> None:
        _deprecated("TriaxialAnalysis")
        part = TriaxialPart(tuple(levels), dict(reference), segmenting_axis, dict(level_axis),
                            {n: red for n, _, red in channels if red is not None})
        method = channels[0][1].method if channels else "random"
        VreResult.__init__(self, method, Conditions(), (), provenance={},
                           axis_results=tuple((n, r) for n, r, _ in channels), triaxial=part)

    if not TYPE_CHECKING:
        def __getattribute__(self, name: str) -> Any:
            if name == "levels":
                warnings.warn("TriaxialAnalysis.levels is deprecated and will be removed in the next release: "
                              "read reference_levels", DeprecationWarning, stacklevel=2)
                return object.__getattribute__(self, "triaxial").reference_levels
            return super().__getattribute__(name)

    def to_dict(self, provenance: Mapping[str, Any] | None = None) -> dict[str, Any]:
        doc = super().to_dict()
        doc["provenance"] = dict(provenance or {})
        return doc
