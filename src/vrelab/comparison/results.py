"""What :func:`vrelab.compare` returns: one :class:`CandidateRow` a candidate, ranked, in a
:class:`Comparison`."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Mapping, Sequence

from vrelab._format import finite_or_none
from vrelab.gum import CONVENTIONAL_K
from vrelab.results import level_vrc

if TYPE_CHECKING:
    from vrelab.comparison.candidates import Candidate

# verdicts in rank order: a pass first, an invalid prediction last (never ranked as a pass)
VERDICTS = ("pass", "undecided", "fail", "invalid")


@dataclass(frozen=True)
class Point:
    """One candidate at one level and one static field: its VRE [g] with its standard u, and the
    budget [g] at that static field.

    Examples
    --------
    The ADXL355 at ±8 g axis up in flat 20-2000 Hz at 2 g rms, as :func:`vrelab.predict` puts
    it (VRE 0.17 mg, u 3.3 mg: its k2 is only bounded by an assumed range), against 1 mg: the
    guarded margin is above 1 and the unguarded one below, so the budget is neither held nor
    broken whatever the u ("undecided"):

    >>> from vrelab.comparison.results import Point
    >>> point = Point(rms_g=2.0, static_g=1.0, vre_g=0.174e-3, u_vre_g=3.335e-3, limit_g=1e-3)
    >>> print(f"U {point.expanded_g * 1e3:.2f} mg, margins {point.high:.2f} and {point.low:.2f}")
    U 6.67 mg, margins 6.84 and -6.50
    """

    rms_g: float
    static_g: float
    vre_g: float
    u_vre_g: float | None  # None: the sensor states no u (0.0: exact by definition, the ideal part)
    limit_g: float
    shares: Mapping[str, float] = field(default_factory=dict)
    u_sources_g: Mapping[str, float] = field(default_factory=dict)

    @property
    def expanded_g(self) -> float:
        """U = k·u (k = 2) [g]. Where the sensor states no u this is 0 for the margins alone (they
        are then the unguarded ``|VRE|/budget``, which ranks the row): such a point is no claim
        either way, and :func:`vrelab.compare` judges it "undecided"; ``to_dict`` gives U null."""
        return CONVENTIONAL_K * (self.u_vre_g or 0.0)

    @property
    def high(self) -> float:
        """(|VRE| + U) / budget: the guarded margin (≤ 1: within the budget whatever the u)."""
        return (abs(self.vre_g) + self.expanded_g) / self.limit_g

    @property
    def low(self) -> float:
        """(|VRE| − U) / budget (> 1: beyond the budget whatever the u)."""
        return (abs(self.vre_g) - self.expanded_g) / self.limit_g

    def to_dict(self) -> dict[str, Any]:
        return {"rms_g": self.rms_g, "static_g": self.static_g, "vre_g": finite_or_none(self.vre_g),
                "u_vre_g": finite_or_none(self.u_vre_g) if self.u_vre_g is not None else None,
                "U_vre_g": finite_or_none(self.expanded_g) if self.u_vre_g is not None else None,
                "budget_g": finite_or_none(self.limit_g),
                "margin": finite_or_none(self.high)}


def dominant(values: Mapping[str, float]) -> tuple[str | None, float | None]:
    """The name and value of the largest |value| (None, None for none).

    Examples
    --------
    >>> from vrelab.comparison.results import dominant
    >>> dominant({"clip_g": -0.337, "nonlinearity_g": 0.002})
    ('clip_g', -0.337)
    >>> dominant({})
    (None, None)
    """
    if not values:
        return None, None
    name = max(values, key=lambda k: abs(values[k]))
    return name, values[name]


# the shares that are parts of another (each rail of clip_g; each cross term of cross_g)
_PARTS = ("clip_low_g", "clip_high_g")


@dataclass(frozen=True)
class CandidateRow:
    """One candidate's answer: at its worst point (the largest guarded margin over the levels and
    static fields) its VRE, U (k = 2), VRC, tilt error, the dominant mechanism and uncertainty
    source; its ``verdict`` against the budget ("pass": VRE + U ≤ budget at every point; "fail":
    VRE − U > budget at some point; "undecided" otherwise, or where no u is stated, ``reason``
    then saying so; "invalid": the prediction is not valid, ``reason`` says why) and every point.

    Examples
    --------
    The ideal part at ±2 g on an axis tilted 30° (static 0.5 g) in Gaussian vibration of 0.5
    and 1 g rms: its VRE is the clip's censored mean shift, -0.19 and -27.3 mg
    (:func:`vrelab.models.design.clip_vre`), against a tilt budget of 0.05°, a VRE of 0.756 mg
    there. The worst point is 1 g rms: 36 times the budget, a tilt error of about -1.8°:

    >>> from vrelab.comparison.candidates import Candidate
    >>> from vrelab.comparison.results import CandidateRow, Point
    >>> from vrelab.models.design import clip_vre
    >>> points = tuple(Point(rms, 0.5, clip_vre(0.5, rms, -2.0, 2.0), None, 0.756e-3,
    ...                      shares={"clip_g": clip_vre(0.5, rms, -2.0, 2.0)}) for rms in (0.5, 1.0))
    >>> row = CandidateRow(Candidate("ideal", 2.0), "fail", points)
    >>> tilt, _ = row.tilt_error_deg
    >>> print(f"{row.worst.rms_g:g} g rms: VRE {row.worst.vre_g * 1e3:.1f} mg, margin {row.margin:.1f}, "
    ...       f"tilt {tilt:.1f} deg, {row.mechanism}")
    1 g rms: VRE -27.3 mg, margin 36.1, tilt -1.8 deg, clip
    """

    candidate: Candidate
    verdict: str
    points: tuple[Point, ...] = ()
    reason: str | None = None
    notes: tuple[str, ...] = ()

    @property
    def valid(self) -> bool:
        return self.verdict != "invalid"

    @property
    def worst(self) -> Point | None:
        return max(self.points, key=lambda p: p.high) if self.points else None

    @property
    def margin(self) -> float | None:
        """(|VRE| + U)/budget at the worst point: what the rows are ranked by (None: invalid)."""
        w = self.worst
        return w.high if w is not None else None

    @property
    def vrc_ug_per_g2(self) -> float | None:
        """The VRE per rms² at the worst point [µg/g²] (:func:`vrelab.results.level_vrc`)."""
        w = self.worst
        return None if w is None else level_vrc(w.vre_g, w.rms_g)[0]

    @property
    def tilt_error_deg(self) -> tuple[float, float] | None:
        """(tilt error, its U) [deg] at the worst point, ``δ/(g·cos θ)``
        (:class:`~vrelab.comparison.candidates.Budget`); None on a vertical axis (|g0| near 1 g)."""
        from vrelab.comparison.candidates import Budget
        from vrelab.models.design import NEAR_VERTICAL_G

        w = self.worst
        if w is None or abs(w.static_g) > 1.0 - NEAR_VERTICAL_G:
            return None
        expanded = w.expanded_g if w.u_vre_g is not None else math.nan  # no u stated: no U
        return Budget.tilt_deg(w.vre_g, w.static_g), Budget.tilt_deg(expanded, w.static_g)

    @property
    def mechanism(self) -> str | None:
        """The largest share of the VRE at the worst point (``clip``, ``nonlinearity``, ``overrange``, ``cross``)."""
        w = self.worst
        if w is None:
            return None
        name, _ = dominant({k: v for k, v in w.shares.items() if k not in _PARTS and not k.startswith("cross_k")})
        return name[:-2] if name and name.endswith("_g") else name

    @property
    def dominant_u(self) -> tuple[str, float] | None:
        """The largest uncertainty source at the worst point and its standard u [g] (None: no u stated)."""
        w = self.worst
        name, value = dominant(dict(w.u_sources_g)) if w is not None else (None, None)
        return None if name is None or value is None else (name, value)

    def to_dict(self) -> dict[str, Any]:
        w = self.worst
        tilt = self.tilt_error_deg
        du = self.dominant_u
        return {
            "candidate": self.candidate.spec, "label": self.candidate.label, "part": self.candidate.part,
            "range_g": self.candidate.range_g, "odr_hz": self.candidate.odr_hz, "axis": self.candidate.axis,
            "verdict": self.verdict, "valid": self.valid, "reason": self.reason,
            "vre_g": finite_or_none(w.vre_g) if w else None,
            "U_vre_g": finite_or_none(w.expanded_g) if w and w.u_vre_g is not None else None, "k": CONVENTIONAL_K,
            "vrc_ug_per_g2": finite_or_none(self.vrc_ug_per_g2) if w else None,
            "tilt_error_deg": finite_or_none(tilt[0]) if tilt else None,
            "U_tilt_error_deg": finite_or_none(tilt[1]) if tilt else None,
            "margin": finite_or_none(self.margin) if w else None,
            "worst": {"rms_g": w.rms_g, "static_g": w.static_g} if w else None,
            "dominant_mechanism": self.mechanism,
            "dominant_u": {"source": du[0], "u_vre_g": finite_or_none(du[1])} if du else None,
            "points": [p.to_dict() for p in self.points],
            "notes": list(self.notes),
        }


def ranked(rows: Sequence[CandidateRow]) -> tuple[CandidateRow, ...]:
    """Pass, undecided, fail, invalid; within each by the guarded margin (smaller first), then by label.

    Examples
    --------
    Four ranges of one part against 1 mg at 2 g rms, given in any order (VREs without a u):

    >>> from vrelab.comparison.candidates import Candidate
    >>> from vrelab.comparison.results import CandidateRow, Point, ranked
    >>> def row(range_g, vre_mg, verdict):
    ...     points = (Point(2.0, 1.0, vre_mg * 1e-3, None, 1e-3),) if vre_mg is not None else ()
    ...     return CandidateRow(Candidate("adxl355", range_g, 4000.0), verdict, points)
    >>> rows = [row(2.0, -3.0, "fail"), row(4.0, -0.5, "pass"), row(8.0, -0.2, "pass"), row(16.0, None, "invalid")]
    >>> for r in ranked(rows):
    ...     print(r.candidate.label, r.verdict)
    adxl355 ±8 g 4000 Hz pass
    adxl355 ±4 g 4000 Hz pass
    adxl355 ±2 g 4000 Hz fail
    adxl355 ±16 g 4000 Hz invalid
    """
    return tuple(sorted(rows, key=lambda r: (VERDICTS.index(r.verdict),
                                             r.margin if r.margin is not None and math.isfinite(r.margin) else math.inf,
                                             r.candidate.label)))


@dataclass(frozen=True)
class Comparison:
    """Candidates ranked against a budget in one environment (:func:`vrelab.compare`).

    ``rows`` in rank order (:func:`ranked`); ``conditions``: the environment, levels, static
    fields, budget and mount they were judged at; ``notes``: what applies to every row.

    Examples
    --------
    Two ranges of the ideal part, axis up in flat 20-2000 Hz at 2 g rms, against 1 mg:

    >>> import vrelab
    >>> comparison = vrelab.compare("flat:20-2000", [2.0], "1mg", candidates="ideal:2g,ideal:8g")
    >>> print(comparison.best.candidate.label, "|", comparison.to_dict()["counts"])
    ideal ±8 g no ODR | {'pass': 1, 'undecided': 0, 'fail': 1, 'invalid': 0}
    >>> print(comparison.conditions["budget"], comparison.conditions["band_hz"])
    VRE 1 mg [20.0, 2000.0]
    """

    conditions: Mapping[str, Any]
    rows: tuple[CandidateRow, ...]
    notes: tuple[str, ...] = ()

    @property
    def best(self) -> CandidateRow | None:
        """The first-ranked row that passes; None where none does (no candidate is shown to hold the budget)."""
        return next((r for r in self.rows if r.verdict == "pass"), None)

    def to_dict(self) -> dict[str, Any]:
        best = self.best
        return {"kind": "comparison", "conditions": dict(self.conditions),
                "best": best.candidate.spec if best else None,
                "counts": {v: sum(r.verdict == v for r in self.rows) for v in VERDICTS},
                "rows": [r.to_dict() for r in self.rows], "notes": list(self.notes)}

    def to_dataframe(self) -> Any:
        """One row a candidate (rank order) with the scalar columns of :meth:`CandidateRow.to_dict`
        (pandas: installed with the ``sweep`` extra's xarray)."""
        import importlib

        try:  # pandas is no dependency of vrelab (xarray brings it), nor typed here
            pd = importlib.import_module("pandas")
        except ImportError:
            raise ValueError("to_dataframe needs pandas (pip install pandas, or vrelab[sweep])") from None
        rows = []
        for r in self.rows:
            d = r.to_dict()
            du = d.pop("dominant_u") or {}
            d.pop("points"), d.pop("worst")
            d["notes"] = "; ".join(d["notes"])
            d["dominant_u"], d["dominant_u_g"] = du.get("source"), du.get("u_vre_g")
            rows.append(d)
        return pd.DataFrame(rows)

    def __repr__(self) -> str:
        counts = ", ".join(f"{sum(r.verdict == v for r in self.rows)} {v}" for v in VERDICTS)
        best = self.best
        return (f"<Comparison {len(self.rows)} candidates against {self.conditions.get('budget')}: {counts}; "
                f"best {best.candidate.label if best else 'none'}>")
