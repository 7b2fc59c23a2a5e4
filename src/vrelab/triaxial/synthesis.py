"""A Gaussian triaxial (MIMO) drive with a prescribed 3×3 cross-spectral density, in blocks.

A shaker controller driving three axes at once shapes three independent white noises
``w_m(t)`` into the table's motion ``x_j(t) = Σ_m (L_jm * w_m)(t)`` with a matrix of filters
whose response ``L(f)`` factors the target: ``L(f) L(f)ᴴ · 2/fs = S(f)`` (white noise of unit
variance has the one-sided PSD 2/fs). Here:

* **the factor** is ``L = D · chol(C̃)``: ``D = diag(√(P̄_j·fs/2))`` the per-axis amplitude
  (``P̄_j`` the profile's mean PSD over each FFT bin, closed-form areas:
  :func:`vrelab.synthesis.design_fir`'s own bin powers, so each axis's variance is exactly its
  profile mean square, Parseval) and ``chol(C̃)`` the Cholesky factor of the coherency
  ``C(f)`` (unit diagonal, :meth:`TriaxialProfile.csd` normalised) at the bin's centre,
  regularised ``C̃ = (C + εI)/(1 + ε)`` with ε = 1e-9 so fully coherent axes (a singular C)
  factor too, at the price of an incoherent floor of relative power ~2ε, and the unit diagonal
  (each axis's variance) is kept. Why Cholesky and not an eigen-factor ``V Λ^½``: the
  eigenvectors carry an arbitrary phase per frequency (and swap order where eigenvalues
  cross), so ``V Λ^½`` jumps from bin to bin and its impulse responses are as long as the
  frame; the Cholesky factor is unique (real positive diagonal) and as smooth in f as C
  itself, so the filters are as compact as the single-axis design's.
* **the filters** are N-tap FIRs by frequency sampling (``irfft`` of ``L`` at the N-point
  bins, delayed N/2 samples), N the single-axis rule (:func:`vrelab.synthesis.design_fir`:
  bins at most f_lo/8 wide): a lower-triangular 3×3 matrix of them; a still axis has none.
* **the streams**: noise stream m is :func:`vrelab.synthesis.random_blocks`'s Gaussian
  stream (overlap-save frames seeded by frame index, so values do not depend on the block
  size and memory does not grow with the record) through each filter of column m; stream m
  is drawn once per filter it feeds (the same seed, the same noise).
* **rank one**: a profile that is one real direction times one PSD (``TriaxialProfile.along``,
  the mount-angle drive) is synthesised as that: ``x = d · s(t)`` with ``s`` today's
  single-axis drive (:func:`direction_blocks`), exactly coherent.

References
----------
.. [1] D. O. Smallwood, "Multiple-input multiple-output (MIMO) linear systems extreme inputs/
   outputs", Shock and Vibration 14 (2007): drive synthesis from a Cholesky factor of the
   spectral density matrix.
.. [2] J. S. Bendat, A. G. Piersol, *Random Data*, 4th ed., Wiley 2010, ch. 9 (coherence and
   cross-spectrum estimates and their random errors).
"""

from __future__ import annotations

import math
from typing import Iterator

import numpy as np
import scipy.fft
from numpy.typing import ArrayLike, NDArray

from vrelab import _validate as V
from vrelab.profiles import RandomProfile, SineOnRandom

# The single-axis design's rules, imported rather than copied (one owner): the FIR length
# (bins at most f_lo/8 wide), each bin's exact mean square, the overlap-save frame size, the
# Gaussian noise stream and the re-chunking into blocks.
from vrelab.synthesis import MIN_FFT, bin_powers, gaussian_frames, rechunk, resolution_length
from vrelab.synthesis import Method as DriveMethod
from vrelab.triaxial.profile import TriaxialProfile, TriaxialSine, unit_vector

FloatArray = NDArray[np.float64]

__all__ = ["design_fir_matrix", "direction_blocks", "triaxial_random_blocks", "triaxial_random_signal", "rank_one", "COHERENCE_EPS"]

