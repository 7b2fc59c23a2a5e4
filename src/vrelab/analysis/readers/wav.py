"""WAV (RIFF, RIFX, RF64, WAVE_FORMAT_EXTENSIBLE; PCM 8/16/24/32-bit and IEEE float) through
soundfile (libsndfile), read by seeking: memory follows the block read, not the file.

libsndfile reads the chunks audio and recorder software write around the samples (LIST, bext,
fact, PEAK, junk, cue, acid, ...); only a data chunk shorter than its header says (a truncated
file) is refused: libsndfile would read on, and a shorter record is not the recorded test.

Integer PCM is returned as counts at the file's bit depth (8-bit WAV is unsigned with an offset of
128: counts are value - 128; a 24-bit sample is -8388608..8388607; a 27-bit sample in a 32-bit
word is read as its 32-bit word), which need a sensitivity in LSB/g (``--dut-units lsb``).
Without soundfile, ``scipy.io.wavfile`` reads the plain layouts (memory-mapped where it can).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from vrelab.analysis.readers._base import (
    Source,
    register,
)

# bits per integer sample of each libsndfile PCM subtype (counts are the left-justified int32
# libsndfile gives, shifted down to these bits)
_PCM_BITS = {"PCM_U8": 8, "PCM_S8": 8, "PCM_16": 16, "PCM_24": 24, "PCM_32": 32}
# libsndfile's log when a chunk's size in the header exceeds what the file holds
_SHORT = re.compile(r"^data\s*:\s*(\d+)\s*\(should be (\d+)\)", re.MULTILINE)
_UNSET = (0, 0xFFFFFFFF)  # a data size a streaming writer leaves before it finalizes the file


class _Unopened(ValueError):
    """libsndfile could not open the file at all."""


@register
class WavSource(Source):
    fmt = "wav"
    extensions = (".wav", ".wave")

    @classmethod
    def can_open(cls, head: bytes) -> bool:
        return head[:4] in (b"RIFF", b"RF64", b"RIFX") and head[8:12] == b"WAVE"

    @classmethod
    def open(cls, path: Path) -> Source:
        try:
            import soundfile  # noqa: F401
        except (ImportError, OSError):  # no soundfile, or no libsndfile behind it
            return ScipyWavSource(path)
        try:
            return cls(path)
        except _Unopened as exc:
            # a header libsndfile refuses (a corrupt rate: physics §4.2 lets --fs override it) may
            # still be read by scipy; if neither can, libsndfile's reason is the one given
            try:
                return ScipyWavSource(path)
            except ValueError:
                raise ValueError(str(exc)) from None

    def __init__(self, path: Path) -> None:
        import soundfile as sf

        super().__init__(path)
        try:
            self.f = sf.SoundFile(str(path))
        except Exception as exc:  # soundfile.LibsndfileError (a RuntimeError) on a bad file
            msg = str(exc).replace(f"Error opening {str(path)!r}: ", "")
            raise _Unopened(f"{path.name}: cannot read WAV (truncated or corrupt?): {msg}") from None
        m = _SHORT.search(self.f.extra_info)
        if m and int(m.group(1)) not in _UNSET and int(m.group(1)) > int(m.group(2)):
            self.f.close()
            raise ValueError(f"{path.name}: WAV data chunk is truncated: the header says {int(m.group(1))} bytes, "
                             f"the file holds {int(m.group(2))}")
        if m and int(m.group(1)) in _UNSET:
            self.notes.append(f"WAV data chunk size not set in the header (a recording not finalized): "
                              f"{self.f.frames} frames read, as many as the file holds")
        self.bits = _PCM_BITS.get(self.f.subtype)
        if self.f.subtype not in _PCM_BITS and self.f.subtype not in ("FLOAT", "DOUBLE"):
            self.f.close()
            raise ValueError(f"{path.name}: WAV holds {self.f.subtype} samples (compressed): vrelab reads PCM "
                             "or IEEE float WAV")
        self.fs_hz = float(self.f.samplerate)
        for i in range(self.f.channels):
            self.lengths[str(i)] = int(self.f.frames)
        if self.bits:
            self.notes.append(f"WAV holds {self.bits}-bit PCM counts ({self.f.subtype}): give the sensitivity "
                              "in LSB/g to scale to g")

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        self.f.seek(int(start))
        n = int(stop - start)
        # soundfile has no type hints: its read gives the dtype asked for, (frames, channels)
        if self.bits:
            raw: NDArray[np.int32] = self.f.read(n, dtype="int32", always_2d=True)[:, int(name)]
            return (raw >> (32 - self.bits)).astype(np.int32)
        samples: NDArray[np.float64] = self.f.read(n, dtype="float64", always_2d=True)[:, int(name)]
        return samples

    def is_integer(self, name: str) -> bool:
        return self.bits is not None

    def close(self) -> None:
        self.f.close()


class ScipyWavSource(Source):
    """WAV through ``scipy.io.wavfile`` (when soundfile is not installed): memory-mapped where
    scipy can; chunks scipy does not know are skipped, a short data chunk is refused."""

    fmt = "wav"

    def __init__(self, path: Path) -> None:
        import warnings

        from scipy.io import wavfile

        super().__init__(path)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", wavfile.WavFileWarning)
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
            except (ValueError, ArithmeticError, OSError, EOFError) as exc:
                raise ValueError(f"{path.name}: cannot read WAV (truncated or corrupt?): {exc}") from None
        for w in caught:
            # scipy warns and reads on when the file ends before the header's sizes: truncated
            if "prematurely" in str(w.message):
                raise ValueError(f"{path.name}: cannot read WAV (truncated): {w.message}")
        self.fs_hz = float(rate)
        self.data = data
        self.offset = 128 if data.dtype == np.uint8 else 0  # 8-bit WAV is unsigned about 128
        self.shift = 8 if data.dtype == np.int32 and _bits(path) == 24 else 0  # scipy left-justifies 24-bit
        cols = data.shape[1] if data.ndim == 2 else 1
        for i in range(cols):
            self.lengths[str(i)] = int(data.shape[0])
        self.notes.append("WAV read by scipy (pip install soundfile reads every WAV layout)")
        if data.dtype.kind in "iu":
            self.notes.append(f"WAV holds {data.dtype} PCM counts: give the sensitivity in LSB/g to scale to g")

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        i = int(name)
        x = np.array(self.data[start:stop, i] if self.data.ndim == 2 else self.data[start:stop])
        if self.offset:
            return x.astype(np.int16) - self.offset
        return x >> self.shift if self.shift else x


def _bits(path: Path) -> int:
    """wBitsPerSample of the fmt chunk (scipy does not return it)."""
    with open(path, "rb") as fh:
        head = fh.read(4096)
    i = head.find(b"fmt ")
    if i < 0:
        return 0
    order: Literal["big", "little"] = "big" if head[:4] == b"RIFX" else "little"
    return int.from_bytes(head[i + 22 : i + 24], order)
