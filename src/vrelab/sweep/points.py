"""The built-in point kinds: each is ``f(params, seed) -> {name: float}`` (see the engine).

``model``: closed forms only (physics §1.1-1.3); about 0.2 ms a point, a few ms with the
  resonance integral of a random band:
  the vibration at the proof mass has rms ``rms_mass = rms_g·|H(freq_hz)|`` for a sine, or
  ``rms_g·sqrt(mean |H|² over [f_lo_hz, f_hi_hz])`` for a flat random band, with
  ``H = 1/(1 - r² + j·r/q)``, ``r = f/fn_hz`` (no resonance when ``fn_hz`` is not given);
  ``vre_clip_g``, ``vre_poly_g``: the ideal sensor's chain (polynomial, then ``offset_g``,
  then rails ±``range_g``, none with ``clip_kind = "none"``) as its stages, each one's own
  mean shift summed as ``predict`` does (:func:`vrelab.prediction.memoryless_level`): the
  polynomial's share rectifies around ``static_g``, the rails' is what they add to it, and
  ``vre_g`` = their sum is the exact mean of the one memoryless map; all referred to the
  vibration-off reading ``vibration_off_g`` = ``clip(P(static_g) + offset_g)`` (physics §1.5);
  ``tilt_error_deg`` = :func:`vrelab.models.design.tilt_error_from_static_deg` for an axis at
  tilt ``asin(static_g)`` (``asin(g0 + δ) - asin(g0)``; NaN where undefined, near ±1 g).
  The rails here see the proof-mass motion: this kind has no output filter (``predict`` does).

``predict``: :func:`vrelab.prediction.predict` on a :func:`vrelab.sensor.load_sensor` sensor at one
  level of a ``profile`` (or a sine at ``freq_hz``); a ``profile`` is any string of
  :func:`vrelab.profiles.parse_profile`, a named environment or sine-on-random
  (``"navmat-p9492+sine:120:0.5"``, or a TOML file with ``[[tone]]`` tables) included.

``simulate``: the simulated shaker test, :func:`vrelab.shaker.run_random_test` (or
  ``run_sine_test`` with ``freq_hz``), one level, seeded from the point's seed; ``seconds``
  (top level of the file), ``baseline_s`` and ``settle_s`` are passed when given, else the
  shaker's defaults apply.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
from typing import TYPE_CHECKING, Any, Mapping

import numpy as np

from vrelab.models.kinds import DEFAULT_CLIP_KIND

if TYPE_CHECKING:
    from vrelab.profiles import Profile
    from vrelab.sensor.base import Stage
    from vrelab.sensor.loader import Sensor
    from vrelab.simulation.plan import TestPlan


def _rms_at_proof_mass(rms_g: float, params: Mapping[str, Any]) -> float:
    """rms of the proof-mass motion: through the resonance at the sine frequency, or over the
    flat random band (``effective_rms`` of a unit-variance flat PSD); unchanged without fn_hz."""
    from vrelab.models.dynamics import effective_rms, resonator, rms_through

    fn, q = params.get("fn_hz"), params.get("q")
    if fn is None and q is None:
        return rms_g
    if fn is None or q is None:
        raise ValueError("fn_hz and q go together: give both or neither")
    h = resonator(fn, q)
    if params.get("shape", "gaussian") == "sine":
        if "freq_hz" not in params:
            raise ValueError("freq_hz is needed with fn_hz for a sine")
        return float(rms_through(params["freq_hz"], rms_g, [h]))
    lo, hi = params.get("f_lo_hz"), params.get("f_hi_hz")
    if lo is None or hi is None:
        raise ValueError("f_lo_hz and f_hi_hz (the flat random band) are needed with fn_hz")
    s0 = 1.0 / (hi - lo)  # flat PSD of unit variance over [lo, hi]
    return rms_g * effective_rms(([lo, hi], [s0, s0]), [h], lo, hi)


def _tilt_deg(vre_g: float, static_g: float) -> float:
    """:func:`vrelab.models.design.tilt_error_from_static_deg` (an axis at tilt ``asin(g0)``), NaN
    where it is undefined (g0 or g0 + δ at or beyond ±1 g): predict's rule, imported."""
    from vrelab.prediction import tilt_note

    return tilt_note(vre_g, static_g)[0]


