""":func:`compare`: which part, range and output rate holds a VRE or tilt budget in a vibration.

Each candidate is one :func:`vrelab.predict` per static field over the levels (the analytic
model, with the parameters' uncertainties carried to the VRE), evaluated as a point of the
sweep's engine (:func:`vrelab.sweep.engine.run_points`: serial, a process pool or Dask, the
same numbers), then judged against the budget with its expanded uncertainty
(:mod:`vrelab.comparison.results`).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

from vrelab.comparison.candidates import (
    Budget,
    Candidate,
    default_candidates,
    parse_budget,
    parse_candidates,
    static_fields,
)
from vrelab.comparison.results import CandidateRow, Comparison, Point, ranked
from vrelab.gum import CONVENTIONAL_K

if TYPE_CHECKING:
    from vrelab.profiles import Profile
    from vrelab.sensor import Sensor

# the point function the engine imports in each worker
POINT_FUNCTION = "vrelab.comparison.run:candidate_point"


def load_candidate(params: Mapping[str, Any]) -> Sensor:
    """A candidate's sensor (the point's ``part``, ``range_g``, ``odr_hz``, ``axis``; the mount as
    the user's values)."""
    from vrelab.sensor import load_sensor

    mount = params.get("mount")
    overrides = {"mount_fn_hz": mount[0], "mount_q": mount[1]} if mount else None
    return load_sensor(params["part"], range_g=params.get("range_g"), axis=params.get("axis"),
                       odr_hz=params.get("odr_hz"), overrides=overrides)


@functools.lru_cache(maxsize=8)
def _environment(text: str) -> Profile:
    from vrelab.profiles import parse_profile

    return parse_profile(text)


def candidate_point(params: Mapping[str, Any], seed: np.random.SeedSequence) -> dict[str, float]:
    """One candidate at every level and static field (``seed`` unused: no randomness).

    Returns the engine's plain numbers, keyed ``"j.i.name"`` (static field j, level i):
    ``vre_g``, ``u_vre_g`` (NaN: none stated), ``share.<mechanism>``, ``u.<source>``. A level
    whose prediction is not valid raises ``ValueError`` with the prediction's reasons: the
    engine records it as the candidate's failure, its reason the row's.

    Examples
    --------
    The ideal part at ±2 g, axis up, in flat 20-2000 Hz at 2 g rms: all of its VRE is the clip's
    censored Gaussian mean shift (:func:`vrelab.models.design.clip_vre`, -337.0 mg), and it
    states no u:

    >>> import numpy as np
    >>> from vrelab.comparison.run import candidate_point
    >>> from vrelab.models.design import clip_vre
    >>> params = {"part": "ideal", "range_g": 2.0, "environment": "flat:20-2000", "levels": [2.0],
    ...           "static_g": [1.0]}
    >>> values = candidate_point(params, np.random.SeedSequence(0))
    >>> print(f"{values['0.0.vre_g'] * 1e3:.1f} mg, clip {values['0.0.share.clip_g'] * 1e3:.1f} mg, "
    ...       f"u {values['0.0.u_vre_g']}; closed form {clip_vre(1.0, 2.0, -2.0, 2.0) * 1e3:.1f} mg")
    -337.0 mg, clip -337.0 mg, u nan; closed form -337.0 mg
    """
    from vrelab.prediction import predict

    sensor = load_candidate(params)
    env = params["environment"]
    excitation = _environment(env) if isinstance(env, str) else env
    out: dict[str, float] = {}
    reasons: list[str] = []
    for j, g0 in enumerate(params["static_g"]):
        pred = predict(sensor, excitation, list(params["levels"]), static_g=float(g0))
        for i, lv in enumerate(pred.levels):
            key = f"{j}.{i}."
            out[key + "vre_g"] = lv.vre_g
            out[key + "u_vre_g"] = math.nan if lv.u_vre_g is None else lv.u_vre_g
            out.update({f"{key}share.{k}": v for k, v in lv.shares.items()})
            out.update({f"{key}u.{k}": v for k, v in (lv.u_sources_g or {}).items()})
            if not lv.valid:
                reasons += [f"{lv.rms_g:g} g rms, static {g0:.4g} g: {n}" for n in lv.notes] or [
                    f"{lv.rms_g:g} g rms, static {g0:.4g} g: not valid"]
    if reasons:
        raise ValueError("prediction not valid: " + "; ".join(dict.fromkeys(reasons)))
    return out