# Regularisation of the coherency before its Cholesky factor (see the module docstring): a
# fully coherent pair comes out with coherence 1 - O(ε), far below any estimate's resolution.
COHERENCE_EPS = 1e-9
# Relative tolerance for a profile to count as rank one (a direction times one PSD).
_RANK_ONE_RTOL = 1e-12


def _axis_profile(profile: TriaxialProfile, j: int) -> RandomProfile:
    return RandomProfile(profile.freq_hz, profile.axis_psd_g2_per_hz[:, j])


def _check(profile: TriaxialProfile, fs_hz: float) -> float:
    if not isinstance(profile, TriaxialProfile):
        raise ValueError(f"profile must be a TriaxialProfile, got {type(profile).__name__}")
    fs = V.positive_scalar("fs_hz", fs_hz)
    if profile.band[1] > fs / 2:
        raise ValueError(f"profile band {profile.band[0]:g}-{profile.band[1]:g} Hz exceeds fs_hz/2 = {fs / 2:g} Hz "
                         f"(fs_hz = {fs:g}); raise the sample rate")
    if profile.still.all():
        raise ValueError("a triaxial profile with every axis still has no drive to synthesise")
    return fs


def rank_one(profile: TriaxialProfile) -> tuple[RandomProfile, FloatArray] | None:
    """``(P, d)`` when ``S(f) = d dᵀ P(f)`` with a real unit direction ``d`` (every moving pair
    fully coherent, in phase or in antiphase, and the PSDs in fixed ratios), else None.

    Examples
    --------
    A profile along one direction is rank one: its PSD and the direction come back.

    >>> import vrelab
    >>> from vrelab.triaxial.synthesis import rank_one
    >>> tri = vrelab.TriaxialProfile.along(vrelab.parse_profile("flat:50-2000").scaled_to(1.0), (1, 0, 1))
    >>> psd, d = rank_one(tri)
    >>> print(f"{psd.grms:.3f} g rms", d.round(4))
    1.000 g rms [0.7071 0.     0.7071]
    """
    moving = np.flatnonzero(~profile.still)
    p = profile.axis_psd_g2_per_hz
    c = profile.coherency
    ref = moving[0]
    for j in moving:
        if not np.allclose(p[:, j] / p[:, ref], p[0, j] / p[0, ref], rtol=_RANK_ONE_RTOL, atol=0):
            return None
        cj = c[:, ref, j]
        if not (np.allclose(cj.imag, 0.0, atol=_RANK_ONE_RTOL)
                and np.allclose(np.abs(cj.real), 1.0, atol=_RANK_ONE_RTOL)
                and np.all(np.sign(cj.real) == np.sign(cj.real[0]))):
            return None
    for j in moving:
        for k in moving:
            # a consistent sign pattern: C_jk = s_j s_k (implied by PSD-ness given |C| = 1, checked anyway)
            if not np.allclose(c[:, j, k].real, np.sign(c[0, ref, j].real) * np.sign(c[0, ref, k].real),
                               atol=1e-9, rtol=0):
                return None
    total = p.sum(axis=1)
    d = np.zeros(3)
    for j in moving:
        d[j] = math.sqrt(p[0, j] / total[0]) * (1.0 if c[0, ref, j].real > 0 else -1.0)
    return RandomProfile(profile.freq_hz, total, name=profile.name, source=profile.source), d


