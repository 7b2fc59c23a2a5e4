"""The spectral integrals a random level needs at each site (σ², Rice's ν0, the hold's correlations), remembered by their exact inputs."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np
from numpy.typing import NDArray

from vrelab.profiles import RandomProfile
from vrelab.sensor.meanshift import Response
from vrelab.sensor.meanshift import response_key as _response_key

if TYPE_CHECKING:
    pass


def spectral(profile: RandomProfile, responses: Sequence[Response], points_hz: Sequence[float],
              rate: bool = True) -> tuple[float, float]:
    """(σ² [g²], ν0 [Hz]) of the profile seen through ``responses``.

    ``σ² = ∫S·|H|²df`` (:func:`vrelab.models.dynamics.effective_rms`) and Rice's zero
    up-crossing rate ``ν0 = sqrt(∫f²·S·|H|²df / σ²)``
    (:func:`vrelab.models.dynamics.zero_crossing_rate_hz`), over the profile's band, split at
    its breakpoints and at the sensor's resonance. Without ``rate`` (a site that needs no
    crossing rate) ν0 is NaN and its two integrals are not computed.

    The integrals are remembered by their exact inputs (:func:`_spectral_of`) where every
    response is a stage's: an identification or a propagation predicts again and again with
    parameters that leave the resonance and the filters as they were (a polynomial's or a rail's
    step), and the adaptive quadrature is most of a random level's prediction.
    """
    keys = tuple(_response_key(h) for h in responses)
    # the table as its float64 bytes: an exact key, 8 bytes a point
    freq = np.ascontiguousarray(profile.freq_hz, dtype=np.float64).tobytes()
    psd = np.ascontiguousarray(profile.psd_g2_per_hz, dtype=np.float64).tobytes()
    band = tuple(float(b) for b in profile.band)
    points = tuple(float(p) for p in points_hz)
    if all(k is not None for k in keys):
        return _spectral_of(freq, psd, band, keys, points, rate)
    return _spectral_at(freq, psd, band, responses, points, rate)


@functools.lru_cache(maxsize=256)
def _spectral_of(freq: bytes, psd: bytes, band: tuple[float, ...], keys: tuple[tuple[Any, Any], ...],
                 points: tuple[float, ...], rate: bool) -> tuple[float, float]:
    """:func:`_spectral_at` with the responses given as :func:`_response_key` values. A pure
    function of its exact inputs: cached, bounded (a fit's few profiles and resonances)."""
    return _spectral_at(freq, psd, band, [f.__get__(owner) for f, owner in keys], points, rate)


def _spectral_at(freq: bytes, psd: bytes, band: Sequence[float], responses: Sequence[Response],
                 points_hz: Sequence[float], rate: bool) -> tuple[float, float]:
    """:func:`spectral` of the profile's table ``(freq, psd)`` (float64 bytes) over ``band``."""
    from vrelab.models import dynamics

    lo, hi = band
    table = (np.frombuffer(freq, dtype=np.float64), np.frombuffer(psd, dtype=np.float64))
    sigma = dynamics.effective_rms(table, list(responses), lo, hi, points_hz=list(points_hz))
    if not rate:
        return sigma**2, math.nan
    nu0 = dynamics.zero_crossing_rate_hz(table, list(responses), lo, hi, points_hz=list(points_hz))
    return sigma**2, nu0


@dataclass(frozen=True)
class _HoldWeight:
    """The non-negative weight |W(f)| under which the hold's correlation integrals are spectral
    integrals ∫S·|H·W|² (:func:`hold_correlation`): ``sqrt(1 - sinc(2f·hold))`` for the
    correlation averaged over the hold, ``sqrt(2)·|sin(πf·hold)|`` for ``1 - ρ(hold)``. A frozen
    dataclass, so :func:`spectral` remembers its integrals as it does a stage's."""

    hold_s: float
    end: bool

    def response(self, f: NDArray[np.float64]) -> NDArray[np.complex128]:
        if self.end:
            return (math.sqrt(2.0) * np.abs(np.sin(np.pi * np.asarray(f) * self.hold_s))).astype(complex)
        return np.sqrt(np.maximum(1.0 - np.sinc(2.0 * np.asarray(f) * self.hold_s), 0.0)).astype(complex)


def hold_correlation(profile: RandomProfile, responses: Sequence[Response], points_hz: Sequence[float],
                      hold_s: float, m0: float) -> tuple[float, float]:
    """(ρ̄, 1 - ρ(hold)) of the profile seen through ``responses``: the motion's correlation
    averaged over the hold, ``ρ̄ = ∫S·|H|²·sinc(2f·hold)df/σ²``, and ``1 - ρ(hold) =
    ∫S·|H|²·(1 - cos 2πf·hold)df/σ²``, both as ∫S·|H·W|² with a non-negative weight |W|²
    (1 - sinc and 2·sin², :class:`_HoldWeight`) so the one spectral integral (:func:`spectral`)
    computes them."""
    if not m0 > 0:
        return math.nan, math.nan
    one_minus_mean, _ = spectral(profile, [*responses, _HoldWeight(hold_s, False).response], points_hz, rate=False)
    one_minus_end, _ = spectral(profile, [*responses, _HoldWeight(hold_s, True).response], points_hz, rate=False)
    return 1.0 - one_minus_mean / m0, one_minus_end / m0

