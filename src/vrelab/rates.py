"""The simulation's sampling rates: one owner for the rule, with its measured error bound.

* :func:`simulation_rate_hz` — the internal rate a sensor chain runs at for a drive reaching
  ``f_max_hz`` (used by the simulated test, the chain tests and everything that simulates).
* :func:`record_step` — how many internal samples make one sample of the simulated record.
"""

from __future__ import annotations

import math

# The record's Nyquist frequency must exceed the highest drive frequency by this factor.
NYQUIST_MARGIN = 1.25
# Without an ODR (an analog or ideal sensor) the internal rate is a multiple of this [Hz].
_RATE_GRID_HZ = 1000.0


def record_step(decimation: int, fs_internal_hz: float, f_max_hz: float) -> int:
    """Largest divisor m of the decimation with fs_internal/m >= 2·1.25·f_max (1 if none)."""
    # fs/m >= need  <=>  m <= fs/need: start the search there, not at the decimation (a low
    # ODR makes decimations in the thousands, and simulation_rate_hz asks for each of k0..2·k0).
    m_max = int(min(decimation, math.floor(fs_internal_hz / (2 * NYQUIST_MARGIN * f_max_hz) + 1e-9)))
    for m in range(m_max, 0, -1):
        if decimation % m == 0 and fs_internal_hz / m >= 2 * NYQUIST_MARGIN * f_max_hz:
            return m
    return 1


# Rate rule of the simulated test (see simulation_rate_hz), each factor from a measurement:
# the drive's highest frequency is sampled 8 times per period, so the harmonics the
# nonlinearity makes up to the 4th (4·f_max) stay below Nyquist and the output-side stages
# (filters, output clip) see them unaliased;
_DRIVE_OVERSAMPLING = 8.0
# an analog corner (resonance, anti-alias) at or below fs/5: the matched-pole + least-squares
# design (vrelab.sensor.stages.discretize_zpk) then matches the analog |H| within 0.03 % up to
# fs/8 >= f_max (measured with scipy.signal.sosfreqz for Q from 0.5 to 100 and Butterworth
# orders 2 to 6; tests/test_sensor_stages.py holds it to 0.05 %);
_ANALOG_OVERSAMPLING = 5.0
# the sensor's digital low-pass corner at or below fs/16, where its design at the simulation
# rate and its analog prototype differ by well under 1 % in band (LowPass docstring).
_LOWPASS_OVERSAMPLING = 16.0


def simulation_rate_hz(sensor: object, f_max_hz: float) -> float:
    """The internal rate of a simulated test: accurate where the test looks, and cheap.

    Rule: ``f_need = max(8·f_max, 5·fn, 5·f_anti-alias, 5·f_mount, 16·bandwidth)`` (the reasons for each
    factor are at ``_DRIVE_OVERSAMPLING`` and below), rounded up to a multiple ``k0·ODR``.
    The former conservative rule asked 8× *every* corner, including the resonance, which only
    the drive (≤ f_max) passes through: the 5× rule keeps every discretised analog
    filter within 0.05 % of its analog ``|H|`` up to f_max, 8× keeps the nonlinearity's
    harmonics unaliased, and the tests check that the VRE it gives matches a 4× faster
    simulation within a fraction of its uncertainty (article random case, sine near fn).

    The cost of a test is about (chain at fs_internal) + (reduction at fs_record). Among the
    multiples k·ODR from ``k0`` to ``2·k0``, take the one that minimises
    ``fs_internal + fs_record`` (ties: the lower rate): for the ADXL355 at ODR 4 kHz and a
    2 kHz profile, ``f_need = max(16, 12, 7.5, 16) kHz`` = 16 kHz internal, 8 kHz record (the
    sensor's own rule, 8·fn = 19.2 kHz, gives 20 kHz, and then 24 kHz for an 8 kHz record).
    A sensor without an ODR takes the smallest multiple of 1 kHz >= ``f_need``.

    Over-range: the protection (:class:`~vrelab.sensor.stages.OverRange`) places its hold in
    continuous time (crossings from a cubic through the samples, peaks between samples from a
    parabola, fractional coverage of the samples), so its effect on the mean is second order in
    1/fs. On the ADXL355 Z axis at 2.5 g rms (50 Hz-2 kHz, 1 g, multisine, noise-free, 10 s
    levels, seeds 1-6) the VRE at 16 kHz is within 0.17 % (0.8 u) of 128 kHz for five seeds
    and 1.0 % (1.8 u) for the sixth; the former whole-sample hold was 0.35-5.7 % off (3.4 %
    mean, up to 56 u). What remains are peaks within a few mg of the threshold that trip at one
    rate and not at the other; a multisine drive repeats its frame (0.256 s in the case
    examined), so one such peak counts once per frame. Below the threshold the two rates agree
    within 0.5 %.
    """
    f_max = float(f_max_hz)
    if not math.isfinite(f_max) or f_max <= 0:
        raise ValueError(f"f_max_hz must be a finite number > 0, got {f_max_hz!r}")
    # any object: a sensor's optional corners are read by name, absent or None if it has none
    odr: float | None = getattr(sensor, "odr_hz", None)
    corners = {
        _ANALOG_OVERSAMPLING: (getattr(sensor, "fn_hz", None), getattr(sensor, "anti_alias_hz", None),
                               getattr(sensor, "mount_fn_hz", None)),
        _LOWPASS_OVERSAMPLING: (getattr(sensor, "bandwidth_hz", None),),
    }
    need = _DRIVE_OVERSAMPLING * float(f_max_hz)
    for factor, values in corners.items():
        for value in values:
            if value:
                need = max(need, factor * float(value))
    if not odr:
        return max(1, math.ceil(need / _RATE_GRID_HZ - 1e-9)) * _RATE_GRID_HZ
    k0 = max(1, math.ceil(need / odr - 1e-9))
    best_k, best_cost = k0, math.inf
    for k in range(k0, 2 * k0 + 1):
        fs = k * odr
        cost = fs + fs / record_step(k, fs, f_max_hz)
        if cost < best_cost - 1e-9:
            best_k, best_cost = k, cost
    return best_k * float(odr)
