"""
A simulated shaker test against the analytic prediction
=======================================================

:func:`vrelab.simulate` runs a sensor's whole chain on a simulated shaker (a Gaussian random
drive, vibration-off baselines between the levels) and reduces the record like a lab record:
each level's VRE with its standard uncertainty from the record. :func:`vrelab.predict` gives
the same quantity in closed form. On the ideal ±2 g sensor in a 1 g field (rails only, no
dynamics) both are the censored clipping model of :doc:`/physics`, so they should agree to
within a few of the simulation's standard uncertainties; the printed differences say how well
(in units of u).
"""

import matplotlib.pyplot as plt
import numpy as np

import vrelab

sensor = vrelab.load_sensor("ideal", range_g=2)
profile = vrelab.parse_profile("flat:50-2000")
levels = [0.5, 1.0, 1.5, 2.0]

simulated = vrelab.simulate(sensor, profile, levels, static_g=1.0, seconds=2, seed=1)
rms = np.array([lv.rms_g for lv in simulated.levels])
vre = np.array([lv.vre.value for lv in simulated.levels])
u = np.array([lv.vre.u for lv in simulated.levels])
predicted = np.array([lv.vre_g for lv in vrelab.predict(sensor, profile, list(rms), static_g=1.0).levels])

for r, v, uu, p in zip(rms, vre, u, predicted):
    print(f"{r:.3f} g rms: simulated {1e3 * v:8.2f} ± {1e3 * uu:.2f} mg, predicted {1e3 * p:8.2f} mg, "
          f"difference {(v - p) / uu:+.1f} u")

grid = np.linspace(0.05, 2.2, 100)
fig, ax = plt.subplots(figsize=(6, 4))
ax.plot(grid, [1e3 * lv.vre_g for lv in vrelab.predict(sensor, profile, list(grid), static_g=1.0).levels],
        label="predict (censored closed form)")
ax.errorbar(rms, 1e3 * vre, yerr=2e3 * u, fmt="o", label="simulate (± 2 u)")
ax.set_xlabel("vibration [g rms]")
ax.set_ylabel("VRE [mg]")
ax.set_title("ideal ±2 g sensor, 1 g field, flat 50 Hz–2 kHz")
ax.grid(True, alpha=0.3)
ax.legend()
plt.show()
