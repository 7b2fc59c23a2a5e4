"""One result for one DUT axis or several (issue 31): what :class:`vrelab.results.VreResult` adds
to read a test by axis.

A result is an ordered set of DUT axes, each with its levels, VREs, VRCs and fits. A single-axis
result is the one-axis case: it holds them itself and ``axes`` is ``{its axis: itself}``. A result
of several axes (a triaxial test or analysis: ``axis_results``, in order) holds each axis's own
:class:`~vrelab.results.VreResult`, and optionally the triaxial part (``triaxial``: the
reference's vector levels, the simulation's vector field and vibration, :class:`vrelab.triaxial.
result.TriaxialPart`). Its per-axis attributes (``levels``, ``fits``, ``warnings``, ``noise``,
``conditions``) read through to its only axis; with several axes they are refused (an
AttributeError naming the axes), never one axis's numbers silently taken for the test's.
``method``, ``kind`` and ``provenance`` are the test's own.

Light on purpose (no numpy): :mod:`vrelab.results` builds on it and is imported by every command.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from vrelab._display import per_axis

if TYPE_CHECKING:
    from vrelab.results import VreResult
    from vrelab.triaxial.analyze import TriaxialLevel
    from vrelab.triaxial.result import TriaxialPart

# the attributes one DUT axis holds (a result of several axes reads them from its axes)
PER_AXIS = frozenset({"levels", "fits", "warnings", "noise", "conditions"})


def _several(axes: tuple[tuple[str, VreResult], ...], name: str) -> str:
    """Why a result of several axes does not read ``name`` (one axis's attribute)."""
    return (f"this result holds {len(axes)} DUT axes ({', '.join(a for a, _ in axes)}): read result.axes[axis].{name}"
            + (" (the reference's levels are result.reference_levels)" if name == "levels" else ""))


class ByAxis:
    """Mixin of :class:`~vrelab.results.VreResult`: the reading by axis (the module docstring)."""

    if TYPE_CHECKING:
        axis_results: tuple[tuple[str, VreResult], ...]
        triaxial: TriaxialPart | None
        method: str
        kind: str
        provenance: Mapping[str, Any]
    else:
        def __getattribute__(self, name: str) -> Any:
            if name in PER_AXIS:
                axes = object.__getattribute__(self, "axis_results")
                if len(axes) == 1:
                    return getattr(axes[0][1], name)
                if axes:
                    raise AttributeError(_several(axes, name))
            return object.__getattribute__(self, name)

        def __getattr__(self, name: str) -> Any:
            if name in PER_AXIS:  # (Python calls this after __getattribute__ refused: the same words)
                raise AttributeError(_several(object.__getattribute__(self, "axis_results"), name))
            # TriaxialTest's and TriaxialAnalysis's own attributes (excitation, levels_g, static_g,
            # record_path, reference, segmenting_axis, level_axis): read on the triaxial part
            part = object.__getattribute__(self, "triaxial") if not name.startswith("__") else None
            if part is not None and name in part.FORMER:
                warnings.warn(f"result.{name} is deprecated and will be removed in the next release: read "
                              f"result.triaxial.{name}", DeprecationWarning, stacklevel=2)
                return getattr(part, name)
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def __eq__(self, other: object) -> bool:
        # the fields as stored: a result of several axes refuses to read its per-axis ones
        if type(other) is not type(self):
            return NotImplemented
        names = list(self.__dataclass_fields__)  # type: ignore[attr-defined]  # the mixin is a dataclass's
        return tuple(object.__getattribute__(self, n) for n in names) == tuple(
            object.__getattribute__(other, n) for n in names)

    @classmethod
    def of_axes(cls, results: Mapping[str, VreResult], *, kind: str | None = None,
                provenance: Mapping[str, Any] | None = None, triaxial: TriaxialPart | None = None) -> VreResult:
        """One result of the DUT axes ``results`` (axis -> its single-axis result, in order), with
        the triaxial part ``triaxial``: ``method`` the axes' (one method), ``kind`` the axes'
        unless given, ``provenance`` the test's (default the first axis's).

        Examples
        --------
        Two DUT axes of one test, read by axis; a result of one axis reads as that axis's:

        >>> from vrelab import Conditions, Estimate, LevelResult, VreResult
        >>> level = LevelResult(rms_g=1.0, vre=Estimate(1e-4, 3e-5))
        >>> x = VreResult("random", Conditions(axis="x"), (level,))
        >>> z = VreResult("random", Conditions(axis="z"), (level, level))
        >>> both = VreResult.of_axes({"x": x, "z": z})
        >>> list(both.axes), len(both.axes["z"].levels)
        (['x', 'z'], 2)
        >>> len(VreResult.of_axes({"z": z}).levels)
        2
        """
        if not results:
            raise ValueError("a result needs at least one DUT axis")
        first = next(iter(results.values()))
        methods = {r.method for r in results.values()}
        if len(methods) != 1:
            raise ValueError(f"the DUT axes of one result share one method, got {sorted(methods)}")
        # the per-axis fields of a result of several axes are never read (the module docstring);
        # cls is VreResult, whose fields mypy does not see on the mixin
        return cls(first.method, first.conditions, (),  # type: ignore[call-arg,return-value]
                   kind=first.kind if kind is None else kind,
                   provenance=dict(first.provenance if provenance is None else provenance),
                   axis_results=tuple(results.items()), triaxial=triaxial)

    @property
    def axes(self) -> dict[str, VreResult]:
        """The result by DUT axis, in order: a single-axis result under its ``conditions.axis``
        (``"dut"`` when unknown), so every result of :func:`vrelab.simulate` and
        :func:`vrelab.analyze` reads alike."""
        if self.axis_results:
            return dict(self.axis_results)
        own: VreResult = self  # type: ignore[assignment]  # the mixin is VreResult's
        return {own.conditions.axis or "dut": own}

    @property
    def reference_levels(self) -> tuple[TriaxialLevel, ...]:
        """A triaxial analysis's levels of the reference: each level's total and per-axis rms
        and cross-spectrum (:class:`vrelab.triaxial.analyze.TriaxialLevel`); empty for a result
        without a triaxial reference."""
        return () if self.triaxial is None else self.triaxial.reference_levels

    @property
    def channels(self) -> tuple[tuple[str, VreResult, Any], ...]:
        """Deprecated (one release): ``(axis, result, reduction)`` per DUT axis, as the former
        ``TriaxialAnalysis.channels``; read :attr:`axes` (and ``triaxial.reductions``)."""
        warnings.warn("result.channels is deprecated and will be removed in the next release: read result.axes "
                      "(axis -> VreResult; the reductions are result.triaxial.reductions)", DeprecationWarning,
                      stacklevel=2)
        red = {} if self.triaxial is None else dict(self.triaxial.reductions)
        return tuple((a, r, red.get(a)) for a, r in self.axes.items())

    def axes_fields(self) -> list[tuple[str, Any]]:
        """What a repr of a result of several axes shows: the test's, the triaxial part's, and
        each axis's fits (else its count of levels)."""
        own = [("kind", self.kind), ("method", self.method)]
        part = [] if self.triaxial is None else self.triaxial.display_fields()
        return own + part + per_axis(self.axes)[0]

    def axes_rows(self) -> list[dict[str, Any]] | None:
        """One row per axis and level (the axis first) for a result of several axes; a
        single-axis result's own rows otherwise."""
        return per_axis(self.axes)[1] if self.axis_results else None

    def axes_document(self) -> dict[str, Any]:
        """``to_dict()`` of a result of several axes: the triaxial part's document, else the
        document of several DUT channels (:func:`vrelab.results.channels_to_dict`)."""
        if self.triaxial is not None:
            return self.triaxial.document(self.axis_results, self.method, self.provenance)
        return channels_to_dict(self.axis_results, self.provenance)


def channels_to_dict(results: Sequence[tuple[str, VreResult]], provenance: Mapping[str, Any]) -> dict[str, Any]:
    """The document of several DUT channels of one file (the CLI reference): ``channels``: [{``channel``,
    ``levels``, ``fit``, ...}], each a whole :meth:`VreResult.to_dict`; the file's provenance.

    Examples
    --------
    >>> from vrelab import Conditions, Estimate, LevelResult, VreResult
    >>> from vrelab.results import channels_to_dict
    >>> result = VreResult("sine", Conditions(), (LevelResult(rms_g=1.0, vre=Estimate(1e-4, 3e-5)),))
    >>> doc = channels_to_dict([("sn1", result), ("sn2", result)], {"tool": "example"})
    >>> [c["channel"] for c in doc["channels"]]
    ['sn1', 'sn2']
    """
    chans = [{"channel": name, **result.to_dict()} for name, result in results]
    return {"kind": "measurement", "method": chans[0]["method"] if chans else None, "channels": chans,
            "provenance": dict(provenance)}
