"""Over-range protection (physics §1.3): the stage that holds the output after the proof mass crosses
its threshold, placed in continuous time between the samples."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, NamedTuple

import numpy as np
from numpy.typing import NDArray

from vrelab.sensor.base import StageBase, finite, non_negative, positive
from vrelab.sensor.meanshift import Shift, Site

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

# The over-range model counts independent holds: beyond this fraction of time held, holds
# overlap and the output no longer returns to the vibration between them.
MAX_HOLD_DUTY = 0.05

# ----------------------------------------------------------------------------- over-range


class _HoldState(NamedTuple):
    n_in: int  # input samples seen so far
    pending: tuple[float, float, float]  # the last three inputs: the last two go out next block
    start: float  # the latest hold episode [start, end), in global sample times
    end: float
    start_value: float  # the input where that episode began (float_tau_s)
    events: int
    held_samples: float  # sum of the output samples' hold coverage


def _peak_margin(z: FloatArray) -> float:
    """max|Δz|/4: how far a parabola through three consecutive samples can rise above them."""
    d = np.diff(z)
    np.abs(d, out=d)
    return 0.25 * float(d.max())


def _cubic_crossing(z0: FloatArray, z1: FloatArray, z2: FloatArray, z3: FloatArray, thr: float) -> FloatArray:
    """Where the cubic through ``(-1, z0), (0, z1), (1, z2), (2, z3)`` crosses ``thr`` between
    0 and 1 (``z1`` and ``z2`` on either side of it).

    Near a peak the straight line between two samples cuts under the curve and puts the
    crossing late; the cubic's error is two orders of ``1/fs`` smaller. Newton steps from the
    straight line's crossing, kept in the shrinking bracket (a step that leaves it bisects).
    """
    c1 = -z0 / 3.0 - z1 / 2.0 + z2 - z3 / 6.0
    c2 = (z0 + z2) / 2.0 - z1
    c3 = (z3 - z0) / 6.0 + (z1 - z2) / 2.0
    f0 = z1 - thr  # P(0) - thr; P(1) - thr = z2 - thr has the other sign
    tau = f0 / (z1 - z2)
    lo, hi = np.zeros(z1.size), np.ones(z1.size)

    def newton(t: FloatArray, g0: FloatArray, k1: FloatArray, k2: FloatArray, k3: FloatArray,
               lo: FloatArray, hi: FloatArray) -> FloatArray:  # one safeguarded step; updates lo, hi in place
        f = g0 + t * (k1 + t * (k2 + t * k3))
        same = (f > 0) == (g0 > 0)
        np.copyto(lo, t, where=same)
        np.copyto(hi, t, where=~same)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = t - f / (k1 + t * (2.0 * k2 + 3.0 * t * k3))
        return np.where((step >= lo) & (step <= hi), step, 0.5 * (lo + hi))

    # Six steps on all crossings (most have converged by then), then each one still moving
    # iterates until its own step is below 1e-15: per crossing, so the result does not
    # depend on which crossings share a block.
    for _ in range(6):
        prev, tau = tau, newton(tau, f0, c1, c2, c3, lo, hi)
    act = np.flatnonzero(np.abs(tau - prev) > 1e-15)
    for _ in range(60):
        if act.size == 0:
            break
        t = tau[act]
        a_lo, a_hi = lo[act], hi[act]
        new = newton(t, f0[act], c1[act], c2[act], c3[act], a_lo, a_hi)
        lo[act], hi[act], tau[act] = a_lo, a_hi, new
        act = act[np.abs(new - t) > 1e-15]
    return tau


def _excursions(
    z: FloatArray, thr: float, t0: float, margin: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Where the input modelled from its samples ``z`` (``z[i]`` at time ``t0 + i``) is beyond ±thr.

    This block's share: the segments ``z[i] .. z[i+1]`` for ``1 <= i <= z.size - 3`` and the
    peaks at ``z[k]`` for ``2 <= k <= z.size - 2`` (``z[0]`` and ``z[-1]`` are context). A
    segment with one end beyond the threshold crosses it where the cubic through the four
    samples around it does (:func:`_cubic_crossing`); one with both ends beyond is beyond
    throughout. At a local extremum ``z[k]`` whose neighbours are both within ±thr, the
    parabola through ``z[k-1], z[k], z[k+1]`` gives the excursion: a peak between two samples
    that the samples cut off (at 8 samples per period a sine's samples miss its peak by up to
    7.6 %, the parabola by 0.85 %). Returns the union as disjoint intervals in time order:
    (starts, ends, input at each start).
    """
    out = []
    # A parabola's vertex exceeds its middle sample by at most max|Δz|/4 (``margin``): only
    # samples within that margin of the threshold can matter. A pass over the block finds
    # them; the rest works on those few, both sides at once, mirrored so the threshold is +thr.
    near = np.flatnonzero(np.abs(z) > thr - margin)
    side = np.where(z[near] > 0, 1.0, -1.0)
    beyond = side * z[near] > thr
    # segments with an end beyond the threshold, one per side: key = 2·segment + (side < 0)
    key = 2 * near[beyond] + (side[beyond] < 0)
    key = np.sort(np.concatenate((key - 2, key)))  # both sorted: few, cheap
    key = key[np.concatenate(([True], key[1:] != key[:-1]))] if key.size else key
    seg, sign = key // 2, np.where(key % 2 == 1, -1.0, 1.0)
    keep = (seg >= 1) & (seg <= z.size - 3)
    seg, sign = seg[keep], sign[keep]
    if seg.size:
        p, q = sign * z[seg], sign * z[seg + 1]
        p_in, q_in = p > thr, q > thr
        cross = np.flatnonzero(p_in != q_in)
        sc, c = sign[cross], seg[cross]
        tau = _cubic_crossing(sc * z[c - 1], sc * z[c], sc * z[c + 1], sc * z[c + 2], thr)
        a, b = np.zeros(seg.size), np.ones(seg.size)
        a[cross] = np.where(q_in[cross], tau, 0.0)  # entering the excursion
        b[cross] = np.where(p_in[cross], tau, 1.0)  # leaving it
        base = t0 + seg
        out.append((base + a, base + b, sign * np.where(p_in, p, thr)))
    inner = (near >= 2) & (near <= z.size - 2)
    k, sign = near[inner], side[inner]
    if k.size:
        left, mid, right = sign * z[k - 1], sign * z[k], sign * z[k + 1]
        curv = left - 2.0 * mid + right
        ok = (mid >= left) & (mid >= right) & (curv < 0) & (left <= thr) & (right <= thr)
        k, sign, left, mid, right, curv = k[ok], sign[ok], left[ok], mid[ok], right[ok], curv[ok]
        slope = 0.5 * (right - left)
        hit = mid - slope * slope / (2.0 * curv) > thr  # the vertex
        if hit.any():
            k, sign, mid, slope, curv = k[hit], sign[hit], mid[hit], slope[hit], curv[hit]
            # P(τ) = mid + slope·τ + curv·τ²/2 = thr, curv < 0: the two roots, lower first
            root = np.sqrt(slope * slope - 2.0 * curv * (mid - thr))
            base = t0 + k
            out.append((base + (slope - root) / -curv, base + (slope + root) / -curv, sign * thr))
    if not out:
        return np.empty(0), np.empty(0), np.empty(0)
    starts, ends, values = (np.concatenate(parts) for parts in zip(*out))
    order = np.argsort(starts, kind="stable")
    starts, ends, values = starts[order], ends[order], values[order]
    # union: an interval that starts before every earlier one has ended continues it
    first = np.empty(starts.size, dtype=bool)
    first[0] = True
    first[1:] = starts[1:] > np.maximum.accumulate(ends)[:-1]
    idx = np.flatnonzero(first)
    return starts[idx], np.maximum.reduceat(ends, idx), values[idx]


