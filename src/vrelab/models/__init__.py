"""Pure analytic physics of vibration rectification (SPEC sections 1 and 4): no I/O, no printing.

* :mod:`~vrelab.models.clipping`: asymmetric rails, censored and truncated (SPEC 1.1)
"""

from vrelab.models.clipping import (
    censored_mean_shift,
    clip_mean_shift,
    mean_shift,
    sine_clip_mean_shift,
    truncated_mean_shift,
)

__all__ = [
    "censored_mean_shift",
    "clip_mean_shift",
    "mean_shift",
    "sine_clip_mean_shift",
    "truncated_mean_shift",
]
