"""The analysis's first pass (segmentation.window_pass_many) against each window computed on its
own with plain numpy: sums, extremes, samples on a rail, the reference's AC power in the time
domain (Parseval's other side), its in-band power from numpy's FFT of that window alone, and
the Hann-smoothed DUT series from the kernel's definition. The record is cut in blocks and
chunks that end mid-record and leave a partial last window, so every edge of the pass is
crossed; the numbers do not depend on the block size."""

from __future__ import annotations

import numpy as np
import pytest

from vrelab.analysis import segmentation
from vrelab.analysis.segmentation import SMOOTH_WINDOWS, window_length, window_pass_many
from vrelab.record import ArrayRecord

FS = 1000.0
BAND = (50.0, 300.0)


def _record(n: int, seed: int = 3) -> ArrayRecord:
    rng = np.random.default_rng(seed)
    ref = rng.standard_normal(n) * np.linspace(0.0, 2.0, n)
    a = 1.0 + ref
    clipped = np.clip(a + 1e-3 * a**2 + 1e-4 * rng.standard_normal(n), -1.5, 2.5)
    other = -1.0 + 0.5 * ref + 1e-4 * rng.standard_normal(n)
    return ArrayRecord({"reference": ref, "dut": clipped, "dut:y": other}, FS)


def _by_hand(x: np.ndarray, w: int, ref: np.ndarray, rail_g: float) -> dict[str, np.ndarray]:
    n = len(x)
    starts = np.arange(0, n, w)
    out: dict[str, list[float]] = {k: [] for k in ("count", "sum", "max", "min", "rail", "ac", "band", "rsum")}
    for s in starts:
        seg, r = x[s : s + w], ref[s : s + w]
        L = len(seg)
        out["count"].append(L)
        out["sum"].append(seg.sum())
        out["max"].append(seg.max())
        out["min"].append(seg.min())
        thr = rail_g * (1 - 1e-6)
        out["rail"].append(np.count_nonzero((seg >= thr) | (seg <= -thr)))
        out["ac"].append(np.sum((r - r.mean()) ** 2))  # Parseval: all bins but DC, in the time domain
        X = np.fft.rfft(r)
        f = np.fft.rfftfreq(L, 1 / FS)
        weight = np.where((f >= BAND[0]) & (f <= BAND[1]), 2.0, 0.0)
        weight[0] = 0.0
        if L % 2 == 0 and f[-1] >= BAND[0] and f[-1] <= BAND[1]:
            weight[-1] = 1.0  # the Nyquist bin of an even window counts once
        out["band"].append(np.sum(weight * np.abs(X) ** 2) / L)
        out["rsum"].append(r.sum())
    # the smoothed series: a Hann kernel over 3 windows centred on each, h(i) = sin²(π(i+½)/3w),
    # normalised by the weights present; a partial last window weighs as if it were whole
    h = np.sin(np.pi * (np.arange(SMOOTH_WINDOWS * w) + 0.5) / (SMOOTH_WINDOWS * w)) ** 2
    k = len(starts)
    smooth = np.zeros(k)
    for j in range(k):
        num = den = 0.0
        for q in range(SMOOTH_WINDOWS):
            src = j - SMOOTH_WINDOWS // 2 + q
            if 0 <= src < k:
                seg = x[src * w : src * w + w]
                hq = h[q * w : q * w + w]
                num += np.dot(hq[: len(seg)], seg) * (w / len(seg))
                den += hq.sum()
        smooth[j] = num / den
    return {key: np.array(v) for key, v in out.items()} | {"smooth": smooth}


