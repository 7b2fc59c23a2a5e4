"""The analysis' CSV tables read back for the report (``envelope.csv``, ``psd.csv``), and the
fractional-octave band average a PSD is read against: data, not drawing, so a module apart from
:mod:`vrelab.report.plots` (which re-exports them)."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


def read_envelope_csv(path: str | Path) -> dict[str, FloatArray | list[str]]:
    """Read ``envelope.csv`` (analyze's per-window table) into columns; text columns stay text."""
    path = Path(path)
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    if len(rows) < 2:
        raise ValueError(f"{path.name} has no data rows")
    head = [h.strip() for h in rows[0]]
    cols: dict[str, FloatArray | list[str]] = {}
    for i, h in enumerate(head):
        vals = [r[i].strip() if i < len(r) else "" for r in rows[1:]]
        try:
            cols[h] = np.array([float(v) if v else np.nan for v in vals])
        except ValueError:
            cols[h] = vals
    return cols


def pick_column(cols: Mapping[str, object], *cands: str) -> str | None:
    """The first column named exactly as one of ``cands`` (in their order), else the first whose
    name contains one of them; None if none does."""
    for c in cands:
        for k in cols:
            if k == c:
                return k
    for c in cands:
        for k in cols:
            if c in k:
                return k
    return None


def fractional_octave_average(
    freq_hz: ArrayLike, psd: ArrayLike, fraction: int = 24, *others: ArrayLike
) -> tuple[FloatArray, ...]:
    """Average PSD lines in 1/``fraction``-octave bands (power average, the way analyzers do).

    A short record's fine-resolution PSD scatters by ±5 dB or more line to line (few averages
    per line); a band average has the variance of many lines and is what a ±3 dB tolerance is
    read against. Returns the lines' mean frequency per band, the averaged PSD, and the same
    average of each array in ``others`` (e.g. the profile). Lines with f <= 0 or NaN PSD are
    dropped; empty bands are skipped.
    """
    f = np.asarray(freq_hz, dtype=np.float64)
    arrays = [np.asarray(psd, dtype=np.float64)] + [np.asarray(o, dtype=np.float64) for o in others]
    keep = (f > 0) & np.all([np.isfinite(a) for a in arrays], axis=0)
    f = f[keep]
    arrays = [a[keep] for a in arrays]
    if f.size == 0:
        return (f, *arrays)
    band = np.floor(fraction * np.log2(f / f.min()) + 1e-9).astype(np.int64)
    n = np.bincount(band)
    used = n > 0
    out = [np.bincount(band, weights=f)[used] / n[used]]
    out += [np.bincount(band, weights=a)[used] / n[used] for a in arrays]
    return tuple(out)


def read_psd_csv(path: str | Path) -> dict[str, FloatArray]:
    """Read ``psd.csv`` into ``freq_hz``, ``psd_measured``, ``psd_profile`` (g²/Hz)."""
    cols = read_envelope_csv(path)
    fk = pick_column(cols, "freq_hz", "f_hz", "frequency_hz", "freq")
    mk = pick_column(cols, "psd_measured_g2_per_hz", "psd_measured", "measured", "psd_reference", "reference")
    pk = pick_column(cols, "psd_profile_g2_per_hz", "psd_profile", "profile")
    if fk is None or mk is None or pk is None:
        raise ValueError(f"{Path(path).name}: need frequency, measured and profile PSD columns, got {', '.join(cols)}")
    return {"freq_hz": np.asarray(cols[fk]), "psd_measured": np.asarray(cols[mk]), "psd_profile": np.asarray(cols[pk])}
