"""SPEC 4.2 plausibility checks, each on a record that trips it and on one that must not."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import signal

from vrelab.analysis.plausibility import (
    SINE_LINE_FRACTION,
    UNIT_RATIO_LIMIT,
    check_channels,
    check_units,
    probe_segment,
    resolve_methods,
)
from vrelab.record import ArrayRecord

FS = 8000.0
BAND = (50.0, 2000.0)


def _random(rng: np.random.Generator, n: int, rms: float) -> np.ndarray:
    """Band-limited Gaussian noise, 50-2000 Hz, at ``rms`` g (a shaker's random drive)."""
    sos = signal.butter(6, BAND, btype="bandpass", fs=FS, output="sos")
    x = signal.sosfilt(sos, rng.standard_normal(n + 4000))[4000:]
    return x * rms / x.std()


def _record(kind: str, dut_scale: float = 1.0, ref_dc: float = 0.0, dut_dc: float = 1.0, seed: int = 7) -> ArrayRecord:
    """2 s off, 4 s at 1 g rms, 2 s off; DUT = reference × dut_scale + static field + noise."""
    rng = np.random.default_rng(seed)
    n_off, n_on = int(2 * FS), int(4 * FS)
    t = np.arange(n_on) / FS
    vib = math.sqrt(2) * np.sin(2 * np.pi * 160.0 * t) if kind == "sine" else _random(rng, n_on, 1.0)
    ref = np.concatenate([np.zeros(n_off), vib, np.zeros(n_off)]) + 1e-4 * rng.standard_normal(2 * n_off + n_on)
    dut = dut_scale * (ref - ref.mean() * 0) + dut_dc + 1e-4 * rng.standard_normal(ref.size)
    return ArrayRecord({"dut": dut, "ref": ref + ref_dc}, FS)


def _probes(rec: ArrayRecord, dut: str = "dut", ref: str = "ref"):
    level = probe_segment(rec, dut, ref, 2.5, 5.5, BAND)
    base = [probe_segment(rec, dut, ref, 0.2, 1.8, BAND), probe_segment(rec, dut, ref, 6.2, 7.8, BAND)]
    return level, base


@pytest.mark.parametrize("kind", ["sine", "random"])
def test_auto_method_recognises_each_level(kind):
    level, _ = _probes(_record(kind))
    assert level.kind == kind
    if kind == "sine":
        assert level.line_fraction > 0.99 and level.peak_hz == pytest.approx(160.0, abs=0.5)
    else:
        assert level.line_fraction < 0.05  # 7 of ~2000 lines of a broad spectrum
    assert resolve_methods("auto", [level]) == [kind]
    assert resolve_methods(kind, [level]) == [kind]


def test_explicit_method_contradicting_the_data_is_refused_with_what_was_found():
    sine_level, _ = _probes(_record("sine"))
    random_level, _ = _probes(_record("random"))
    with pytest.raises(ValueError, match=r"--method random does not fit the record.*one line at 160"):
        resolve_methods("random", [sine_level])
    with pytest.raises(ValueError, match=r"--method sine does not fit the record.*broadband"):
        resolve_methods("sine", [random_level])
    assert resolve_methods("sine", [random_level], accept=True) == ["sine"]


def test_sine_on_random_is_neither_and_auto_asks_for_a_method():
    """A tone holding about half the power is neither clearly sine nor random."""
    rng = np.random.default_rng(3)
    n = int(4 * FS)
    t = np.arange(n) / FS
    x = _random(rng, n, 1.0) + math.sqrt(2) * np.sin(2 * np.pi * 300.0 * t)
    rec = ArrayRecord({"dut": x + 1.0, "ref": x}, FS)
    p = probe_segment(rec, "dut", "ref", 0.0, 4.0, BAND)
    assert 0.3 < p.line_fraction < SINE_LINE_FRACTION
    if p.kind is None:
        with pytest.raises(ValueError, match="neither a sine nor a random level"):
            resolve_methods("auto", [p])


@pytest.mark.parametrize("scale, trips", [(1.0, False), (1.6, False), (10.0, True), (9.80665, True), (1e-3, True)])
def test_unit_slip_is_refused_naming_the_ratio(scale, trips):
    """mV at 10 mV/g read as g: ×10; m/s² read as g: ×9.81; a correct DUT: ×1."""
    for kind in ("sine", "random"):
        level, _ = _probes(_record(kind, dut_scale=scale))
        assert level.unit_ratio == pytest.approx(scale, rel=0.02)
        if trips:
            with pytest.raises(ValueError, match=r"differ by a factor of [0-9.e+-]+ .*--reference-units.*--accept-unit-ratio"):
                check_units([level], "dut", "ref")
            check_units([level], "dut", "ref", accept=True)
        else:
            check_units([level], "dut", "ref")
    assert UNIT_RATIO_LIMIT == 3.0  # SPEC 4.2's bar


def test_a_dut_with_a_narrow_bandwidth_is_not_taken_for_a_unit_slip():
    """ODR 500 (125 Hz low-pass, the article's Figure 4) sees little of a 50-2000 Hz drive, yet is
    flat at the bottom of the band, where the check looks."""
    rec = _record("random")
    sos = signal.butter(4, 125.0, fs=FS, output="sos")
    dut = signal.sosfilt(sos, rec.data["ref"]) + 1.0
    narrow = ArrayRecord({"dut": dut, "ref": rec.data["ref"]}, FS)
    level, _ = _probes(narrow)
    assert 1 / UNIT_RATIO_LIMIT < level.unit_ratio < UNIT_RATIO_LIMIT
    check_units([level], "dut", "ref")


def test_swapped_channels_are_refused():
    """DC-coupled 'reference' at +1 g, 'DUT' with none: the user swapped --dut and --reference."""
    rec = _record("random", ref_dc=1.0, dut_dc=0.0)
    _, base = _probes(rec)
    with pytest.raises(ValueError, match=r"reference 'ref' reads a static field of \+1 g.*swapped"):
        check_channels(base, "dut", "ref")
    check_channels(base, "dut", "ref", accept=True)
    # the right way round: the DUT reads the field, the reference none
    _, ok = _probes(_record("random"))
    check_channels(ok, "dut", "ref")
    # a horizontal DUT (g0 = 0) with an AC reference: nothing to refuse
    _, flat = _probes(_record("random", dut_dc=0.0))
    check_channels(flat, "dut", "ref")


def test_probe_reads_a_bounded_stretch():
    """The probe reads at most PROBE_SAMPLES, from the middle, whatever the segment's length."""
    calls = []
    rec = _record("sine")

    class Spy:
        fs_hz, n_samples, channels, schedule, meta = rec.fs_hz, rec.n_samples, rec.channels, None, {}

        def blocks(self, block_size, channels, start=0, stop=None):
            calls.append((block_size, start, stop))
            return rec.blocks(block_size, channels, start, stop)

    probe_segment(Spy(), "dut", "ref", 0.0, 8.0, BAND, max_samples=4096)
    assert calls == [(4096, 32000 - 2048, 32000 + 2048)]


def test_a_sequential_record_is_probed_in_one_pass():
    """A CSV file is parsed from its start: its probes are cut from one pass over the record, not
    one pass per probe, and give the same probes as reads by position."""
    from vrelab.analysis.plausibility import probe_segments

    rec = _record("random")
    calls = []

    class Sequential:
        fs_hz, n_samples, channels, schedule, meta = rec.fs_hz, rec.n_samples, rec.channels, None, {}
        random_access = False

        def blocks(self, block_size, channels, start=0, stop=None):
            calls.append((start, stop))
            return rec.blocks(block_size, channels, start, stop)

    segs = [(0.2, 1.8), (2.5, 5.5), (6.2, 7.8)]
    one_pass = probe_segments(Sequential(), "dut", "ref", segs, BAND, max_samples=4096)
    by_position = probe_segments(rec, "dut", "ref", segs, BAND, max_samples=4096)
    assert len(calls) == 1
    assert one_pass == by_position
