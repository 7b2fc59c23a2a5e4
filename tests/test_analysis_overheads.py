"""The reduction's shortcuts past numpy's per-call overhead give what the plain array code gives
(issue 29: the analysis after its first pass, every number the same bits).

Each shortcut is held against the computation it replaced, written here plainly: the same
pieces from binary segmentation whichever way a piece's split is searched, the same probe from
slices as from boolean masks, and an HDF5 channel read without HDF5's chunk cache only when its
chunks are stored uncompressed (a compressed chunk keeps the cache: it would be inflated again
by every read that touches it).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from vrelab.analysis import plausibility as P
from vrelab.analysis import segmentation as S


def _pieces(rng: np.random.Generator, n: int) -> np.ndarray:
    """A log envelope: plateaus, ramps between them, and noise (what auto_segment cuts)."""
    knots = np.sort(rng.choice(np.arange(1, n), size=min(6, n - 1), replace=False))
    levels = rng.normal(0.0, 1.0, size=knots.size + 1)
    x = np.repeat(levels, np.diff(np.concatenate([[0], knots, [n]])))
    ramp = np.convolve(x, np.ones(5) / 5, mode="same")  # edges become short ramps
    return ramp + rng.choice([1e-3, 1e-2, 0.1]) * rng.standard_normal(n)


@pytest.mark.parametrize("seed", range(4))
def test_binary_segmentation_same_pieces_from_the_scalar_and_the_array_search(seed, monkeypatch):
    """Every piece searched by the scalar loop (threshold above any length) and every piece by
    the array code (threshold 0) cut a series into the same pieces: the two searches compute
    each split's gain by the same operations on the same doubles and take the first largest."""
    rng = np.random.default_rng(seed)
    for _ in range(60):
        x = _pieces(rng, int(rng.integers(5, 400)))
        sigma, step = float(rng.uniform(0.0, 0.05)), float(rng.uniform(0.0, 0.1))
        monkeypatch.setattr(S, "_SCALAR_PIECE", 0)
        by_array = S._binary_segmentation(x, sigma, step)
        monkeypatch.setattr(S, "_SCALAR_PIECE", 10**9)
        by_scalar = S._binary_segmentation(x, sigma, step)
        assert by_scalar == by_array
        assert by_array[0][0] == 0 and by_array[-1][1] == len(x)


def _probe_by_masks(fs: float, x_dut: np.ndarray, x_ref: np.ndarray, band: tuple[float, float]) -> tuple[float, ...]:
    """The probe as it was written with boolean masks over the spectrum (the reference)."""
    n = x_dut.size
    ref_dc, dut_dc = float(np.mean(x_ref)), float(np.mean(x_dut))
    win = np.hanning(n)
    freqs = np.fft.rfftfreq(n, 1.0 / fs)
    p_ref = np.abs(np.fft.rfft((x_ref - ref_dc) * win)) ** 2
    p_dut = np.abs(np.fft.rfft((x_dut - dut_dc) * win)) ** 2
    ac = np.arange(freqs.size) > 3
    total_ac = float(p_ref[ac].sum())
    k_peak = int(np.flatnonzero(ac)[np.argmax(p_ref[ac])])
    line = slice(max(0, k_peak - 3), k_peak + 4)
    fraction = float(p_ref[line].sum()) / total_ac
    in_band = ac & (freqs >= band[0]) & (freqs <= band[1])
    ratio_hz = float(freqs[k_peak])
    sel = np.zeros_like(ac)
    if fraction >= P.SINE_LINE_FRACTION or not in_band.any() or float(p_ref[in_band].sum()) <= 0:
        sel[line] = True
    else:
        k_in = np.flatnonzero(in_band)
        total = float(p_ref[k_in].sum())
        n_low = max(8, int(np.searchsorted(np.cumsum(p_ref[k_in]), P.LOW_POWER_SHARE * total)) + 1)
        sel[k_in[:n_low]] = True
        ratio_hz = float((freqs[sel] * p_ref[sel]).sum() / p_ref[sel].sum())
    return (float(freqs[k_peak]), fraction, math.sqrt(float(p_ref[sel].sum())), math.sqrt(float(p_dut[sel].sum())),
            ref_dc, dut_dc, ratio_hz)


@pytest.mark.parametrize("kind", ["random", "sine", "below-band"])
def test_probe_from_slices_is_the_probe_from_masks(kind):
    """The bins a probe sums are contiguous runs (the frequencies rise with the index): taken as
    slices they give every field of the probe in the same bits as the masked copies."""
    rng = np.random.default_rng(11)
    fs = 4000.0
    for n in (8192, 8000, 4096, 1000, 37):  # 8000: the band edges fall on bins (0.5 Hz apart)
        t = np.arange(n + 1) / fs
        if kind == "random":
            x = rng.standard_normal(n + 1)
        else:
            f0 = 160.0 if kind == "sine" else 12.0
            x = np.sin(2 * np.pi * f0 * t) + 1e-3 * rng.standard_normal(n + 1)
        ref, dut = x[1:], 1.02 * x[1:] + 1.0  # an unaligned view, as a block's slice may be
        for band in ((50.0, 2000.0), (50.0, 60.0)):  # a narrow band: its top edge moves the low lines' share
            probe = P._probe_arrays(fs, 0.0, 1.0, dut, ref, band)
            got = (probe.peak_hz, probe.line_fraction, probe.ref_rms_g, probe.dut_rms_g, probe.ref_dc_g,
                   probe.dut_dc_g, probe.ratio_hz)
            assert [repr(v) for v in got] == [repr(v) for v in _probe_by_masks(fs, dut, ref, band)]


def test_hdf5_uncompressed_chunks_are_read_past_the_chunk_cache(tmp_path):
    """An uncompressed chunked channel is opened with no chunk cache (a read copies no chunk
    whole); a compressed one keeps the file's (each chunk inflated once); both read the file's
    values."""
    h5py = pytest.importorskip("h5py")
    from vrelab.analysis.readers import open_record

    rng = np.random.default_rng(3)
    ref, dut = rng.standard_normal(20000), 1.0 + 1e-3 * rng.standard_normal(20000)
    path = tmp_path / "rec.h5"
    with h5py.File(path, "w") as f:
        f.attrs["fs_hz"] = 1000.0
        f.create_dataset("reference", data=ref, chunks=(4096,))
        f.create_dataset("dut", data=dut, chunks=(4096,), compression="gzip")
    with open_record(path, "dut", "reference") as rec:
        cache = {c: rec.source.specs[c][0].id.get_access_plist().get_chunk_cache()[1] for c in ("dut", "reference")}
        assert cache["reference"] == 0
        assert cache["dut"] > 0
        got = {c: np.concatenate([b[c] for b in rec.blocks(3000, ["dut", "reference"], 123, 19000)])
               for c in ("dut", "reference")}
    np.testing.assert_array_equal(got["reference"], ref[123:19000])
    np.testing.assert_array_equal(got["dut"], dut[123:19000])
