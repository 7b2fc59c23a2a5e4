"""
Censored, truncated and sine clipping
=====================================

The article's Figure 1 case: a ±2 g sensor in a 1 g field under vibration of growing rms. The
censored model (a sample beyond a rail reads as the rail: physical saturation) is vrelab's
default; the article's truncated model (samples beyond a rail discarded) predicts about three
times more; a sine of the same rms clips later than Gaussian motion because its peaks are only
√2 times its rms. Equations: :doc:`/physics`, "Asymmetric rails".
"""

import matplotlib.pyplot as plt
import numpy as np

from vrelab.models.clipping import censored_mean_shift, sine_clip_mean_shift, truncated_mean_shift

rms_g = np.linspace(0.05, 3.0, 120)
censored = censored_mean_shift(1.0, rms_g, -2.0, 2.0)
truncated = truncated_mean_shift(1.0, rms_g, -2.0, 2.0)
sine = sine_clip_mean_shift(1.0, rms_g * np.sqrt(2), -2.0, 2.0)

print(f"at 1 g rms: censored {1e3 * censored_mean_shift(1.0, 1.0, -2.0, 2.0):.1f} mg, "
      f"truncated {1e3 * truncated_mean_shift(1.0, 1.0, -2.0, 2.0):.1f} mg, "
      f"sine {1e3 * sine_clip_mean_shift(1.0, np.sqrt(2), -2.0, 2.0):.1f} mg")

fig, ax = plt.subplots(figsize=(6, 4))
ax.plot(rms_g, 1e3 * censored, label="Gaussian, censored (default)")
ax.plot(rms_g, 1e3 * truncated, "--", label="Gaussian, truncated (the article's model)")
ax.plot(rms_g, 1e3 * sine, ":", label="sine, censored")
ax.set_xlabel("vibration [g rms]")
ax.set_ylabel("VRE [mg]")
ax.set_title("±2 g rails, 1 g static field")
ax.grid(True, alpha=0.3)
ax.legend()
plt.show()
