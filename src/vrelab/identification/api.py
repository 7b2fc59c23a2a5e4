"""Identification of a whole campaign: every channel on one base sensor (:func:`identify`)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Mapping

from vrelab import _validate as V
from vrelab._display import Shown
from vrelab.identification.channel import IdentifyOptions, identify_channel
from vrelab.identification.observation import ChannelModel, Observation, failed_runs, observations
from vrelab.models.clipping import Kind as ClipKind

if TYPE_CHECKING:
    from vrelab.sensor.loader import Sensor


@dataclass(frozen=True, repr=False)
class Identification(Shown):
    """Every channel of a campaign identified on one base sensor.

    Examples
    --------
    A campaign's channels identified on one base sensor (here one channel, built directly):

    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> import vrelab
    >>> base = vrelab.load_sensor("ideal", range_g=2)
    >>> from vrelab.identification.channel import identify_channel
    >>> ident = vrelab.Identification("two runs", "ideal", base, (identify_channel("sn1", obs, base),), "censored")
    >>> [channel.channel for channel in ident.channels], ident.base_spec
    (['sn1'], 'ideal')
    """

    campaign: str
    base_spec: str
    base: Sensor  # the resolved base Sensor
    channels: tuple[ChannelModel, ...]
    kind: ClipKind
    provenance: Mapping[str, Any] = field(default_factory=dict)
    notes: tuple[str, ...] = ()  # the campaign's: runs that failed

    def display_fields(self) -> list[tuple[str, Any]]:  # each channel's determined parameters
        return [("campaign", self.campaign), ("base_spec", self.base_spec), ("kind", self.kind),
                *((c.channel, c.parameters) for c in self.channels), ("notes", self.notes)]

    def to_dict(self, sensor_file: str | None = None) -> dict[str, Any]:
        return {
            "kind": "identification",
            "campaign": self.campaign,
            "base_sensor": {"spec": self.base_spec, "name": self.base.name, "range_g": self.base.range_g,
                            "axis": self.base.axis, "odr_hz": self.base.odr_hz},
            "clip_model": self.kind,
            "sensor_file": sensor_file,
            "channels": [c.to_dict() for c in self.channels],
            "notes": list(self.notes),
            "provenance": dict(self.provenance),
        }


def identify(doc: Mapping[str, Any], base_spec: str = "ideal", range_g: float | None = None,
             odr_hz: float | None = None, base_axis: str | None = None,
             options: IdentifyOptions | None = None) -> Identification:
    """Identify every channel of a campaign document on the base sensor ``base_spec``
    (:func:`vrelab.sensor.load_sensor` at ``range_g``, ``odr_hz``, ``base_axis``).

    ``options`` (:class:`IdentifyOptions`): the clipping model ``kind``; ``typeb`` (a
    :class:`vrelab.gum.TypeB`) overrides the budget the runs declared; without it the largest
    value each run declared is used (one reference, one DUT: their terms are common to every
    run). ``workers`` > 1 identifies channels in parallel processes. ``prefer_base``: fn and Q
    that the runs see but determine poorly (relative u above ``MAX_REL_U``) are replaced by the
    base sensor's (by default they are kept with their u). Failed runs are listed in ``notes``
    and in every channel's notes. The model and its data flow: :mod:`vrelab.identification`.

    Examples
    --------
    The campaign of one run of :func:`vrelab.campaign`'s example, identified on the ideal sensor
    (rails at ±2.048 g and the polynomial nonlinearity). One orientation determines the VRC at
    +1 g, k2 + 3·k3, not k2 and k3 apart: identify says so instead of giving a number (the example
    campaign's own manifest, ``examples/campaign/campaign.toml``, has both orientations).

    >>> import vrelab
    >>> identification = vrelab.identify(vrelab.campaign("examples/campaign/one-run.toml"), base_spec="ideal", range_g=2.048)
    >>> channel = identification.channels[0]
    >>> print(channel.channel)
    sn1
    >>> print(channel.parameters["k2_ug_per_g2"], channel.values["rail_high_g"])
    None 2.048
    >>> print(channel.reasons["k2_ug_per_g2"])
    one orientation only (g0 = +1 g): k2 and k3 are not separable (only k2 + 3·k3·g0 is, see the notes)
    """
    from vrelab.gum import TYPE_B_KEYS, TypeB
    from vrelab.models.clipping import KINDS
    from vrelab.sensor import load_sensor

    if options is not None and not isinstance(options, IdentifyOptions):
        # a dict or another options object would fail later on a missing attribute
        raise TypeError(f"identify: options must be an IdentifyOptions, not {type(options).__name__}"
                        " (vrelab.identification.IdentifyOptions(kind=..., typeb=..., workers=...))")
    opts = options or IdentifyOptions()
    kind, typeb = opts.kind, opts.typeb
    V.one_of("kind", kind, KINDS)
    workers = V.integer("workers", opts.workers, 1)
    base = load_sensor(base_spec, range_g=range_g, axis=base_axis, odr_hz=odr_hz)
    if base_axis in ("x", "y", "z") and base.input_axis is None:
        # named on purpose: the channels measured the part's base_axis (a default axis says nothing)
        base = dataclasses.replace(base, input_axis=base_axis)
    obs, notes = observations(doc)
    failed = failed_runs(doc)
    if not obs:
        raise ValueError("identify: the campaign has no DUT channel with results"
                         + (f" ({len(failed)} run(s) failed: {'; '.join(failed)})" if failed else ""))
    if typeb is None:
        runs = [r for r in doc["runs"] if isinstance(r.get("budget"), Mapping)]
        typeb = TypeB(**{k: max((float(r["budget"].get(k, 0.0)) for r in runs), default=0.0) for k in TYPE_B_KEYS})
    name = str(doc.get("name", "campaign"))
    empty = [ch for ch, o in obs.items() if not o]
    if empty:
        raise ValueError(f"identify: channel {empty[0]!r} has no usable level in any run "
                         f"({'; '.join(notes.get(empty[0], [])) or 'no levels'})")
    opts = dataclasses.replace(opts, typeb=typeb, workers=workers)
    jobs: list[_Job] = [(ch, obs[ch], base, opts, name, notes.get(ch, [])) for ch in obs]
    if workers > 1 and len(jobs) > 1:
        from vrelab._pool import worker_pool  # workers die with this process (Ctrl-C, SIGTERM, SIGKILL)

        with worker_pool(min(workers, len(jobs))) as pool:
            models = list(pool.map(_identify_job, jobs))
    else:
        models = [_identify_job(j) for j in jobs]
    return Identification(name, base_spec, base, tuple(models), kind, notes=tuple(failed))


# one channel's identification as a worker process gets it (picklable):
# (channel, observations, base sensor, options with the Type B budget resolved, campaign name, notes)
_Job = tuple[str, list["Observation"], "Sensor", IdentifyOptions, str, list[str]]


def _identify_job(job: _Job) -> ChannelModel:
    ch, ob, base, options, name, notes = job
    return identify_channel(ch, ob, base, options, name, notes)