@pytest.mark.parametrize("cores", [1, 2])
@pytest.mark.parametrize("block", [1 << 18, 7 * 100 + 3])
def test_window_sums_match_each_window_computed_alone(block, cores, monkeypatch):
    n = 12_345  # 123 whole windows of 100 samples and a partial one of 45
    rec = _record(n)
    w = window_length(FS, BAND)
    assert w == 100
    monkeypatch.setattr(segmentation, "CHUNK_SAMPLES", 250)  # chunks of 2 windows inside each block
    monkeypatch.setattr(segmentation, "_cores", lambda: cores)  # 2: the DUTs' statistics in a second thread
    stats = window_pass_many(rec, BAND, ["dut", "dut:y"], block_size=block, rail_g=2.5)
    for d in ("dut", "dut:y"):
        want = _by_hand(rec.data[d], w, rec.data["reference"], 2.5)
        got = stats[d]
        assert got.n_windows == 124
        np.testing.assert_array_equal(got.count, want["count"])
        np.testing.assert_allclose(got.dut_sum, want["sum"], rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(got.dut_max, want["max"])
        np.testing.assert_array_equal(got.dut_min, want["min"])
        np.testing.assert_array_equal(got.n_beyond_rail, want["rail"])
        np.testing.assert_allclose(got.ref_ac_sumsq, want["ac"], rtol=1e-11)
        np.testing.assert_allclose(got.ref_band_sumsq, want["band"], rtol=1e-11)
        np.testing.assert_allclose(got.ref_sum, want["rsum"], rtol=1e-11, atol=1e-11)
        np.testing.assert_allclose(got.dut_smooth, want["smooth"], rtol=1e-12)
    # samples on the DUT's upper rail (2.5 g) counted in every window that reaches it
    sat, notes = stats["dut"].saturated()
    on = stats["dut"].dut_max >= 2.5 * (1 - 1e-6)
    assert on.sum() > 5 and np.all(sat[on] >= want["rail"][on])


def test_block_and_chunk_sizes_change_no_number(monkeypatch):
    rec = _record(20_011, seed=4)
    a = window_pass_many(rec, BAND, ["dut"])["dut"]
    monkeypatch.setattr(segmentation, "CHUNK_SAMPLES", 300)
    b = window_pass_many(rec, BAND, ["dut"], block_size=1_000)["dut"]
    monkeypatch.setattr(segmentation, "_cores", lambda: 1)  # one thread: the same numbers, bit for bit
    c = window_pass_many(rec, BAND, ["dut"], block_size=1_000)["dut"]
    for name in ("count", "dut_sum", "dut_smooth", "dut_max", "dut_min", "ref_ac_sumsq", "ref_band_sumsq", "ref_sum"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    # (the counts at the extremes are kept only in windows at the running extreme, which depends
    # on the blocks; between one and two threads, with the same blocks, nothing may differ)
    for name in ("count", "dut_sum", "dut_smooth", "dut_max", "dut_min", "ref_ac_sumsq", "ref_band_sumsq", "ref_sum",
                 "ref_band_var", "n_at_max", "n_at_min", "n_beyond_rail"):
        np.testing.assert_array_equal(getattr(b, name), getattr(c, name), err_msg=name)


def test_an_error_in_the_dut_thread_reaches_the_caller_and_the_thread_ends(monkeypatch):
    """The DUT statistics run in a second thread: what fails there is raised by the pass, which
    leaves no thread behind (the reference's work on that block is joined first)."""
    import threading

    monkeypatch.setattr(segmentation, "_cores", lambda: 2)
    calls = []

    def boom(self, dv, kk, kern):
        calls.append(threading.current_thread().name)
        raise MemoryError("no room for the window sums")

    monkeypatch.setattr(segmentation._DutWindows, "add", boom)
    with pytest.raises(MemoryError, match="no room"):
        window_pass_many(_record(20_011, seed=4), BAND, ["dut"], block_size=1_000)
    assert calls and calls[0].startswith("vrelab-dut")
    assert not [t for t in threading.enumerate() if t.name.startswith(("vrelab-dut", "vrelab-read"))]


def test_window_times_are_window_centres_and_a_range_is_the_slice_of_all():
    """Window k of w samples (the last partial, 45 of 100) is centred at (k·w + L/2)/fs; the times
    of a range of windows are those of the whole record's, bit for bit (levels use the range)."""
    stats = window_pass_many(_record(12_345), BAND, ["dut"])["dut"]
    w = stats.window
    lengths = np.minimum(w, 12_345 - np.arange(124) * w)
    np.testing.assert_allclose(stats.times_s, (np.arange(124) * w + lengths / 2) / FS, rtol=1e-15)
    assert stats.times_s[-1] == pytest.approx((123 * 100 + 22.5) / FS)
    for k0, k1 in ((0, 124), (5, 17), (100, 124), (30, 30)):
        assert stats.window_times_s(k0, k1).tobytes() == stats.times_s[k0:k1].tobytes()