def design_fir_matrix(profile: TriaxialProfile, fs_hz: float, n_taps: int | None = None) -> FloatArray:
    """The lower-triangular 3×3 matrix of FIR filters ``h[j, m]`` (shape (3, 3, N)) that shapes
    three independent unit white noises into the profile (module docstring).

    Parameters
    ----------
    profile : TriaxialProfile
        Target one-sided CSD [g²/Hz]; its band at or below fs_hz/2.
    fs_hz : float
        Sample rate [Hz].
    n_taps : int, optional
        Even filter length; default :func:`vrelab.synthesis.design_fir`'s rule.

    Notes
    -----
    At bin k (``f_k = k·fs/N``) ``H_k = D_k · chol(C̃(f_k))``, ``D_k = diag(√(P̄_jk/df · fs/2))``,
    so ``H_k H_kᴴ · 2/fs = D_k C̃ D_k · 2/fs``: the target's PSDs averaged over the bin on the
    diagonal (each row of the Cholesky factor of a unit-diagonal matrix has unit norm, so
    ``Σ_m Σ_n h[j, m, n]² = ∫P_j df`` exactly, Parseval) and the coherency at the bin centre
    off it. Row j holds axis j's filters, column m those of noise stream m.

    Examples
    --------
    >>> import vrelab
    >>> from vrelab.triaxial.synthesis import design_fir_matrix
    >>> tri = vrelab.TriaxialProfile.along(vrelab.parse_profile("flat:50-2000").scaled_to(1.0), (1, 0, 1))
    >>> h = design_fir_matrix(tri, 8000.0, n_taps=256)
    >>> h.shape, bool((h[0, 1:] == 0).all())
    ((3, 3, 256), True)
    """
    fs = _check(profile, fs_hz)
    moving = np.flatnonzero(~profile.still)
    lowest = _axis_profile(profile, int(moving[0]))
    n = resolution_length(lowest, fs) if n_taps is None else V.integer("n_taps", n_taps, 4)
    if n % 2:
        raise ValueError(f"n_taps must be even, got {n_taps!r}")
    df = fs / n
    k = np.arange(n // 2 + 1)
    amp = np.zeros((k.size, 3))
    for j in moving:
        amp[:, j] = np.sqrt(bin_powers(_axis_profile(profile, int(j)), fs, n) / df * fs / 2)
    # the coherency at the bin centres (inside the band; outside, the amplitude is 0 anyway)
    f = np.clip(k * df, profile.band[0], profile.band[1])
    s = profile.csd(f)[:, moving][:, :, moving]
    dia = np.sqrt(np.real(np.diagonal(s, axis1=1, axis2=2)))
    c = s / (dia[:, :, None] * dia[:, None, :])
    eye = np.eye(moving.size)
    chol = np.linalg.cholesky((c + COHERENCE_EPS * eye) / (1.0 + COHERENCE_EPS))
    h_f = np.zeros((k.size, 3, 3), dtype=np.complex128)
    h_f[np.ix_(np.arange(k.size), moving, moving)] = amp[:, moving, None] * chol
    h_f *= np.exp(-1j * np.pi * k)[:, None, None]  # delay by N/2 samples: causal
    h = scipy.fft.irfft(h_f, n, axis=0)  # (N, 3, 3)
    return np.ascontiguousarray(np.moveaxis(h, 0, -1))


def triaxial_random_blocks(
    profile: TriaxialProfile,
    fs_hz: float,
    n_samples: int,
    block_size: int,
    seed: int,
) -> Iterator[FloatArray]:
    """A Gaussian drive along x, y, z [g] with the profile's cross-spectral density: (3, n) blocks.

    Parameters
    ----------
    profile : TriaxialProfile
        Target CSD; each axis's rms is its profile rms, the total its grms.
    fs_hz : float
        Sample rate [Hz].
    n_samples, block_size : int
        Record and block length [samples]; values do not depend on block_size.
    seed : int
        Non-negative seed: noise stream m's seed is child m of ``SeedSequence(seed)``; a
        rank-one profile's single stream is :func:`vrelab.synthesis.random_blocks` with ``seed``.

    Notes
    -----
    Stationary and Gaussian at every sample (white Gaussian noise through fixed linear
    filters, started with a full filter's worth of noise: no start-up transient); expected CSD
    the target at the design frequencies (module docstring).

    Examples
    --------
    >>> import vrelab
    >>> from vrelab.triaxial.synthesis import triaxial_random_blocks
    >>> tri = vrelab.TriaxialProfile.along(vrelab.parse_profile("flat:50-2000").scaled_to(1.0), (1, 0, 1))
    >>> [block.shape for block in triaxial_random_blocks(tri, 8000.0, 20000, 8192, seed=1)]
    [(3, 8192), (3, 8192), (3, 3616)]
    """
    fs = _check(profile, fs_hz)
    n = V.integer("n_samples", n_samples, 0)
    bs = V.integer("block_size", block_size, 1)
    sd = V.integer("seed", seed, 0)
    one = rank_one(profile)
    if one is not None:
        yield from direction_blocks(one[0], fs, n, bs, sd, direction=one[1])
        return
    h = design_fir_matrix(profile, fs)
    m = h.shape[-1]
    nfft = max(MIN_FFT, 1 << math.ceil(math.log2(5 * m)))
    frame = nfft - (m - 1)
    stream_seeds = [int(s.generate_state(1, np.uint32)[0]) for s in np.random.SeedSequence(sd).spawn(3)]
    rows: list[Iterator[FloatArray]] = []
    for j in range(3):
        gens = [gaussian_frames(h[j, c], stream_seeds[c], frame, n) for c in range(3) if np.any(h[j, c])]
        rows.append(rechunk(_summed(gens, frame, n), n, bs))
    for x, y, z in zip(*rows):
        yield np.stack([x, y, z])


def _summed(gens: list[Iterator[FloatArray]], frame: int, n: int) -> Iterator[FloatArray]:
    """Frame-by-frame sums of the frame streams ``gens`` (zeros for an axis with none)."""
    if not gens:
        left = n
        while left > 0:
            yield np.zeros(min(frame, left))
            left -= frame
        return
    for frames in zip(*gens):
        out = frames[0].copy()
        for fr in frames[1:]:
            out += fr
        yield out


def triaxial_random_signal(profile: TriaxialProfile, fs_hz: float, n_samples: int, seed: int) -> FloatArray:
    """The whole record of :func:`triaxial_random_blocks` as one (3, n) array (short records).

    Examples
    --------
    1 g rms along 45° in x-z: x and z each carry 0.707 g rms and y is still.

    >>> import vrelab
    >>> from vrelab.triaxial.synthesis import triaxial_random_signal
    >>> tri = vrelab.TriaxialProfile.along(vrelab.parse_profile("flat:50-2000").scaled_to(1.0), (1, 0, 1))
    >>> x = triaxial_random_signal(tri, 8000.0, 80000, seed=1)
    >>> print(x.shape, [f"{v:.2f}" for v in x.std(axis=1)])
    (3, 80000) ['0.70', '0.00', '0.70']
    """
    n = V.integer("n_samples", n_samples, 0)
    blocks = list(triaxial_random_blocks(profile, fs_hz, n, max(n, 1), seed))
    return np.concatenate(blocks, axis=1) if blocks else np.zeros((3, 0))


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

    Examples
    --------
    A 1 g rms sine at 100 Hz along 45° in x-z, as (3, n) blocks:

    >>> import numpy as np
    >>> import vrelab
    >>> from vrelab.triaxial.synthesis import direction_blocks
    >>> blocks = list(direction_blocks(vrelab.TriaxialSine(100.0, (1.0, 0.0, 1.0)), 8000.0, 8000, 4000, seed=1))
    >>> x = np.concatenate(blocks, axis=1)
    >>> print(len(blocks), [f"{v:.3f}" for v in np.sqrt((x ** 2).mean(axis=1))])
    2 ['0.707', '0.000', '0.707']
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
        d = unit_vector(direction)
        blocks = synthesis.random_blocks(excitation, fs_hz, n_samples, block_size, seed, method)
    else:
        raise ValueError(f"excitation must be a RandomProfile, SineOnRandom or TriaxialSine, "
                         f"got {type(excitation).__name__}")
    for s in blocks:
        yield d[:, None] * s[None, :]