def model_point(params: Mapping[str, Any], seed: np.random.SeedSequence) -> dict[str, float]:
    """Analytic VRE (clipping + polynomial) at one point; ``seed`` is unused (no randomness)."""
    from vrelab.models.nonlinearity import ug_per_g2_to_per_g
    from vrelab.prediction import memoryless_level
    from vrelab.sensor.stages import Clip, Offset, Polynomial

    rms = float(params["rms_g"])
    static = float(params.get("static_g", 1.0))
    range_g = float(params.get("range_g", 2.0))
    shape = params.get("shape", "gaussian")
    clip_kind = params.get("clip_kind", DEFAULT_CLIP_KIND)
    rms_mass = _rms_at_proof_mass(rms, params)
    k2 = float(ug_per_g2_to_per_g(float(params.get("k2_ug_per_g2", 0.0))))
    k3 = float(ug_per_g2_to_per_g(float(params.get("k3_ug_per_g3", 0.0))))  # µg/g³ -> 1/g²: same factor
    offset = float(params.get("offset_g", 0.0))
    # the ideal sensor's chain, as vrelab.sensor.Sensor.stages builds it
    stages: list[Stage] = [Polynomial(k2, k3)] if k2 or k3 else []
    stages += [Offset(offset)] if offset else []
    stages += [Clip(-range_g, range_g)] if clip_kind != "none" else []
    level, off = memoryless_level(stages, static, rms_mass, shape,
                                  DEFAULT_CLIP_KIND if clip_kind == "none" else clip_kind, each_rail=False)
    return {
        "vre_g": level.vre_g,
        "vre_clip_g": level.shares["clip_g"],
        "vre_poly_g": level.shares["nonlinearity_g"],
        "rms_mass_g": rms_mass,
        "vibration_off_g": off,
        "tilt_error_deg": level.tilt_error_deg,
    }


def _base_sensor(name: str, range_g: float | None, axis: str | None, odr_hz: float | None,
                 overrides: tuple[tuple[str, Any], ...]) -> Sensor:
    # A sensor file's state is part of the cache key: an edited file is read again.
    try:
        st = os.stat(name)
        version: tuple[int, int] | None = (st.st_mtime_ns, st.st_size)
    except OSError:
        version = None  # a preset name
    return _load_sensor_cached(name, version, range_g, axis, odr_hz, overrides)


@functools.lru_cache(maxsize=64)
def _load_sensor_cached(name: str, version: tuple[int, int] | None, range_g: float | None, axis: str | None,
                        odr_hz: float | None, overrides: tuple[tuple[str, Any], ...]) -> Sensor:
    from vrelab.sensor import load_sensor

    return load_sensor(name, range_g=range_g, axis=axis, odr_hz=odr_hz, overrides=dict(overrides))


def sensor_for(params: Mapping[str, Any]) -> Sensor:
    """The :class:`vrelab.sensor.Sensor` of a point: a preset (or file) as configured, with the
    point's sensor parameters (the field table's sweepable rows, by file key: ``k2_ug_per_g2``,
    ``fn_hz``, ``q``, ``offset_g``, ``kip_ug_per_g2``, ...; a Monte Carlo unit's draws) set as the
    user's values (:func:`vrelab.sensor.load_sensor`'s ``overrides``: they leave the file's
    covariance and assumed u, and the Sensor checks them)."""
    from vrelab.sensor.fields import sweepable

    overrides = tuple((f.key, params[f.key]) for f in sweepable() if f.key in params)
    return _base_sensor(params.get("sensor", "adxl355"), params.get("range_g"), params.get("axis"),
                        params.get("odr_hz"), overrides)


