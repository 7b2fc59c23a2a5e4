"""Pure analytic physics of vibration rectification (SPEC sections 1 and 4): no I/O, no printing.

* :mod:`~vrelab.models.clipping`: asymmetric rails, censored and truncated (SPEC 1.1)
* :mod:`~vrelab.models.nonlinearity`: polynomial scale-factor nonlinearity, VRC units (SPEC 1.2)
* :mod:`~vrelab.models.dynamics`: resonance, filters, effective rms, Rice crossings (SPEC 1.3)
* :mod:`~vrelab.models.design`: the designer's inverse questions and planning checks (SPEC 4)
"""

from vrelab.models.clipping import (
    censored_mean_shift,
    clip_mean_shift,
    mean_shift,
    sine_clip_mean_shift,
    truncated_mean_shift,
)
from vrelab.models.design import (
    fixture_resonance_ok,
    grms_at_peak_threshold,
    max_rms_for_budget,
    max_sine_level_clear_of_rails,
    overrange_vre,
    tilt_error_deg,
    tilt_error_from_static_deg,
    total_vre,
)
from vrelab.models.dynamics import (
    effective_rms,
    resonator,
    rice_upcrossing_rate,
    rms_through,
    second_order_response,
    vrc_at_frequency,
    zero_crossing_rate_hz,
)
from vrelab.models.nonlinearity import (
    gaussian_moments,
    per_g_to_ug_per_g2,
    polynomial_vre,
    ppm_per_g_to_ug_per_g2,
    sample_moments,
    separate_k2_k3,
    sine_moments,
    ug_per_g2_from_ppm_fs,
    ug_per_g2_to_per_g,
    vrc_ug_per_g2_from_vre,
    vre_poly,
)

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
