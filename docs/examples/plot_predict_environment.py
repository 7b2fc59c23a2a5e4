"""
VRE of an ADXL355 on a truck bed, by mechanism
==============================================

:func:`vrelab.prediction.predict` on the ADXL355 preset (±2 g, Z axis, ODR 4 kHz, axis up in a
1 g field) in MIL-STD-810H's common-carrier vertical environment, scaled from its stated
1.08 g rms up to 4 g rms: the total VRE and the share of each mechanism (clipping at the rails,
the scale-factor nonlinearity, over-range protection).
Levels where an approximation stops holding are drawn hollow (``valid = False``: simulate them).
"""

import matplotlib.pyplot as plt
import numpy as np

import vrelab

sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
profile = vrelab.parse_profile("mil-std-810h-common-carrier-vertical")
levels = np.round(np.linspace(0.5, 4.0, 15), 3)
prediction = vrelab.predict(sensor, profile, list(levels), static_g=1.0)

for level in prediction.levels[::4]:
    print(f"{level.rms_g:.2f} g rms: VRE {1e3 * level.vre_g:8.2f} mg, valid {level.valid}")

vre_mg = np.array([1e3 * lv.vre_g for lv in prediction.levels])
valid = np.array([bool(lv.valid) for lv in prediction.levels])
fig, ax = plt.subplots(figsize=(6, 4))
ax.plot(levels, vre_mg, "-", color="C0", label="total")
ax.plot(levels[valid], vre_mg[valid], "o", color="C0")
ax.plot(levels[~valid], vre_mg[~valid], "o", mfc="none", color="C0", label="not valid: simulate")
for share, style in (("clip_g", "--"), ("nonlinearity_g", ":"), ("overrange_g", "-.")):
    ax.plot(levels, [1e3 * lv.shares[share] for lv in prediction.levels], style, label=share)
ax.set_xlabel("vibration [g rms]")
ax.set_ylabel("VRE [mg]")
ax.set_title("ADXL355 ±2 g Z, MIL-STD-810H common carrier (vertical)")
ax.grid(True, alpha=0.3)
ax.legend()
plt.show()