@functools.lru_cache(maxsize=64)
def _profile(text: str) -> Profile:
    from vrelab.profiles import parse_profile

    return parse_profile(text)


def _excitation(params: Mapping[str, Any]) -> float | Profile:
    """A sine's frequency [Hz] (a float) or a random profile."""
    if ("profile" in params) == ("freq_hz" in params):
        raise ValueError("give exactly one of profile (random) and freq_hz (sine)")
    if "freq_hz" in params:
        return float(params["freq_hz"])
    return _profile(params["profile"])


def predict_point(params: Mapping[str, Any], seed: np.random.SeedSequence) -> dict[str, float]:
    """:func:`vrelab.prediction.predict` at one level; ``seed`` is unused (no randomness)."""
    from vrelab.prediction import predict

    excitation = _excitation(params)
    # a point records no u (the dataset has no column for it): the sensor file's assumed u is not
    # propagated per point (dozens of predictions each), and each level's validity is judged
    # against 1 % of |VRE| instead, the stricter; an assumption with no u is still probed
    sensor = dataclasses.replace(sensor_for(params), uncertainty={})
    pred = predict(sensor, excitation, [float(params["rms_g"])], static_g=float(params.get("static_g", 1.0)))
    lv = pred.levels[0]
    sh = lv.shares
    return {
        "vre_g": lv.vre_g,
        "tilt_error_deg": lv.tilt_error_deg,
        "vre_clip_g": sh.get("clip_g", math.nan),
        "vre_poly_g": sh.get("nonlinearity_g", math.nan),
        "vre_overrange_g": sh.get("overrange_g", math.nan),
        "rms_mass_g": lv.sigma_proof_mass_g,
        "rms_out_g": lv.sigma_output_g,
        "vibration_off_g": pred.vibration_off_g,
        "valid": float(lv.valid),
    }


def simulate_plan(params: Mapping[str, Any], seed: np.random.SeedSequence | None = None) -> TestPlan:
    """The simulated shaker test of one point (one level), as ``vrelab simulate`` runs it: a level
    lasts :data:`vrelab.simulation.durations.DEFAULT_LEVEL_S` (4 s) unless the file sets ``seconds``, sine and
    random alike (:func:`vrelab.shaker.run_sine_test`, :func:`vrelab.shaker.run_random_test`); ``seed`` None: 0 (a plan to size, not to run)."""
    from vrelab.simulation.plan import TestPlan

    excitation = _excitation(params)
    sensor = sensor_for(params)
    rms = float(params["rms_g"])
    static = float(params.get("static_g", 1.0))
    # durations the file does not set keep the shaker's own defaults
    timing: dict[str, Any] = {k: float(params[k]) for k in ("seconds", "baseline_s", "settle_s") if k in params}
    # the shaker takes an integer seed: 64 bits of the point's SeedSequence, itself unique per point
    seed_int = 0 if seed is None else int(seed.generate_state(1, dtype=np.uint64)[0])
    if isinstance(excitation, float):
        return TestPlan.sine(sensor, [excitation], [rms], static_g=static, seed=seed_int, **timing)
    return TestPlan.random(sensor, excitation, [rms], static_g=static, seed=seed_int, **timing)


def simulate_point(params: Mapping[str, Any], seed: np.random.SeedSequence) -> dict[str, float]:
    """One level of the simulated shaker test, its randomness drawn from the point's ``seed``."""
    from vrelab.shaker import run_test

    static = float(params.get("static_g", 1.0))
    res = run_test(simulate_plan(params, seed))
    lv = res.levels[0]
    return {
        "vre_g": lv.vre.value,
        "u_vre_g": lv.vre.u,
        "tilt_error_deg": _tilt_deg(lv.vre.value, static),
        "rms_measured_g": lv.rms_g,
        "n_saturated": float(lv.n_saturated),
    }