# The parts exact by definition: the ideal preset is rails at exactly ±range and the polynomial
# given, no part's unknown numbers, so its prediction's u is 0. Any other part whose prediction
# states no u (a sensor file without [uncertainty] or covariance) is no claim against a budget.
EXACT_PARTS = ("ideal",)
NO_U = ("its prediction states no u (a sensor file with no [uncertainty] or covariance: its numbers are not "
        "known exactly): neither a pass nor a fail can be claimed; give its parameters' u")


def _points(values: Mapping[str, float], statics: Sequence[float], levels: Sequence[float],
            budget: Budget, exact: bool) -> tuple[Point, ...]:
    out = []
    for j, g0 in enumerate(statics):
        for i, rms in enumerate(levels):
            key = f"{j}.{i}."
            u = values[key + "u_vre_g"]
            if exact and math.isnan(u):
                u = 0.0
            shares = {k[len(key) + 6:]: v for k, v in values.items() if k.startswith(key + "share.")}
            sources = {k[len(key) + 2:]: v for k, v in values.items() if k.startswith(key + "u.")}
            out.append(Point(float(rms), float(g0), values[key + "vre_g"], None if math.isnan(u) else u,
                             budget.limit_g(g0), shares, sources))
    return tuple(out)


def _verdict(points: Sequence[Point]) -> str:
    if any(not (math.isfinite(p.high) and math.isfinite(p.low)) for p in points):
        return "invalid"
    if any(p.u_vre_g is None for p in points):
        return "undecided"  # no U: the margins are no claim (NO_U)
    if all(p.high <= 1.0 for p in points):
        return "pass"
    return "fail" if any(p.low > 1.0 for p in points) else "undecided"


def _candidates(given: str | Sequence[Candidate | str] | None) -> list[Candidate]:
    if given is None:
        return default_candidates()
    if isinstance(given, str):
        return parse_candidates(given)
    out: list[Candidate] = []
    for c in given:
        out += parse_candidates(c) if isinstance(c, str) else [c]
    return out


