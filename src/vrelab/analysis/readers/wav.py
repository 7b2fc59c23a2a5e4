"""WAV (PCM, IEEE float, RF64) through ``scipy.io.wavfile`` (memory-mapped where scipy can)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vrelab.analysis.readers._base import (
    Source,
    register,
)


@register
class WavSource(Source):
    fmt = "wav"
    extensions = (".wav", ".wave")

    @classmethod
    def can_open(cls, head: bytes) -> bool:
        return head[:4] in (b"RIFF", b"RF64", b"RIFX") and head[8:12] == b"WAVE"

    def __init__(self, path: Path) -> None:
        import warnings

        from scipy.io import wavfile

        super().__init__(path)
        with warnings.catch_warnings():
            # scipy warns (and reads on) when the data is shorter than the header says: a
            # truncated file, refused here rather than read as a shorter record
            warnings.simplefilter("error", wavfile.WavFileWarning)
            try:
                try:
                    rate, data = wavfile.read(path, mmap=True)
                except ValueError as exc:
                    if "mmap" not in str(exc):
                        raise
                    rate, data = wavfile.read(path, mmap=False)
                    self.notes.append(f"WAV read whole into memory (scipy cannot memory-map it: {exc})")
            except MemoryError:
                raise
            except (ValueError, wavfile.WavFileWarning, ArithmeticError, OSError, EOFError) as exc:
                raise ValueError(f"{path.name}: cannot read WAV (truncated or corrupt?): {exc}") from None
        self.fs_hz = float(rate)
        self.data = data
        cols = data.shape[1] if data.ndim == 2 else 1
        for i in range(cols):
            self.lengths[str(i)] = int(data.shape[0])
        if data.dtype.kind in "iu":
            self.notes.append(f"WAV holds {data.dtype} PCM counts: give the sensitivity in LSB/g to scale to g")

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        i = int(name)
        return np.array(self.data[start:stop, i] if self.data.ndim == 2 else self.data[start:stop])
