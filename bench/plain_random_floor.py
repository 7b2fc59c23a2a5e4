"""The floor of a random-method reduction: the same work as ``vrelab analyze --method random``,
written plainly with numpy and h5py (issue 29: the analysis is held against this, not against
a bare read, because it must take every reference sample's spectrum for the level's u).

The work, and nothing else:

1. read the two channels in blocks (h5py);
2. per window (1 s by default) the reference's band power from its Hann-windowed rfft
   (Parseval: ``mean square ≈ 2·Σ_band |X_k|² / (N·Σ h²)``) and the DUT's mean;
3. windows grouped into levels: vibration-off windows below OFF_RMS_G; a level is a run of
   vibration-on windows, less the ramp windows more than STEADY from the run's median rms;
   the windows at each run's edges are dropped (settling);
4. each level's mean offset against the vibration-off windows: the level's DUT mean minus the
   off-runs' means before and after, linearly interpolated to the level's centre.

No uncertainties, no fits, no checks: a floor of CPU, not a reduction anyone should use. It
prints one JSON line: the levels' rms [g] and offsets [g] (the bench compares them with the
analysis's, so that the two did the same work).

    python bench/plain_random_floor.py FILE.h5 [--dut dut] [--reference reference] [--window-s 1]
"""

from __future__ import annotations

import argparse
import json

import h5py
import numpy as np

BAND_HZ = (50.0, 2000.0)  # vrelab's default test band (analysis.options.DEFAULT_BAND_HZ)
OFF_RMS_G = 0.02  # below: vibration off (the bench's lowest level is 0.1 g)
STEADY = 0.1  # a level's window within 10 % of its run's median rms
EDGE_WINDOWS = 1  # dropped at each end of a run (settling)
BLOCK_WINDOWS = 64


def window_series(path: str, dut: str, reference: str, window_s: float) -> tuple[float, np.ndarray, np.ndarray]:
    """(window length [s], reference band mean square per window [g²], DUT mean per window [g])."""
    with h5py.File(path, "r") as f:
        fs = float(f.attrs["fs_hz"])
        r, d = f[reference], f[dut]
        w = int(round(window_s * fs))
        hann = np.hanning(w)
        k = np.fft.rfftfreq(w, 1.0 / fs)
        band = (k >= BAND_HZ[0]) & (k <= BAND_HZ[1])
        scale = 2.0 / (w * float(hann @ hann))
        n = r.shape[0] // w * w
        step = BLOCK_WINDOWS * w
        power, mean = [], []
        for i in range(0, n, step):
            a = r[i : min(i + step, n)].reshape(-1, w)
            b = d[i : min(i + step, n)].reshape(-1, w)
            x = np.fft.rfft(a * hann, axis=1)[:, band]
            power.append((x.real**2 + x.imag**2).sum(axis=1) * scale)
            mean.append(b.mean(axis=1))
    return w / fs, np.concatenate(power), np.concatenate(mean)


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) of each run of True."""
    edges = np.flatnonzero(np.diff(np.concatenate(([0], mask.astype(np.int8), [0]))))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist()))


def levels(window_s: float, power: np.ndarray, mean: np.ndarray) -> list[dict[str, float]]:
    rms = np.sqrt(power)
    off = rms < OFF_RMS_G
    offs = []  # (centre time, DUT mean) of each vibration-off run
    for a, b in runs(off):
        a, b = a + EDGE_WINDOWS, b - EDGE_WINDOWS
        if b > a:
            offs.append(((a + b) / 2 * window_s, float(mean[a:b].mean())))
    t_off = np.array([t for t, _ in offs])
    m_off = np.array([m for _, m in offs])
    out = []
    for a, b in runs(~off):
        a, b = a + EDGE_WINDOWS, b - EDGE_WINDOWS
        if b - a < 3:
            continue
        steady = np.abs(rms[a:b] / np.median(rms[a:b]) - 1.0) < STEADY
        idx = a + np.flatnonzero(steady)
        t = float(idx.mean() + 0.5) * window_s
        j = int(np.searchsorted(t_off, t))
        if j == 0 or j == len(t_off):
            continue  # not bracketed by vibration-off stretches
        lam = (t - t_off[j - 1]) / (t_off[j] - t_off[j - 1])
        base = (1 - lam) * m_off[j - 1] + lam * m_off[j]
        out.append({"rms_g": float(np.sqrt(power[idx].mean())), "vre_g": float(mean[idx].mean() - base)})
    return out


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("path")
    p.add_argument("--dut", default="dut")
    p.add_argument("--reference", default="reference")
    p.add_argument("--window-s", type=float, default=1.0)
    args = p.parse_args(argv)
    window_s, power, mean = window_series(args.path, args.dut, args.reference, args.window_s)
    print(json.dumps({"levels": levels(window_s, power, mean)}))


if __name__ == "__main__":
    main()
