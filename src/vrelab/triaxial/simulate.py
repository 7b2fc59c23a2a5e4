"""A triaxial shaker test, simulated: the drive along x, y, z and each DUT axis's output (SPEC 1.6).

The table moves along x, y and z (the part's frame); an ideal triaxial reference accelerometer
records the vibration ``x(t)`` (3 channels, no gravity) and each DUT axis sees the total
acceleration ``g + x(t)`` (``g`` the static vector) through its triaxial chain
(:mod:`vrelab.triaxial.chain`). Everything streams in blocks: memory does not grow with the
record.

* :func:`direction_blocks`: a single-axis drive (today's synthesis,
  :func:`vrelab.synthesis.random_blocks` or :func:`~vrelab.synthesis.sine_blocks`) applied
  along a unit direction ``d``: ``x(t) = d · s(t)`` (an IEEE 1293 mount angle, a
  :class:`~vrelab.triaxial.profile.TriaxialSine`).
* :func:`simulate_direction`: that drive plus the static vector through one or more DUT axes,
  block by block: (reference (3, n), {axis: output}).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterator, Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vrelab import _validate as V
from vrelab.profiles import RandomProfile, SineOnRandom
from vrelab.synthesis import Method as DriveMethod
from vrelab.triaxial.chain import TriaxialRun, triaxial_chain
from vrelab.triaxial.profile import AXES, TriaxialSine, _unit

FloatArray = NDArray[np.float64]

__all__ = ["direction_blocks", "simulate_direction", "DirectionBlock", "static_vector", "axis_runs"]

# Internal samples per simulated block (as vrelab.simulation.record.BLOCK_INTERNAL).
BLOCK = 1 << 16


def static_vector(value: ArrayLike | None) -> FloatArray:
    """The static acceleration (x, y, z) [g] in the part's frame; None: 1 g along +z (the part
    flat on the table, z up)."""
    if value is None:
        return np.array([0.0, 0.0, 1.0])
    g = np.asarray(value, dtype=np.float64).ravel()
    if g.size != 3 or not np.isfinite(g).all():
        raise ValueError(f"static vector must be three finite numbers (x, y, z) in g, got {value!r}")
    return g


def direction_blocks(
    excitation: RandomProfile | SineOnRandom | TriaxialSine,
    fs_hz: float,
    n_samples: int,
    block_size: int,
    seed: int,
    direction: ArrayLike | None = None,
    method: DriveMethod = "gaussian",
) -> Iterator[FloatArray]:
    """A single-axis drive along a direction: (3, n) blocks of ``d · s(t)`` [g].

    Parameters
    ----------
    excitation : RandomProfile, SineOnRandom or TriaxialSine
        A random profile (its grms the rms along ``d``), or a sine along its own direction.
    fs_hz : float
        Sample rate [Hz].
    n_samples, block_size : int
        Record and block length [samples]; the values do not depend on ``block_size``.
    seed : int
        Seed of the random drive (:func:`vrelab.synthesis.random_blocks`); a sine starts at phase 0.
    direction : array_like (3,), optional
        The direction (normalised here); required for a random profile, and for a sine must
        be left out (its own direction is used).
    method : {"gaussian", "multisine"}
        The random drive's synthesis.
    """
    from vrelab import synthesis

    if isinstance(excitation, TriaxialSine):
        if direction is not None:
            raise ValueError("a TriaxialSine carries its own direction: leave direction out")
        d = np.asarray(excitation.direction, dtype=np.float64)
        blocks = synthesis.sine_blocks(excitation.freq_hz, excitation.rms_g, fs_hz, n_samples, block_size)
    elif isinstance(excitation, (RandomProfile, SineOnRandom)):
        if direction is None:
            raise ValueError("a random profile along a direction needs the direction (x, y, z)")
        d = _unit(direction)
        blocks = synthesis.random_blocks(excitation, fs_hz, n_samples, block_size, seed, method)
    else:
        raise ValueError(f"excitation must be a RandomProfile, SineOnRandom or TriaxialSine, "
                         f"got {type(excitation).__name__}")
    for s in blocks:
        yield d[:, None] * s[None, :]


@dataclass(frozen=True)
class DirectionBlock:
    """One block of a simulated triaxial test: the reference (3, n) at the internal rate (the
    vibration along x, y, z, no gravity) and each DUT axis's output at its output rate."""

    reference: FloatArray
    dut: Mapping[str, FloatArray]


