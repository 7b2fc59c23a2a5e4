"""The front door's verbs that are not already one function of a module.

:func:`simulate`, :func:`analyze` and :func:`campaign` each join two or three calls of the
modules below them (a plan and its run, a file's record and its reduction, a manifest and its
runs), so that ``import vrelab`` is enough in a notebook. They add no rule of their own: the
work is done by :mod:`vrelab.shaker`, :mod:`vrelab.analysis` and :mod:`vrelab.campaign`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from vrelab.profiles import RandomProfile, SineOnRandom
    from vrelab.results import VreResult
    from vrelab.sensor import Sensor

__all__ = ["simulate", "analyze", "campaign"]


def simulate(
    sensor: Sensor,
    profile: RandomProfile | SineOnRandom | str | None = None,
    levels: Sequence[float] = (),
    static_g: float = 1.0,
    *,
    freq_hz: float | Sequence[float] | None = None,
    seconds: float | None = None,
    seed: int | None = None,
    record_path: str | Path | None = None,
    **plan: Any,
) -> VreResult:
    """Simulate a shaker test of ``sensor`` and reduce it like a lab record.

    Give either ``profile`` (the random method: ``levels`` are the profile's g rms, its shape
    scaled to each) or ``freq_hz`` (the sine method of IEEE Std 1293: ``levels`` are the sine's
    g rms at each frequency), not both.

    Parameters
    ----------
    sensor : Sensor
        A sensor from :func:`vrelab.load_sensor`.
    profile : RandomProfile, SineOnRandom or str, optional
        The random (or sine-on-random) vibration; a string is read by
        :func:`vrelab.parse_profile`.
    levels : sequence of float
        Vibration levels [g rms].
    static_g : float
        Static field along the axis [g] (+1: axis up in a 1 g field).
    freq_hz : float or sequence of float, optional
        Sine frequencies [Hz] (the sine method).
    seconds : float, optional
        Duration of each level [s]; default that of :func:`vrelab.shaker.run_random_test`
        or :func:`vrelab.shaker.run_sine_test`.
    seed : int, optional
        Seed of the drive and the sensor's noise (same seed, same bits).
    record_path : str or Path, optional
        Also write the simulated record there (HDF5), as a lab would keep it.
    **plan
        Other keywords of :class:`vrelab.simulation.plan.TestPlan` (``ramp_s``, ``drift_g_per_s``, ...).

    Returns
    -------
    VreResult
        Every level's VRE with its standard uncertainty and conditions, and the fits
        (``to_dict()`` is what ``vrelab simulate --json`` prints).

    Raises
    ------
    ValueError
        Both or neither of ``profile`` and ``freq_hz``, no level, or a bad plan.
    """
    from vrelab.shaker import run_random_test, run_sine_test

    if (profile is None) == (freq_hz is None):
        raise ValueError("simulate: give either profile (random method) or freq_hz (sine method), not both")
    if not len(levels):
        raise ValueError("simulate: levels is empty (give the vibration levels in g rms)")
    if seconds is not None:
        plan["seconds"] = seconds
    if seed is not None:
        plan["seed"] = seed
    if freq_hz is not None:
        freqs = [float(freq_hz)] if isinstance(freq_hz, (int, float)) else [float(f) for f in freq_hz]
        return run_sine_test(sensor, freqs, list(levels), static_g, record_path=record_path, **plan)
    if isinstance(profile, str):
        from vrelab.profiles import parse_profile

        profile = parse_profile(profile)
    assert profile is not None  # checked above: freq_hz is None, so profile is given
    return run_random_test(sensor, profile, list(levels), static_g, record_path=record_path, **plan)


def analyze(
    path: str | Path,
    dut: str,
    reference: str | None = None,
    *,
    fs_hz: float | None = None,
    dut_scale: Any = None,
    reference_scale: Any = None,
    method: str = "auto",
    **options: Any,
) -> VreResult:
    """Reduce a recorded shaker test (one DUT channel) to VRE per level and its fits.

    Opens ``path`` read-only with :func:`vrelab.analysis.readers.open_record` (any format
    ``vrelab channels`` lists) and reduces it with :func:`vrelab.analysis.analyze`; the file is
    closed afterwards. Several DUT channels of one file: ``vrelab analyze --dut A,B`` or
    :func:`vrelab.analysis.pipeline.analyze_channels`.

    Parameters
    ----------
    path : str or Path
        The recorded file.
    dut, reference : str
        Channel names as the file gives them (``vrelab channels FILE`` lists them).
    fs_hz : float, optional
        Sample rate [Hz] where the file does not state it (CSV without a time column).
    dut_scale, reference_scale : optional
        Units and sensitivity of each channel (see :func:`vrelab.analysis.readers.open_record`).
    method : {"auto", "sine", "random"}
        How each level is reduced; ``auto`` decides from the reference's spectrum.
    **options
        Keywords of :func:`vrelab.analysis.analyze`: ``options`` (a
        :class:`~vrelab.analysis.options.ReductionOptions`: band, settling, rail, profile, ...),
        ``fit`` (:class:`~vrelab.analysis.options.FitOptions`: static field, clipping model, ...),
        ``budget`` (:class:`~vrelab.analysis.options.BudgetOptions`), ``conditions``. The former
        flat keywords (``profile=``, ``static_g=``, ...) work for one more release.

    Returns
    -------
    VreResult
        What ``vrelab analyze --json`` prints, as objects.
    """
    from vrelab.analysis import analyze as _reduce
    from vrelab.analysis import open_record

    with open_record(path, dut=dut, reference=reference, fs_hz=fs_hz, dut_scale=dut_scale,
                     reference_scale=reference_scale) as record:
        return _reduce(record, method, **options)  # type: ignore[arg-type]


def campaign(manifest: str | Path, workers: int = 1, limit_g: float | None = None) -> Mapping[str, Any]:
    """Reduce every run of a campaign manifest (SPEC 4.1) and combine each channel's results.

    Parameters
    ----------
    manifest : str or Path
        The campaign's TOML manifest (checked whole before any run is reduced).
    workers : int
        Runs reduced at once, in processes.
    limit_g : float, optional
        A VRE limit [g]: each level gets a guarded-acceptance decision (SPEC 4.3).

    Returns
    -------
    dict
        The campaign document (``runs``, ``channels`` with ``vrc_by_freq``, ``k2_ug_per_g2``,
        ``k3_ug_per_g3``, ``rail_g``): what ``vrelab campaign --json`` prints and what
        :func:`vrelab.identify` takes. A run that failed is in it with its ``error``. To write
        a results folder (and then a report), use ``vrelab campaign MANIFEST --out DIR``.
    """
    from vrelab.campaigns import campaign_doc, combine, read_manifest, run_campaign

    m = read_manifest(manifest)
    results = run_campaign(m, workers, None, None, limit_g)
    return campaign_doc(m, results, combine(results, m.channels))
