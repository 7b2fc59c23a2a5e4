"""A triaxial profile measured from a recording, and triaxial recordings reduced per axis.

Known truth: three channels made of two independent white noises through known filters and a
known mixing; their cross-spectral matrix is ``S_jk = (2/fs)·Σ_s T_js T_ks*`` (one-sided, unit
variance white noise) with ``T`` the filters' responses from scipy.signal.freqz, independent of
the estimator. The estimator's expectation is the band mean of the true CSD over the Welch bins
of each band (vrelab.triaxial.recording docstring), so that is the truth its u is held against.
Uncertainty formulas: Bendat & Piersol, Random Data, 4th ed., Table 9.6.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import h5py
import numpy as np
import pytest
import scipy.signal as ss

import vrelab
from vrelab.analysis.options import ReductionOptions
from vrelab.record import ArrayRecord
from vrelab.triaxial.recording import CsdAccumulator, measure_csd, read_recording_profile

FS = 1024.0
B1, A1 = ss.butter(2, [20, 300], "bandpass", fs=FS)
B2, A2 = ss.butter(2, 200, fs=FS)
BG, AG = ss.butter(1, 100, fs=FS)  # z sees source 1 through a further low-pass: z lags x


def _signals(seed: int, n: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    n1, n2 = rng.standard_normal((2, n + 4096))
    u1 = ss.lfilter(B1, A1, n1)
    u2 = ss.lfilter(B2, A2, n2)
    g = ss.lfilter(BG, AG, u1)
    return np.column_stack([u1, 0.7 * u1 + u2, g + 0.5 * u2])[4096:]  # filters' start-up dropped


def _true_csd(f: np.ndarray) -> np.ndarray:
    _, h1 = ss.freqz(B1, A1, worN=f, fs=FS)
    _, h2 = ss.freqz(B2, A2, worN=f, fs=FS)
    _, g = ss.freqz(BG, AG, worN=f, fs=FS)
    t = np.zeros((f.size, 3, 2), complex)
    t[:, :, 0] = np.column_stack([h1, 0.7 * h1, h1 * g])
    t[:, :, 1] = np.column_stack([0 * h2, h2, 0.5 * h2])
    return 2.0 / FS * np.einsum("mjs,mks->mjk", t, t.conj())


def _band_truth(m) -> np.ndarray:
    fb = np.fft.rfftfreq(m.nperseg, 1 / FS)
    s = _true_csd(fb)
    e = m.band_edges_hz
    out = []
    for i in range(len(m.freq_hz)):
        hi = (fb <= e[i + 1]) if i == len(m.freq_hz) - 1 else (fb < e[i + 1])
        out.append(s[(fb >= e[i]) & hi].mean(axis=0))
    return np.asarray(out)


def _blocks(a: np.ndarray, size: int = 10007):
    for i in range(0, a.shape[0], size):
        yield a[i:i + size]


def test_streamed_csd_is_scipy_csd_of_the_whole_record():
    a = _signals(0, 40000)
    acc = CsdAccumulator(FS, 512)
    for b in _blocks(a, 3001):
        acc.add(b)
    for j in range(3):
        for k in range(3):
            # scipy's Pxy = conj(X)·Y: S_jk = E[A_j A_k*] is csd(x=channel k, y=channel j)
            _, p = ss.csd(a[:, k], a[:, j], FS, nperseg=512)
            np.testing.assert_allclose(acc.csd[:, j, k], p, rtol=1e-9, atol=1e-12 * np.abs(p).max())
    assert acc.n_segments == (40000 - 512) // 256 + 1


def test_phase_positive_when_the_second_axis_lags():
    rng = np.random.default_rng(7)
    x = rng.standard_normal(70000)
    a = np.column_stack([x[2:], x[:-2], rng.standard_normal(x.size - 2)])  # y = x delayed by 2 samples
    m = measure_csd(_blocks(a), FS, (20, 200), 3)
    expected = 360.0 * m.freq_hz * 2 / FS  # ω·τ at the band centres
    assert np.all(m.phase_deg[:, 0, 1] > 0)
    np.testing.assert_allclose(m.phase_deg[:, 0, 1], expected, rtol=0.05)
    assert np.all(m.coherence[:, 0, 1] > 0.95)


def test_csd_estimate_coverage_over_seeds():
    z = {"psd": [], "coherence": [], "phase": []}
    for seed in range(10):
        m = measure_csd(_blocks(_signals(100 + seed, 65536)), FS, (20, 400), 3)
        s = _band_truth(m)
        p = np.real(np.diagonal(s, axis1=1, axis2=2))
        z["psd"].append(((m.psd - p) / m.u_psd).ravel())
        g2 = np.abs(s) ** 2 / (p[:, :, None] * p[:, None, :])
        for j, k in ((0, 1), (0, 2), (1, 2)):
            z["coherence"].append((m.coherence[:, j, k] - g2[:, j, k]) / m.u_coherence[:, j, k])
            d = (m.phase_deg[:, j, k] - np.degrees(np.angle(s[:, j, k])) + 180) % 360 - 180
            ok = g2[:, j, k] > 0.05
            z["phase"].append((d / m.u_phase_deg[:, j, k])[ok])
    assert m.n_averages.min() > 100  # the stated number of averages
    for what, parts in z.items():
        zz = np.concatenate(parts)
        assert zz.size > 300
        inside = float(np.mean(np.abs(zz) < 2))
        spread = float(np.sqrt(np.mean(zz**2)))
        assert 0.88 <= inside <= 0.995, (what, inside)  # about 95 % within 2u: u neither too small nor too large
        assert 0.75 <= spread <= 1.3, (what, spread)


def test_measured_profile_is_a_valid_triaxial_profile():
    m = measure_csd(_blocks(_signals(3, 65536)), FS, (20, 400), 3)
    prof = m.profile
    np.testing.assert_allclose(prof.axis_psd_g2_per_hz, m.psd)
    np.testing.assert_allclose(np.abs(prof.coherency[:, 0, 2]) ** 2, m.coherence[:, 0, 2], rtol=1e-12)
    d = m.to_dict()
    assert d["welch"]["n_segments"] == m.n_segments and len(d["n_averages"]) == len(m.freq_hz)


def _write_files(tmp_path, a):
    from nptdms import ChannelObject, GroupObject, TdmsWriter

    h5 = tmp_path / "ref.h5"
    with h5py.File(h5, "w") as f:
        f.attrs["fs_hz"] = FS
        for name, col in zip(("ax", "ay", "az"), a.T):
            f[name] = col
    td = tmp_path / "ref.tdms"
    props = {"wf_increment": 1.0 / FS, "wf_start_offset": 0.0, "unit_string": "g"}
    with TdmsWriter(td) as w:
        w.write_segment([GroupObject("ref")] + [ChannelObject("ref", name, np.ascontiguousarray(col), properties=props)
                                                 for name, col in zip(("ax", "ay", "az"), a.T)])
    return h5, td


def test_recording_files_give_the_arrays_csd(tmp_path):
    a = _signals(5, 20000)
    direct = measure_csd(_blocks(a), FS, (20, 400), 3)
    for path in _write_files(tmp_path, a):
        m = read_recording_profile(path, ["ax", "ay", "az"], (20, 400), 3)
        np.testing.assert_allclose(m.csd, direct.csd, rtol=1e-9, atol=1e-15)
        np.testing.assert_allclose(m.n_averages, direct.n_averages)


def test_recording_bad_inputs(tmp_path):
    a = _signals(5, 4000)
    h5, _ = _write_files(tmp_path, a)
    with pytest.raises(ValueError, match="three channels"):
        read_recording_profile(h5, ["ax", "ay"], (20, 400))
    with pytest.raises(ValueError, match="too short"):
        read_recording_profile(h5, ["ax", "ay", "az"], (20, 400), nperseg=8192)
    with pytest.raises(ValueError, match="Nyquist"):
        read_recording_profile(h5, ["ax", "ay", "az"], (20, 900))
    bad = a.copy()
    bad[100, 1] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        measure_csd([bad], FS, (20, 400))


# --- triaxial recordings reduced per axis ---------------------------------------------------

K2 = 2e-3  # 1/g
KXZ = 5e-3  # 1/g: DUT x reads K2·x² + KXZ·x·z (a cross-coupling term, SPEC 1.6)
MIX = np.array([[1.0, 0.0], [0.0, 0.0], [0.8, 0.6]])  # x = n1, y still, z = 0.8 n1 + 0.6 n2: E[xz] = 0.8 σ²


def _shaker_record(seed: int, fs: float = 2048.0, seg_s: float = 6.0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    b, a = ss.butter(4, [50, 500], "bandpass", fs=fs)
    chunks = []
    for level in (0.0, 1.0, 0.0, 2.0, 0.0):
        n = int(seg_s * fs)
        w = ss.lfilter(b, a, rng.standard_normal((2, n + 2000)))[:, 2000:]
        w /= w.std(axis=1, keepdims=True)
        chunks.append(level * (MIX @ w))
    acc = np.concatenate(chunks, axis=1)
    x, y, z = acc
    noise = lambda: 1e-4 * rng.standard_normal(x.size)  # noqa: E731
    return {"rx": x + noise(), "ry": y + noise(), "rz": z + noise(),
            "dx": x + K2 * x**2 + KXZ * x * z + noise(), "dy": y + K2 * y**2 + noise(),
            "dz": z + K2 * z**2 + 1.0 + noise()}


def test_triaxial_reduction_recovers_the_cross_axis_vrc():
    rec = ArrayRecord(_shaker_record(11), 2048.0)
    res = vrelab.analyze(rec, {"x": "dx", "y": "dy", "z": "dz"}, {"x": "rx", "y": "ry", "z": "rz"},
                         options=ReductionOptions(band_hz=(20, 800)))
    by = res.axes
    # truth per g² of total mean square (σx² = σz² = L², E[xz] = 0.8 L², σ_total² = 2 L²)
    truth = {"x": (K2 + 0.8 * KXZ) / 2 * 1e6, "y": 0.0, "z": K2 / 2 * 1e6}
    for axis, want in truth.items():
        fit = next(f for f in by[axis].fits if f.model.name == "vrc").params["vrc_ug_per_g2"]
        assert abs(fit.value - want) < 3 * fit.u + 1e-3, (axis, fit.value, fit.u, want)
        assert not any(f.model.name.startswith("clip") for f in by[axis].fits)  # the rail is not fitted
    for lv, level in zip(res.reference_levels, (1.0, 2.0)):
        assert lv.rms_g == pytest.approx(math.sqrt(2) * level, rel=0.03)
        assert lv.axis_rms_g[1] < 1e-3
        k = np.argmin(np.abs(lv.csd.freq_hz - 150))
        assert lv.csd.coherence[k, 0, 2] == pytest.approx(0.64, abs=4 * lv.csd.u_coherence[k, 0, 2])
    for lv in by["x"].levels:
        assert lv.rms_g == pytest.approx(math.sqrt(2) * round(lv.rms_g / math.sqrt(2)), rel=0.03)
    # y's reference axis is still: its levels come from the most moving axis (x and z move alike)
    assert res.triaxial.level_axis["x"] == "x" and res.triaxial.level_axis["z"] == "z"
    assert res.triaxial.level_axis["y"] == res.triaxial.segmenting_axis in ("x", "z")
    assert any("reference axis y is still" in w for w in by["y"].warnings)


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "vrelab", *args], capture_output=True, text=True, env={**os.environ})


def test_cli_analyze_triaxial(tmp_path, capsys):
    from vrelab.cli import main
    data = _shaker_record(12)
    p = tmp_path / "tri.h5"
    with h5py.File(p, "w") as f:
        f.attrs["fs_hz"] = 2048.0
        for k, v in data.items():
            f[k] = v
    run = _cli("analyze", str(p), "--triaxial", "--reference", "rx,ry,rz", "--dut", "x=dx,z=dz", "--band", "20:800",
               "--json", "--out", str(tmp_path / "out"))
    assert run.returncode == 0, run.stderr
    doc = json.loads(run.stdout)
    assert [c["channel"] for c in doc["channels"]] == ["x", "z"]
    lv = doc["channels"][0]["levels"][1]
    assert lv["rms_g"] == pytest.approx(2 * math.sqrt(2), rel=0.03)
    assert set(lv["axis_rms_g"]) == {"x", "y", "z"}
    tri = doc["triaxial"]
    assert tri["reference_channels"] == {"x": "rx", "y": "ry", "z": "rz"}
    csd = tri["levels"][0]["csd"]
    assert {"coherence", "phase_deg", "u_coherence", "u_phase_deg", "n_averages"} <= set(csd)
    assert (tmp_path / "out" / "reference_csd.csv").is_file() and (tmp_path / "out" / "x" / "results.json").is_file()
    for bad, words in ((["--reference", "rx,ry", "--dut", "dx"], "three"),
                       (["--reference", "rx,ry,rz", "--dut", "dx", "--profile", "flat:20-800"], "not supported"),
                       (["--reference", "rx,ry,rz", "--dut", "w=dx"], "AXIS=CHANNEL")):
        code = main(["analyze", str(p), "--triaxial", *bad])  # in-process: a subprocess costs seconds
        err = capsys.readouterr().err
        assert code == 2 and words in err and err.count("\n") == 1 and "Traceback" not in err, err
