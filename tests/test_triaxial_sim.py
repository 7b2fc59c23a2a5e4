"""The triaxial chain of one DUT axis and the direction drive (issue 22, SPEC 1.6, TRIAXIAL.md).

Truths: the single-axis chain (a drive along the input axis with the cross terms adding exact
zeros must give it bit for bit, same seed), and IEEE 1293's vibropendulous error
``Kip·σ²·sin φ cos φ`` (SPEC 1.6) for a linear, unclipped ideal axis, whose expectation is
exact here (a Gaussian drive's variance is the profile's mean square, Σh² = grms²).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from vrelab.profiles import RandomProfile
from vrelab.sensor import load_sensor
from vrelab.synthesis import random_signal
from vrelab.triaxial.chain import TriaxialChain, TriaxialPolynomial, triaxial_chain
from vrelab.triaxial.profile import TriaxialSine, direction
from vrelab.triaxial.simulate import simulate_direction
from vrelab.triaxial.synthesis import direction_blocks

FLAT = RandomProfile.flat(20.0, 500.0, grms=1.0)


def _along(axis: int, x: np.ndarray, static: float = 1.0) -> np.ndarray:
    a = np.zeros((3, x.size))
    a[axis] = x + static
    return a


@pytest.mark.parametrize("cross", [{}, {"kip_per_g": 1e-3, "kio_per_g": -2e-3, "kpo_per_g": 5e-4, "koo_per_g": 1e-3}])
def test_drive_along_the_input_axis_is_the_single_axis_chain_bit_for_bit(cross):
    # ADXL355 z: resonance, polynomial, over-range, noise, anti-alias, low-pass, decimation,
    # output clip, quantiser. With cross terms the run takes its general path (three front
    # ends, the extended polynomial, the rest seeded by stage index); without, the linear one.
    sensor = load_sensor("adxl355", axis="z")
    tri = dataclasses.replace(sensor, **cross)
    fs = 16000.0
    x = random_signal(RandomProfile.flat(50.0, 2000.0, grms=1.5), fs, 40000, seed=4)
    want, want_stats = sensor.chain(fs).apply(x + 1.0, fs, seed=7, block_size=4096)
    got, stats = triaxial_chain(tri, fs).apply(_along(2, x), fs, seed=7, block_size=3000)
    assert np.array_equal(got, want)
    assert stats.clipped_samples == want_stats.clipped_samples and stats.samples_out == want_stats.samples_out
    assert np.ptp(want) > 1.0  # the drive really moved the output (not two constant records)


def test_cross_axis_sensitivity_of_a_linear_axis_reads_the_projected_drive():
    # No K terms: u = w·(H*a) = H*(w·a), the single-axis chain on the projected drive.
    sensor = dataclasses.replace(load_sensor("adxl355", axis="x"), cross_axis_y=0.02, cross_axis_z=-0.01)
    fs = 16000.0
    rng = np.random.default_rng(11)
    a = rng.normal(0.0, 0.5, (3, 20000)) + np.array([[0.0], [0.0], [1.0]])
    linear, _ = triaxial_chain(sensor, fs).apply(a, fs, seed=2)
    w = np.array([1.0, 0.02, -0.01])
    want, _ = sensor.chain(fs).apply(w @ a, fs, seed=2)
    assert np.array_equal(linear, want)
    # x is i, y is p, z is o. With y still, a Kpp (Kpp·b_y² = 0) runs the general path (three
    # front ends, the extended polynomial) and must give the linear path's output to rounding;
    # a Kio (Kio·b_x·b_z) must not.
    b = a.copy()
    b[1] = 0.0
    lin_b, _ = triaxial_chain(sensor, fs).apply(b, fs, seed=2)
    gen_b, _ = triaxial_chain(dataclasses.replace(sensor, kpp_per_g=1e-2), fs).apply(b, fs, seed=2)
    kio_b, _ = triaxial_chain(dataclasses.replace(sensor, kio_per_g=1e-2), fs).apply(b, fs, seed=2)
    np.testing.assert_allclose(gen_b, lin_b, rtol=0, atol=1e-12)
    assert np.max(np.abs(kio_b - lin_b)) > 1e-4


def test_block_size_does_not_change_the_output():
    sensor = dataclasses.replace(load_sensor("adxl355", axis="y"), kip_per_g=1e-3, cross_axis_x=0.01)
    fs = 16000.0
    rng = np.random.default_rng(3)
    a = rng.normal(0.0, 1.0, (3, 12000))
    one, _ = triaxial_chain(sensor, fs).apply(a, fs, seed=5, block_size=12000)
    many, _ = triaxial_chain(sensor, fs).apply(a, fs, seed=5, block_size=777)
    assert np.array_equal(one, many)


def test_polynomial_is_ieee_1293_model_equation():
    # y = u + k2 u² + Kip b_i b_p + Kio b_i b_o + Kpp b_p² + Koo b_o² + Kpo b_p b_o, written out here
    poly = TriaxialPolynomial((0.1, 1.0, 0.05), (1, 2, 0), k2_per_g=0.01, kip_per_g=0.02, kio_per_g=0.03,
                              kpp_per_g=0.04, koo_per_g=0.05, kpo_per_g=0.06)
    b = np.array([[0.3, -1.2], [0.7, 2.0], [-0.4, 0.9]])  # rows x, y, z; i = y, p = z, o = x
    bi, bp, bo = b[1], b[2], b[0]
    u = bi + 0.1 * b[0] + 0.05 * b[2]
    want = u + 0.01 * u**2 + 0.02 * bi * bp + 0.03 * bi * bo + 0.04 * bp**2 + 0.05 * bo**2 + 0.06 * bp * bo
    got, _ = poly.process(b)
    np.testing.assert_allclose(got, want, rtol=1e-15, atol=1e-15)
    assert poly.needed_axes() == (0, 1, 2)


def test_bad_input_is_refused():
    sensor = load_sensor("ideal", axis="z")
    run = triaxial_chain(sensor, 1000.0).start(1000.0)
    with pytest.raises(ValueError, match=r"shape \(3, n\)"):
        run.process(np.zeros(10))
    with pytest.raises(ValueError, match="finite"):
        run.process(np.full((3, 4), np.nan))
    with pytest.raises(ValueError, match="triad"):
        TriaxialPolynomial((1.0, 0.0, 0.0), (0, 0, 1))
    with pytest.raises(ValueError, match="input axis"):
        TriaxialPolynomial((0.5, 0.0, 0.0), (0, 1, 2))
    with pytest.raises(ValueError, match="direction"):
        next(direction_blocks(FLAT, 2000.0, 10, 10, 0))
    with pytest.raises(ValueError, match="own direction"):
        next(direction_blocks(TriaxialSine(50.0, (1, 0, 0)), 2000.0, 10, 10, 0, direction=(0, 1, 0)))
    with pytest.raises(ValueError, match="static_g must be three finite numbers"):
        next(simulate_direction(sensor, FLAT, 100, direction=(0, 0, 1), static_g=(0, 1)))
    assert isinstance(triaxial_chain(sensor, 1000.0), TriaxialChain)


def _vre_batches(sensor, excitation, dirn, seconds, seed, fs=2000.0, batches=40):
    """VRE = mean(output) - vibration-off reading, and its u from batch means (the batches
    are far longer than the drive's correlation time)."""
    n = int(seconds * fs)
    out = np.concatenate([b.dut[sensor.axis] for b in simulate_direction(
        sensor, excitation, n, direction=dirn, static_g=(0.0, 0.0, 1.0), fs_hz=fs, seed=seed, block_size=5000)])
    # the vibration-off reading through the same chain: the static vector alone
    g_only = triaxial_chain(sensor, fs).apply(np.tile([[0.0], [0.0], [1.0]], (1, 1000)), fs)[0]
    means = out[: out.size // batches * batches].reshape(batches, -1).mean(axis=1)
    return float(means.mean() - g_only.mean()), float(means.std(ddof=1) / math.sqrt(batches))


@pytest.mark.parametrize("angle", [45.0, -45.0, 30.0])
def test_vibropendulous_error_of_a_linear_unclipped_axis(angle):
    # SPEC 1.6 / IEEE 1293: a vibration at φ in the IP plane of an otherwise linear axis rectifies
    # Kip·σ²·sin φ cos φ. z is the input axis, x the pendulous one (cyclic default).
    # 1/g = 100 000 µg/g²: large, so the rectified mean stands far above the scatter of the
    # linear part (the drive itself, whose batch means scatter by about 5e-4 g here)
    kip = 0.1
    sensor = dataclasses.replace(load_sensor("ideal", axis="z", range_g=20.0), kip_per_g=kip)
    assert sensor.triad == (2, 0, 1)
    phi = math.radians(angle)
    truth = kip * FLAT.mean_square_g2 * math.sin(phi) * math.cos(phi)
    vre, u = _vre_batches(sensor, FLAT, direction("z", "x", angle), 20.0, seed=3)
    assert abs(vre - truth) < 4 * u
    assert u < 0.05 * abs(truth)  # a sharp test: the error is resolved to a few % of it


def test_the_ip_and_io_planes_separate_kip_and_kio():
    # IEEE 1293's mount angles: Kip = (VRE(+45°) - VRE(-45°))/σ² in the IP plane, Kio likewise in IO.
    sensor = dataclasses.replace(load_sensor("ideal", axis="x", range_g=20.0), kip_per_g=0.03, kio_per_g=-0.01)
    i, p, o = sensor.triad  # x, y, z
    assert (i, p, o) == (0, 1, 2)
    est = {}
    for plane, toward in (("ip", "y"), ("io", "z")):
        plus, up = _vre_batches(sensor, FLAT, direction("x", toward, 45.0), 10.0, seed=1)
        minus, um = _vre_batches(sensor, FLAT, direction("x", toward, -45.0), 10.0, seed=2)
        est[plane] = ((plus - minus) / FLAT.mean_square_g2, math.hypot(up, um) / FLAT.mean_square_g2)
    assert abs(est["ip"][0] - 0.03) < 4 * est["ip"][1]
    assert abs(est["io"][0] + 0.01) < 4 * est["io"][1]


def test_sine_along_a_direction_rectifies_its_mean_square():
    # a sine of rms r at φ: Kip·r²·sin φ cos φ over whole periods (no statistics: 50 Hz, 2 kHz, 40 periods)
    sensor = dataclasses.replace(load_sensor("ideal", axis="y", range_g=20.0), kip_per_g=0.05)
    _, p, _ = sensor.triad  # y -> z
    sine = TriaxialSine(50.0, direction("y", "z", 60.0), rms_g=2.0)
    out = np.concatenate([b.dut["y"] for b in simulate_direction(sensor, sine, 1600, static_g=(0.0, 0.0, 0.0),
                                                                     fs_hz=2000.0)])
    want = 0.05 * 4.0 * math.sin(math.radians(60.0)) * math.cos(math.radians(60.0))
    assert out.mean() == pytest.approx(want, rel=1e-9)


def test_reference_is_the_vibration_along_the_direction():
    sensor = load_sensor("ideal", axis="x")
    d = np.array([1.0, 2.0, 2.0]) / 3.0
    blocks = list(simulate_direction(sensor, FLAT, 4000, direction=d * 5, fs_hz=2000.0, seed=9, block_size=1500))
    ref = np.concatenate([b.reference for b in blocks], axis=1)
    assert ref.shape == (3, 4000)
    np.testing.assert_allclose(ref / d[:, None], np.broadcast_to(ref[0] / d[0], (3, 4000)), rtol=1e-12)
    # static 1 g on z, x sees the drive's x component only (w = e_x, linear ideal axis)
    dut = np.concatenate([b.dut["x"] for b in blocks])
    np.testing.assert_allclose(dut, ref[0], rtol=0, atol=1e-15)