def _axis_sensors(sensors: Any) -> dict[str, Any]:
    """{axis name: Sensor} from one Sensor or a sequence of them (one per axis)."""
    seq = [sensors] if hasattr(sensors, "stages") else list(sensors)
    if not seq:
        raise ValueError("simulate needs at least one DUT axis (a Sensor)")
    out: dict[str, Any] = {}
    for s in seq:
        if not hasattr(s, "stages") or not hasattr(s, "triad"):
            raise ValueError(f"a DUT axis must be a vrelab Sensor, got {type(s).__name__}")
        _ = s.triad  # raises for an axis not named x, y or z
        if s.axis in out:
            raise ValueError(f"DUT axis {s.axis} given twice")
        out[s.axis] = s
    return out


def axis_runs(sensors: Mapping[str, Any], fs_hz: float, seed: np.random.SeedSequence) -> dict[str, TriaxialRun]:
    """A triaxial run per DUT axis; axis ``a`` of (x, y, z) takes child ``AXES.index(a)`` of ``seed``
    (its noise is independent of the other axes' and does not change with which axes run)."""
    ents = seed
    runs = {}
    for a, s in sensors.items():
        child = np.random.SeedSequence(entropy=ents.entropy, spawn_key=(*ents.spawn_key, AXES.index(a)))
        runs[a] = triaxial_chain(s, fs_hz).start(fs_hz, child)
    outs = {r.fs_out_hz for r in runs.values()}
    if len(outs) > 1:
        raise ValueError(f"the DUT axes must share one output rate at {fs_hz:g} Hz, got {sorted(outs)} Hz")
    return runs


def simulate_direction(
    sensors: Any,
    excitation: RandomProfile | SineOnRandom | TriaxialSine,
    n_samples: int,
    *,
    direction: ArrayLike | None = None,
    static_g: ArrayLike | None = None,
    fs_hz: float | None = None,
    seed: int = 0,
    method: DriveMethod = "gaussian",
    block_size: int = BLOCK,
) -> Iterator[DirectionBlock]:
    """A single-axis drive along a direction, plus the static vector, through each DUT axis.

    Parameters
    ----------
    sensors : Sensor or sequence of Sensors
        The DUT axes (one Sensor per axis, e.g. ``load_sensor(..., axis=a)`` for a of x, y, z).
    excitation, direction, method : as :func:`direction_blocks`.
    n_samples : int
        Record length at the internal rate [samples] (a multiple of the decimation keeps the
        output's length exact).
    static_g : array_like (3,), optional
        Static acceleration (x, y, z) [g]; default 1 g along +z.
    fs_hz : float, optional
        Internal rate; default the one rate rule (:func:`vrelab.rates.simulation_rate_hz`) of
        the first axis for the drive's highest frequency.
    seed : int
        Root of every random draw: ``SeedSequence(seed)`` spawns the chains' seed (each axis a
        child of it, see :func:`axis_runs`) and the drive's.

    Yields
    ------
    DirectionBlock
        Blocks of ``block_size`` internal samples (the last may be shorter).
    """
    axes = _axis_sensors(sensors)
    g = static_vector(static_g)
    n = V.integer("n_samples", n_samples, 0)
    bs = V.integer("block_size", block_size, 1)
    sd = V.integer("seed", seed, 0)
    f_max = excitation.freq_hz if isinstance(excitation, TriaxialSine) else excitation.band[1]
    if isinstance(excitation, SineOnRandom):
        f_max = max(f_max, max(t.freq_hz for t in excitation.tones))
    first = next(iter(axes.values()))
    fs = float(first.internal_rate_hz(f_max)) if fs_hz is None else V.positive_scalar("fs_hz", fs_hz)
    chain_seed, drive_seed = np.random.SeedSequence(sd).spawn(2)
    runs = axis_runs(axes, fs, chain_seed)
    drive_int = int(drive_seed.generate_state(1, np.uint32)[0])
    for x in direction_blocks(excitation, fs, n, bs, drive_int, direction, method):
        a = x + g[:, None]
        yield DirectionBlock(x, {ax: r.process(a) for ax, r in runs.items()})