def compare(
    environment: str | Profile,
    levels: float | Sequence[float],
    budget: str | Budget,
    *,
    static_g: float = 1.0,
    tilt_range_deg: tuple[float, float] | None = None,
    candidates: str | Sequence[Candidate | str] | None = None,
    mount: tuple[float, float] | None = None,
    workers: int | str | None = None,
) -> Comparison:
    """Rank parts, ranges and output rates against a VRE or tilt budget in one vibration environment.

    Parameters
    ----------
    environment : str or RandomProfile
        A named environment (``vrelab environment list``), a profile file or a profile string
        (``flat:20-2000``, ``F:P,F:P``, ``+sine:...`` tones).
    levels : float or sequence of float
        The environment's level(s) [g rms], each > 0.
    budget : str or Budget
        ``"1mg"`` (a VRE: g, mg, ug) or ``"0.05deg"`` (a tilt error).
    static_g : float
        The static field along the sensed axis [g] (1: axis up), unless ``tilt_range_deg``.
    tilt_range_deg : (a, b), optional
        The axis's tilts [deg]: judged at the range's ends, middle and 0 where inside it
        (``static = sin θ``), the worst deciding.
    candidates : str or list, optional
        ``"adxl355:2g:4000,my_part.toml:8:500"`` (``PART[:RANGE[:ODR[:AXIS]]]``) or a list of
        :class:`~vrelab.comparison.candidates.Candidate`; default: every preset with listed
        ranges, at each range and output rate.
    mount : (fn_hz, q), optional
        The PCB or bracket every candidate sits on (:class:`vrelab.sensor.configs.Mount`).
    workers : int or str, optional
        Processes (an int), or a Dask scheduler's address (a str, ``"local:N"``): the sweep's
        backends (:func:`vrelab.sweep.backends.make_backend`); default serial.

    Returns
    -------
    Comparison
        ``rows`` ranked (pass, undecided, fail, then invalid; by ``(|VRE| + U)/budget`` at the
        worst level and static field), ``best`` (the first that passes, or None), ``to_dict``.

    Notes
    -----
    The guard: with ``U = 2·u_vre_g`` (k = 2, the prediction's standard u from the sensor's
    stated and assumed parameter uncertainties and the model bound), a candidate passes when
    ``|VRE| + U ≤ budget`` at every level and static field, fails when ``|VRE| − U > budget`` at
    one, and is undecided otherwise. A candidate whose prediction states no u (a sensor file with
    no ``[uncertainty]`` or covariance) is undecided, with the reason: only the ``ideal`` part is
    exact by definition (U = 0). A candidate whose prediction is not valid at some level is
    "invalid" with the reason, ranked last, never a pass. A tilt budget ``δθ`` is the VRE budget
    ``g·cos θ·δθ`` at each static field (:class:`~vrelab.comparison.candidates.Budget`).

    Examples
    --------
    Two ranges of the ideal part (exact by definition: U = 0) on an axis tilted 30° (static 0.5 g) in
    flat 20-2000 Hz at 2 g rms, against a tilt budget of 0.05° (a VRE of 0.756 mg there). The
    VREs are the clip's censored Gaussian mean shifts (:func:`vrelab.models.design.clip_vre`:
    -161.2 mg at ±2 g, -0.037 mg at ±8 g); ±8 g holds the budget with a tilt error of -0.0025°:

    >>> import vrelab
    >>> result = vrelab.compare("flat:20-2000", [2.0], "0.05deg", static_g=0.5, candidates="ideal:2g,ideal:8g")
    >>> for row in result.rows:
    ...     print(f"{row.candidate.label}: {row.verdict}, VRE {row.worst.vre_g * 1e3:.3f} mg")
    ideal ±8 g no ODR: pass, VRE -0.037 mg
    ideal ±2 g no ODR: fail, VRE -161.160 mg
    >>> tilt, expanded = result.best.tilt_error_deg
    >>> print(f"{result.best.candidate.spec}: tilt error {tilt:.4f} ± {expanded:.4f} deg")
    ideal:8g: tilt error -0.0025 ± 0.0000 deg
    """
    from vrelab.prediction.checks import mount_note
    from vrelab.profiles import parse_profile
    from vrelab.sweep.backends import make_backend
    from vrelab.sweep.engine import run_points

    level_list = [float(x) for x in np.atleast_1d(np.asarray(levels, dtype=float))]
    if not level_list or any(not (math.isfinite(x) and x > 0) for x in level_list):
        raise ValueError(f"levels must be numbers > 0 [g rms], got {levels!r}")
    profile = parse_profile(environment) if isinstance(environment, str) else environment
    judged_by = budget if isinstance(budget, Budget) else _budget_of(str(budget))
    statics = static_fields(static_g, tilt_range_deg)
    for g0 in statics:
        judged_by.limit_g(g0)  # a tilt budget on a vertical axis: refused before anything runs
    chosen = _candidates(candidates)
    if not chosen:
        raise ValueError("no candidates to compare: give at least one PART[:RANGE[:ODR]]")
    base: dict[str, Any] = {"environment": environment, "levels": level_list, "static_g": statics,
                            "mount": tuple(mount) if mount else None}
    params = [{**base, "part": c.part, "range_g": c.range_g, "odr_hz": c.odr_hz, "axis": c.axis} for c in chosen]
    sensors = [load_candidate(p) for p in params]  # bad parts, ranges, rates and mounts refused here, in one line
    # each candidate as loaded: the file's default range and rate filled in, so its label says them
    chosen = [dataclasses.replace(c, range_g=float(s.range_g), odr_hz=s.odr_hz) for c, s in zip(chosen, sensors)]
    items = [(k, p, (0, (k,))) for k, p in enumerate(params)]
    backend_args = (workers, None) if not isinstance(workers, str) else (None, workers)
    with make_backend(*backend_args) as backend:
        records = run_points(POINT_FUNCTION, items, backend, retries=0)
    rows = []
    for k, (c, s) in enumerate(zip(chosen, sensors)):
        note = mount_note(s, profile.band)
        rec = records[k]
        if rec.status != "ok":
            reason = (rec.error or "failed").removeprefix("ValueError: ")
            rows.append(CandidateRow(c, "invalid", reason=reason, notes=(note,) if note else ()))
            continue
        pts = _points(rec.values, statics, level_list, judged_by, c.part in EXACT_PARTS)
        verdict = _verdict(pts)
        unstated = verdict == "undecided" and any(p.u_vre_g is None for p in pts)
        rows.append(CandidateRow(c, verdict, pts, reason=NO_U if unstated else None, notes=(note,) if note else ()))
    conditions = {"environment": environment if isinstance(environment, str) else profile.name,
                  "band_hz": list(profile.band), "levels_g": level_list, "static_g": statics,
                  "tilt_range_deg": list(tilt_range_deg) if tilt_range_deg else None,
                  "budget": judged_by.text, "budget_kind": judged_by.kind, "budget_value": judged_by.value,
                  "mount": {"fn_hz": mount[0], "q": mount[1]} if mount else None, "coverage_k": CONVENTIONAL_K}
    return Comparison(conditions, ranked(rows))


def _budget_of(text: str) -> Budget:
    t = text.strip().lower()
    return parse_budget(None, text) if t.endswith("deg") else parse_budget(text, None)
