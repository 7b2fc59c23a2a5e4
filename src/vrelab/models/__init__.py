"""Pure analytic physics of vibration rectification (docs/physics.md §1 and §4): no I/O, no printing.

* :mod:`~vrelab.models.clipping`: asymmetric rails, censored and truncated (physics §1.1)
* :mod:`~vrelab.models.nonlinearity`: polynomial scale-factor nonlinearity, VRC units (physics §1.2)
* :mod:`~vrelab.models.dynamics`: resonance, filters, effective rms, Rice crossings (physics §1.3)
* :mod:`~vrelab.models.design`: the designer's inverse questions and planning checks (physics §4)

The names below are imported on first use (``from vrelab.models import mean_shift`` or
``vrelab.models.mean_shift``): importing one leaf, e.g. :mod:`vrelab.models.kinds` for the
command line's choices, then costs no scipy.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from vrelab._lazy import lazy_getattr

if TYPE_CHECKING:
    from vrelab.models.clipping import censored_mean_shift as censored_mean_shift
    from vrelab.models.clipping import clip_mean_shift as clip_mean_shift
    from vrelab.models.clipping import mean_shift as mean_shift
    from vrelab.models.clipping import sine_clip_mean_shift as sine_clip_mean_shift
    from vrelab.models.clipping import truncated_mean_shift as truncated_mean_shift
    from vrelab.models.design import fixture_resonance_ok as fixture_resonance_ok
    from vrelab.models.design import grms_at_peak_threshold as grms_at_peak_threshold
    from vrelab.models.design import max_rms_for_budget as max_rms_for_budget
    from vrelab.models.design import max_sine_level_clear_of_rails as max_sine_level_clear_of_rails
    from vrelab.models.design import overrange_vre as overrange_vre
    from vrelab.models.design import tilt_error_deg as tilt_error_deg
    from vrelab.models.design import tilt_error_from_static_deg as tilt_error_from_static_deg
    from vrelab.models.design import total_vre as total_vre
    from vrelab.models.dynamics import effective_rms as effective_rms
    from vrelab.models.dynamics import resonator as resonator
    from vrelab.models.dynamics import rice_upcrossing_rate as rice_upcrossing_rate
    from vrelab.models.dynamics import rms_through as rms_through
    from vrelab.models.dynamics import second_order_response as second_order_response
    from vrelab.models.dynamics import vrc_at_frequency as vrc_at_frequency
    from vrelab.models.dynamics import zero_crossing_rate_hz as zero_crossing_rate_hz
    from vrelab.models.nonlinearity import gaussian_moments as gaussian_moments
    from vrelab.models.nonlinearity import per_g_to_ug_per_g2 as per_g_to_ug_per_g2
    from vrelab.models.nonlinearity import polynomial_vre as polynomial_vre
    from vrelab.models.nonlinearity import ppm_per_g_to_ug_per_g2 as ppm_per_g_to_ug_per_g2
    from vrelab.models.nonlinearity import sample_moments as sample_moments
    from vrelab.models.nonlinearity import separate_k2_k3 as separate_k2_k3
    from vrelab.models.nonlinearity import sine_moments as sine_moments
    from vrelab.models.nonlinearity import ug_per_g2_from_ppm_fs as ug_per_g2_from_ppm_fs
    from vrelab.models.nonlinearity import ug_per_g2_to_per_g as ug_per_g2_to_per_g
    from vrelab.models.nonlinearity import vrc_ug_per_g2_from_vre as vrc_ug_per_g2_from_vre
    from vrelab.models.nonlinearity import vre_poly as vre_poly

# name -> module, imported on first use
_LAZY: dict[str, str] = {
    "censored_mean_shift": "vrelab.models.clipping",
    "clip_mean_shift": "vrelab.models.clipping",
    "mean_shift": "vrelab.models.clipping",
    "sine_clip_mean_shift": "vrelab.models.clipping",
    "truncated_mean_shift": "vrelab.models.clipping",
    "fixture_resonance_ok": "vrelab.models.design",
    "grms_at_peak_threshold": "vrelab.models.design",
    "max_rms_for_budget": "vrelab.models.design",
    "max_sine_level_clear_of_rails": "vrelab.models.design",
    "overrange_vre": "vrelab.models.design",
    "tilt_error_deg": "vrelab.models.design",
    "tilt_error_from_static_deg": "vrelab.models.design",
    "total_vre": "vrelab.models.design",
    "effective_rms": "vrelab.models.dynamics",
    "resonator": "vrelab.models.dynamics",
    "rice_upcrossing_rate": "vrelab.models.dynamics",
    "rms_through": "vrelab.models.dynamics",
    "second_order_response": "vrelab.models.dynamics",
    "vrc_at_frequency": "vrelab.models.dynamics",
    "zero_crossing_rate_hz": "vrelab.models.dynamics",
    "gaussian_moments": "vrelab.models.nonlinearity",
    "per_g_to_ug_per_g2": "vrelab.models.nonlinearity",
    "polynomial_vre": "vrelab.models.nonlinearity",
    "ppm_per_g_to_ug_per_g2": "vrelab.models.nonlinearity",
    "sample_moments": "vrelab.models.nonlinearity",
    "separate_k2_k3": "vrelab.models.nonlinearity",
    "sine_moments": "vrelab.models.nonlinearity",
    "ug_per_g2_from_ppm_fs": "vrelab.models.nonlinearity",
    "ug_per_g2_to_per_g": "vrelab.models.nonlinearity",
    "vrc_ug_per_g2_from_vre": "vrelab.models.nonlinearity",
    "vre_poly": "vrelab.models.nonlinearity",
}

__all__ = [
    "censored_mean_shift",
    "clip_mean_shift",
    "effective_rms",
    "fixture_resonance_ok",
    "gaussian_moments",
    "grms_at_peak_threshold",
    "max_rms_for_budget",
    "max_sine_level_clear_of_rails",
    "mean_shift",
    "overrange_vre",
    "per_g_to_ug_per_g2",
    "polynomial_vre",
    "ppm_per_g_to_ug_per_g2",
    "resonator",
    "rice_upcrossing_rate",
    "rms_through",
    "sample_moments",
    "second_order_response",
    "separate_k2_k3",
    "sine_clip_mean_shift",
    "sine_moments",
    "tilt_error_deg",
    "tilt_error_from_static_deg",
    "total_vre",
    "truncated_mean_shift",
    "ug_per_g2_from_ppm_fs",
    "ug_per_g2_to_per_g",
    "vrc_at_frequency",
    "vrc_ug_per_g2_from_vre",
    "vre_poly",
    "zero_crossing_rate_hz",
]


__getattr__ = lazy_getattr(__name__, _LAZY, globals())