@dataclass(frozen=True)
class OverRange(StageBase):
    """Over-range protection: above ``threshold_g`` the output goes to ``value_g`` for ``hold_s``.

    Parameters
    ----------
    threshold_g : trip level on ``|input|`` [g] (ADXL355: ≈8 g on ±2 g, 16 g on ±4/±8 g, ±25 %).
    hold_s : how long the drive stays off [s] (ADXL355: 0.5 ms).
    value_g : where the output goes [g] (ADXL355: floats toward 0; ADXL354: mid-scale = 0 g).
    retrigger : the trip re-arms while the input stays beyond the threshold, so a hold ends
        ``hold_s`` after the input last came back (default); if False a hold lasts exactly
        ``hold_s`` and what happens during it is ignored.
    float_tau_s : time constant of the exponential approach to ``value_g`` [s]; 0 = jump.

    Notes
    -----
    The model is in continuous time, so that its effect on the mean does not move with the
    simulation rate ``fs`` to first order in ``T = 1/fs``. (A trip at the first sample past
    the threshold holding whole samples moved each hold by up to a sample, where the input is
    ≈ the threshold while the hold's mean is ≈ 1 g, and missed peaks between samples: the
    ADXL355's mean shift at 16 kHz was 3-7 % off its continuous value, now < 0.1 %.)

    Input between samples: where a segment has one end beyond ``±threshold_g``, the crossing
    is where the cubic through the four samples around the segment crosses it; a segment with
    both ends beyond is beyond throughout; at a local extremum whose two neighbours are within
    the threshold, the parabola through the three samples gives the excursion (a peak between
    samples: at 8 samples per period the samples miss a sine's peak by up to 7.6 %, the
    parabola by 0.85 %). With ``retrigger`` the hold is the union over the excursions
    ``[a, b]`` of ``[a, b + hold_s)`` (the limit of re-tripping at every sample beyond the
    threshold); without, a hold ``[s, s + hold_s)`` starts at the first time beyond the
    threshold outside a hold (at its end if the input is still beyond). During a hold the
    output is ``v(t) = value_g + (x(s) - value_g)·exp(-(t - s)/float_tau_s)``, ``x(s)`` the
    input where the hold began (``±threshold_g``); ``v = value_g`` for ``float_tau_s = 0``.

    Assumption (how a sampled output represents it): sample ``k`` stands for the interval
    ``(t_k - T/2, t_k + T/2]``, of which the hold covers a fraction ``c_k``, and
    ``y_k = c_k·value_g + (1 - c_k)·x_k - r_k`` (plus ``(1/T)·∫(v - value_g) dt`` over the
    covered part when ``float_tau_s > 0``): the output during the hold is ``value_g``, a
    sample partly held is the mix by coverage. ``r_k = (1/T)·∫(x(t) - x_k) dt`` over the
    covered part less ``c_k`` times the same over the whole interval (``x(t)`` the straight
    lines through the samples) keeps the mean right where the input crosses the threshold
    steeply (≈ 4 g per sample at 16 kHz); ``r_k = 0`` when ``c_k`` is 0 or 1. The resulting
    mean is second order in ``T`` (tests: 16 kHz vs 128 kHz within 0.3 %).

    Locating a crossing or a peak needs up to two samples after it, so the stage's output is
    the input two samples late (``delay_samples``; the first two outputs repeat the first
    input). :class:`~vrelab.sensor.chain.SensorChain` makes a later :class:`Decimate` keep
    the samples of the undelayed grid, so the output still samples the same instants at any
    internal rate (a whole number of output samples late).

    Vectorised: the crossings and peaks come from the samples near the threshold only, the
    retriggered hold is a running maximum of the hold ends (``np.maximum.accumulate``), the
    coverage a ``np.bincount`` over the held samples; without retrigger a loop runs over hold
    episodes, not samples. A block whose samples (and the parabolas through them) stay within
    the threshold, with no hold carried in, is a copy. Times are global sample indices, so
    the output does not depend on the block size. Stats: ``overrange_events`` (hold episodes)
    and ``overrange_samples`` (held samples: the sum of ``c_k``, rounded, at this rate).

    References
    ----------
    ADXL354/ADXL355 data sheet Rev. D (Analog Devices): over-range protection at ≈ ±8 g on the
    ±2 g range, drive off for 0.5 ms; physics §1.3.

    Examples
    --------
    The ADXL355's protection (0.5 ms hold at 0 g) on a 1 ms excursion past a 4 g threshold,
    sampled at 10 kHz: one trip, held for the excursion's 10 samples and 0.5 ms (5) after it.

    >>> import numpy as np
    >>> from vrelab.sensor import OverRange, SensorChain
    >>> x = np.ones(40)
    >>> x[10:20] = 5.0
    >>> y, stats = SensorChain((OverRange(4.0, 0.5e-3),)).apply(x, 10000.0)
    >>> stats.overrange_events, stats.overrange_samples
    (1, 15)
    """

    threshold_g: float
    hold_s: float
    value_g: float = 0.0
    retrigger: bool = True
    float_tau_s: float = 0.0
    is_static: ClassVar[bool] = False
    delay_samples: ClassVar[int] = 2  # output k is input k - 2 (see Notes)
    # what the prediction needs of the motion at this stage (vrelab.predict): Rice's crossing
    # rate and the motion's correlation over the hold
    needs_crossing_rate: ClassVar[bool] = True

    def __post_init__(self) -> None:
        positive(self, "threshold_g")
        positive(self, "hold_s")
        finite(self, "value_g")
        non_negative(self, "float_tau_s")
        if not isinstance(self.retrigger, (bool, np.bool_)):
            raise ValueError(f"OverRange retrigger must be True or False, got {self.retrigger!r}")

    def init_state(self, fs_hz: float, seed_seq: np.random.SeedSequence | None) -> _HoldState:
        return _HoldState(0, (0.0, 0.0, 0.0), -math.inf, -math.inf, 0.0, 0, 0.0)

    def process(self, x: FloatArray, state: _HoldState, fs_hz: float) -> tuple[FloatArray, _HoldState]:
        n = x.size
        if n == 0:
            return x.copy(), state
        thr = self.threshold_g
        # z[i] is the input at global time t0 + i: z[0], z[1] (held back from the last block)
        # to z[n-1] go out now, z[n] and z[n+1] wait for the samples after them.
        t0 = float(state.n_in - 2)
        h = np.empty(n + 3)  # the sample before z[0] (already out), then z
        h[:3] = x[0] if state.n_in == 0 else state.pending
        h[3:] = x
        z = h[1:]
        carried = state._replace(n_in=state.n_in + n, pending=(float(h[-3]), float(h[-2]), float(h[-1])))
        if state.end <= t0 - 0.5:
            # a block whose samples, and the peaks between them (a parabola through three
            # samples rises at most max|Δz|/4 above them), stay within the threshold and no
            # hold carried in (most blocks): a copy and a few reductions
            z_max, z_min = float(h.max()), float(h.min())
            top = max(z_max, -z_min)
            if top + 0.25 * (z_max - z_min) <= thr:
                return z[:n], carried
            margin = _peak_margin(h)
            if top + margin <= thr:
                return z[:n], carried
        else:
            margin = _peak_margin(h)
        starts, ends, values = _excursions(h, thr, t0 - 1.0, margin)
        hold = self.hold_s * fs_hz
        ep_s, ep_e, ep_v, new = self._episodes(starts, ends, values, hold, state)
        y = z[:n].copy()
        held, cov, rest = self._coverage(ep_s, ep_e, ep_v, h, t0, n, fs_hz)
        y[held] = cov * self.value_g + (1.0 - cov) * y[held] + rest
        return y, carried._replace(
            start=float(ep_s[-1]),
            end=float(ep_e[-1]),
            start_value=float(ep_v[-1]),
            events=state.events + new,
            held_samples=state.held_samples + float(cov.sum()),
        )

    def mean_shift(self, site: Site) -> Shift:
        """The change of the mean the holds make (physics §1.3), an estimate.

        Random drive: Rice's trip rate ν of the Gaussian motion at the site
        (:func:`vrelab.models.design.overrange_trip_rate_hz`, with tones the phase-averaged rate)
        and ``VRE_or = (1 - exp(-ν·hold))·(value - held)``
        (:func:`vrelab.models.design.overrange_vre`), ``held`` the mean of the motion over the
        stretches the holds replace (:func:`vrelab.models.design.overrange_held_mean_g`, Rice's
        conditioning on the crossing) read through the rails after the holds (what those
        stretches would have read: the censored mean of a Gaussian of that mean and the rails'
        rms). Invalid where the holds fill more than 5 % of the time (they overlap) and, as a
        ``rough_if_large`` note, where this share is more than a tenth of the largest.

        Sine: a sine whose peak reaches the threshold trips every period; not modelled (invalid);
        one that does not adds nothing.
        """
        from vrelab.models import design

        mo = site.motion
        thr, hold, mean = float(self.threshold_g), float(self.hold_s), site.level_g
        sigma, nu0, peaks = mo.sigma_g, mo.nu0_hz, mo.tone_peaks_g
        if site.drive == "sine":
            peak = math.sqrt(2) * sigma
            if abs(mean) + peak > thr:
                return Shift({"overrange_g": 0.0}, valid=False, rate_hz=site.freq_hz or 0.0, notes=(
                    f"sine peak at the proof mass ({abs(mean) + peak:.3g} g) reaches the over-range "
                    f"threshold ({thr:g} g): trips every period, not modelled — simulate",))
            return Shift({"overrange_g": 0.0})
        notes: list[str] = []
        rate = float(design.overrange_trip_rate_hz(thr, mean, sigma, nu0, peaks, mo.tone_freqs_hz))
        held = None
        if math.isfinite(mo.rho_mean) and sigma > 0:
            held = design.overrange_held_mean_g(mean, sigma, thr, hold, nu0, mo.rho_mean, mo.one_minus_rho_hold)
        duty = rate * hold
        if duty > MAX_HOLD_DUTY:
            notes.append(f"over-range holds fill {100 * duty:.0f} % of the time: holds overlap, "
                         "the rare-event model fails — simulate")
        if held is not None:
            # what the held stretches would have read: their motion, through the rails after
            # (the output stays near its mean over a stretch; its spread taken as the
            # unconditional one at the rails): E[clip(N(held, σ²))]
            from vrelab.models.clipping import censored_mean_shift

            for stage, later in site.after:
                rails = getattr(stage, "rails_g", None)
                if rails is not None and later.rms_g > 0:
                    held = held + float(censored_mean_shift(held, later.rms_g, rails[0], rails[1]))
        over = float(design.overrange_vre(mean, sigma, thr, hold, nu0, value_g=float(self.value_g),
                                          tone_peaks_g=peaks, tone_freqs_hz=mo.tone_freqs_hz, held_mean_g=held))
        rough = ("over-range share is large: the Rice×hold estimate (mean of the held stretches from Rice's "
                 "conditioning on the crossing, holds taken as not overlapping) is rough"
                 + (" (Rice's rate for the Gaussian part with the tones as a moving mean)"
                    if site.drive == "sine-on-random" else "") + " — simulate")
        return Shift({"overrange_g": over}, valid=not notes, notes=tuple(notes), rate_hz=rate, rough_if_large=rough)

    def _episodes(
        self, starts: FloatArray, ends: FloatArray, values: FloatArray, hold: float, state: _HoldState
    ) -> tuple[FloatArray, FloatArray, FloatArray, int]:
        """Hold episodes [s, e) in time order, the one carried in first; and how many are new."""
        if self.retrigger:
            s = np.concatenate(([state.start], starts))
            e = np.concatenate(([state.end], ends + hold))
            v = np.concatenate(([state.start_value], values))
            # a piece that starts before every earlier hold has ended extends that episode
            new = np.empty(s.size, dtype=bool)
            new[0] = True
            new[1:] = s[1:] > np.maximum.accumulate(e)[:-1]
            first = np.flatnonzero(new)
            return s[first], np.maximum.reduceat(e, first), v[first], first.size - 1
        ep_s, ep_e, ep_v = [state.start], [state.end], [state.start_value]
        count = 0
        pos = state.end
        while True:
            # first excursion still going at pos (the excursions are disjoint, in time order)
            k = int(np.searchsorted(ends, pos, side="right"))
            if k == ends.size:
                break
            if starts[k] > pos:
                ep_s.append(float(starts[k]))
                ep_e.append(float(starts[k]) + hold)
                ep_v.append(float(values[k]))
                count += 1
            else:  # still beyond the threshold when the hold ends: a new hold, no gap
                ep_e[-1] = pos + hold
            pos = ep_e[-1]
        return np.array(ep_s), np.array(ep_e), np.array(ep_v), count

    def _coverage(
        self, ep_s: FloatArray, ep_e: FloatArray, ep_v: FloatArray, h: FloatArray, t0: float, n: int,
        fs_hz: float,
    ) -> tuple[NDArray[np.intp], FloatArray, FloatArray]:
        """The output samples (indices in the block) the holds touch, the held fraction ``c_k``
        of each one's interval, and the rest of ``y_k``.

        ``h[j]`` is the input at ``t0 - 1 + j``; output ``k`` is ``h[k + 1]``. The rest is
        ``(1/T)·∫(v(t) - value_g) dt`` over the covered part (``float_tau_s``) minus the
        covered part's departure from the sample: ``(1/T)·∫(x(t) - x_k) dt`` over it, ``x(t)``
        the straight lines through the samples, less its share ``c_k`` of the same over the
        whole interval (which the sampled record neglects everywhere). Without it a sample
        partly held where the input crosses the threshold (steeply: ≈ 4 g per sample at 16 kHz
        on the ADXL355) stands for the unheld part with a value from the held part, an error
        first order in ``1/fs``; with it ``y_k = value_g`` when ``c_k = 1`` and ``x_k`` when 0.
        """
        keep = ep_e > t0 - 0.5
        s, e, v0 = ep_s[keep], ep_e[keep], ep_v[keep]
        # sample c's interval is (c - 1/2, c + 1/2]; those meeting [s, e), within this block
        c_lo = np.maximum(np.floor(s - 0.5) + 1.0, t0)
        c_hi = np.minimum(np.ceil(e + 0.5) - 1.0, t0 + n - 1)
        counts = np.maximum(c_hi - c_lo + 1.0, 0.0).astype(np.int64)
        ep = np.repeat(np.arange(s.size), counts)
        offsets = np.cumsum(counts) - counts
        c = c_lo[ep] + (np.arange(ep.size) - offsets[ep])
        u1 = np.maximum(s[ep], c - 0.5)
        u2 = np.minimum(e[ep], c + 0.5)
        idx = (c - t0).astype(np.int64)
        part = u2 - u1
        # idx does not decrease (episodes in time order); sum the parts that share a sample
        first = np.flatnonzero(np.concatenate(([True], idx[1:] != idx[:-1]))) if idx.size else idx
        cov = np.add.reduceat(part, first) if idx.size else part
        # slopes left and right of each sample [g per sample]; ∫τ·slope dτ over the covered part
        left = h[idx + 1] - h[idx]
        right = h[idx + 2] - h[idx + 1]
        a, b = u1 - c, u2 - c
        lo_a, lo_b = np.minimum(a, 0.0), np.minimum(b, 0.0)
        hi_a, hi_b = np.maximum(a, 0.0), np.maximum(b, 0.0)
        moment = 0.5 * (left * (lo_b * lo_b - lo_a * lo_a) + right * (hi_b * hi_b - hi_a * hi_a))
        rest = -(moment - part * (right - left) / 8.0)
        if self.float_tau_s != 0:
            tau = self.float_tau_s * fs_hz  # [samples]
            amp = (v0[ep] - self.value_g) * tau
            rest = rest + amp * (np.exp(-(u1 - s[ep]) / tau) - np.exp(-(u2 - s[ep]) / tau))
        return idx[first], cov, (np.add.reduceat(rest, first) if idx.size else rest)

    def stats(self, state: _HoldState) -> dict[str, int | float]:
        return {"overrange_events": state.events, "overrange_samples": int(round(state.held_samples))}
