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
    from numpy.typing import ArrayLike

    from vrelab.profiles import RandomProfile, SineOnRandom
    from vrelab.record import Record
    from vrelab.results import VreResult
    from vrelab.sensor import Sensor
    from vrelab.triaxial.profile import TriaxialProfile, TriaxialSine

    Vibration = RandomProfile | SineOnRandom | TriaxialProfile | TriaxialSine

__all__ = ["simulate", "analyze", "campaign"]


def simulate(
    sensor: Sensor | Sequence[Sensor],
    vibration: Vibration | str | None = None,
    levels: Sequence[float] = (),
    static_g: float | ArrayLike = 1.0,
    *,
    freq_hz: float | Sequence[float] | None = None,
    direction: ArrayLike | None = None,
    record_path: str | Path | None = None,
    **plan: Any,
) -> VreResult:
    """Simulate a shaker test of ``sensor`` and reduce it like a lab record: one axis or three.

    Give either ``vibration`` (the random method: ``levels`` are its g rms, its shape scaled to
    each) or ``freq_hz`` (the sine method of IEEE Std 1293: ``levels`` are the sine's g rms at
    each frequency), not both.

    The vibration is along any direction of the part's frame (physics §1.6). Along the sensed axis
    (a plain profile or ``freq_hz``, one Sensor, a scalar ``static_g``) this is the single-axis
    test (:func:`vrelab.shaker.run_random_test`, :func:`~vrelab.shaker.run_sine_test`), reduced
    to a :class:`~vrelab.results.VreResult`. With a ``direction``, a
    :class:`~vrelab.triaxial.profile.TriaxialProfile` or
    :class:`~vrelab.triaxial.profile.TriaxialSine`, a static 3-vector or several DUT axes, it is
    the triaxial test (:func:`vrelab.triaxial.simulate.run_triaxial_test`). Either way the result
    is one :class:`~vrelab.results.VreResult`: its ``axes`` hold each DUT axis's (a single-axis
    test: itself; a triaxial one: levels the vibration's total rms), a triaxial test adds
    ``triaxial`` (:class:`~vrelab.triaxial.result.TriaxialPart`: the vibration, the static vector,
    the reference's levels), and with one DUT axis ``levels``, ``fits``, ... read as that axis's.

    Parameters
    ----------
    sensor : Sensor or sequence of Sensors
        A sensor from :func:`vrelab.load_sensor`; several: the DUT axes of one part (one per
        axis x, y, z, sharing one ODR), a triaxial test.
    vibration : RandomProfile, SineOnRandom, TriaxialProfile, TriaxialSine or str, optional
        The random (or sine-on-random) vibration, or a triaxial one; a string is read by
        :func:`vrelab.parse_profile`.
    levels : sequence of float
        Vibration levels [g rms] (a triaxial test: the total rms).
    static_g : float or array_like (3,)
        Static field [g]: a number along the (first) sensor's input axis (+1: axis up in a
        1 g field), or the vector (gx, gy, gz) in the part's frame.
    freq_hz : float or sequence of float, optional
        Sine frequencies [Hz] (the sine method; along a ``direction``: one frequency).
    direction : array_like (3,), optional
        The direction of a single-axis vibration in the part's frame (normalised).
    record_path : str or Path, optional
        Also write the simulated record there (HDF5), as a lab would keep it.
    **plan
        ``seconds`` (duration of each level [s]; default 4 random, 2 sine), ``seed`` (of the
        drive and the sensor's noise: same seed, same bits), ``progress`` and the other keywords
        of :class:`vrelab.simulation.plan.TestPlan` (``baseline_s``, ``settle_s``, ``ramp_s``,
        ``drift_g_per_s``, ...; a triaxial test takes ``baseline_s``, ``settle_s``,
        ``fs_internal_hz``).

    Returns
    -------
    VreResult
        Every level's VRE with its standard uncertainty and conditions, and the fits
        (``to_dict()`` is what ``vrelab simulate --json`` prints).

    Raises
    ------
    ValueError
        Both or neither of ``vibration`` and ``freq_hz``, no level, or a bad plan.

    Examples
    --------
    A simulated sine test (IEEE Std 1293's sine method) of the ADXL355 at ±2 g, axis up: 2 g rms
    at 100 Hz drives the output past its +2 g rail, and the output reads 0.44 g low.

    >>> import vrelab
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> result = vrelab.simulate(sensor, levels=[2.0], static_g=1.0, freq_hz=100, seconds=2, seed=1)
    >>> level = result.levels[0]
    >>> print(f"{level.rms_g:.2f} g rms: VRE {level.vre.value * 1e3:.0f} mg, u {level.vre.u * 1e3:.2f} mg")
    2.00 g rms: VRE -440 mg, u 0.02 mg
    """
    from vrelab.shaker import run_random_test, run_sine_test

    if vibration is None and "profile" in plan:  # its former name
        vibration = plan.pop("profile")
    # a keyword given as None is its default (the former seconds=None, seed=None)
    plan = {k: v for k, v in plan.items() if v is not None}
    if (vibration is None) == (freq_hz is None):
        raise ValueError("simulate: give either profile (random method) or freq_hz (sine method), not both")
    if not len(levels):
        raise ValueError("simulate: levels is empty (give the vibration levels in g rms)")
    freqs = None
    if freq_hz is not None:
        freqs = [float(freq_hz)] if isinstance(freq_hz, (int, float)) else [float(f) for f in freq_hz]
    if isinstance(vibration, str):
        from vrelab.profiles import parse_profile

        vibration = parse_profile(vibration)
    if _is_triaxial(sensor, vibration, static_g, direction):
        return _simulate_triaxial(sensor, vibration, freqs, levels, static_g, direction, record_path, plan)
    if freqs is not None:
        return run_sine_test(sensor, freqs, list(levels), static_g, record_path=record_path, **plan)  # type: ignore[arg-type]
    assert vibration is not None  # checked above: freq_hz is None, so vibration is given
    return run_random_test(sensor, vibration, list(levels), static_g, record_path=record_path, **plan)  # type: ignore[arg-type]


def _is_triaxial(sensor: Any, vibration: Any, static_g: Any, direction: Any) -> bool:
    """Whether a :func:`simulate` call is a triaxial test (its docstring)."""
    import numpy as np

    from vrelab.triaxial.profile import TriaxialProfile, TriaxialSine

    several = not hasattr(sensor, "stages")
    return (several or direction is not None or isinstance(vibration, (TriaxialProfile, TriaxialSine))
            or np.ndim(static_g) > 0)


def _simulate_triaxial(sensor: Any, vibration: Any, freqs: list[float] | None, levels: Sequence[float],
                       static_g: Any, direction: Any, record_path: str | Path | None,
                       plan: dict[str, Any]) -> VreResult:
    """The triaxial case of :func:`simulate`: the sine along its direction, a number for the
    static field along the first DUT axis's input axis."""
    import numpy as np

    from vrelab.triaxial.profile import TriaxialSine
    from vrelab.triaxial.simulate import run_triaxial_test

    sensor = sensor if hasattr(sensor, "stages") else list(sensor)
    first = sensor if hasattr(sensor, "stages") else next(iter(sensor), None)
    if np.ndim(static_g) == 0 and first is not None and hasattr(first, "triad"):
        static_g = [float(static_g) if j == first.triad[0] else 0.0 for j in range(3)]
    if freqs is not None:
        if direction is None or len(freqs) != 1:
            raise ValueError("a triaxial sine is one freq_hz along a direction (x, y, z)")
        vibration, direction = TriaxialSine(freqs[0], tuple(float(x) for x in direction)), None  # type: ignore[arg-type]
    return run_triaxial_test(sensor, vibration, levels, static_g, direction=direction, record_path=record_path, **plan)


def analyze(
    path_or_record: str | Path | Record,
    dut: str | Mapping[str, str],
    reference: str | Sequence[str] | Mapping[str, str] | None = None,
    *,
    fs_hz: float | None = None,
    dut_scale: Any = None,
    reference_scale: Any = None,
    method: str = "auto",
    **options: Any,
) -> VreResult:
    """Reduce a recorded shaker test to VRE per level and its fits: one reference axis or three.

    A file is opened read-only with :func:`vrelab.analysis.readers.open_record` (any format
    ``vrelab channels`` lists) and closed afterwards; a record already open (the
    :class:`vrelab.record.Record` protocol) is read as it is. With one reference channel (or
    none) the DUT channel is reduced by :func:`vrelab.analysis.analyze`. With a triaxial
    reference (three channels x, y, z) each DUT axis is reduced against it by
    :func:`vrelab.triaxial.analyze.reduce_triaxial` (levels the reference's total rms). Either way
    the result is one :class:`~vrelab.results.VreResult`: ``axes`` holds each DUT axis's, a
    triaxial reference adds ``triaxial`` (:class:`~vrelab.triaxial.result.TriaxialPart`: the
    reference's levels as vectors, ``reference_levels``), and with one DUT axis ``levels``,
    ``fits``, ... read as that axis's. Several DUT channels against one
    reference: ``vrelab analyze --dut A,B`` or :func:`vrelab.analysis.pipeline.analyze_channels`.

    Parameters
    ----------
    path_or_record : str, Path or Record
        The recorded file, or a record.
    dut : str or mapping axis -> str
        The DUT channel as the file gives it (``vrelab channels FILE`` lists them); with a
        triaxial reference, a mapping of the DUT axes ("x", "y", "z") to their channels.
    reference : str, or three channels (x, y, z) as a sequence or mapping, optional
        The reference channel, or a triaxial reference's three.
    fs_hz : float, optional
        Sample rate [Hz] where the file does not state it (CSV without a time column).
    dut_scale, reference_scale : optional
        Units and sensitivity of each channel (see :func:`vrelab.analysis.readers.open_record`),
        or as the CLI names them: ``dut_units="lsb", dut_sensitivity=256000``,
        ``reference_units="mv", reference_sensitivity=10`` (``vrelab analyze --dut-units ...``).
    method : {"auto", "sine", "random"}
        How each level is reduced; ``auto`` decides from the reference's spectrum.
    **options
        ``options`` (a :class:`~vrelab.analysis.options.ReductionOptions`: band, settling, rail,
        profile, ...), ``fit`` (:class:`~vrelab.analysis.options.FitOptions`: static field,
        clipping model, ...), ``schedule``, ``provenance``; one axis: also ``budget``
        (:class:`~vrelab.analysis.options.BudgetOptions`; by default the CLI's, no Type B term:
        every level has ``U_vre_g`` and ``k``), ``conditions`` and, for one more
        release, the former flat keywords (``profile=``, ``static_g=``, ...).

    Returns
    -------
    VreResult
        What ``vrelab analyze --json`` (``--triaxial``) prints, as objects.

    Examples
    --------
    A run of the example campaign (``make examples``): sensor sn1 axis up, sines at 80 Hz. The
    channels' units as the CLI names them (``vrelab analyze --dut-units lsb ...``):

    >>> import vrelab
    >>> result = vrelab.analyze("examples/campaign/runs/01_z_up_80hz.tdms", dut="shaker/sn1_z",
    ...                         reference="shaker/ref", dut_units="lsb", dut_sensitivity=256000,
    ...                         reference_units="mv", reference_sensitivity=10)
    >>> for level in result.levels:
    ...     print(f"{level.rms_g:.1f} g rms: VRE {level.vre.value * 1e3:.2f} ± {level.vre.u * 1e3:.2f} mg")
    0.2 g rms: VRE 0.10 ± 0.03 mg
    0.4 g rms: VRE 0.47 ± 0.03 mg
    0.6 g rms: VRE 1.02 ± 0.04 mg
    """
    from vrelab.analysis import analyze as _reduce
    from vrelab.analysis import open_record

    dut_scale, reference_scale = _scales_named_as_the_cli(options, dut_scale, reference_scale)
    _check_keywords(options)
    if reference is not None and not isinstance(reference, str):
        return _analyze_triaxial(path_or_record, dut, reference, (fs_hz, dut_scale, reference_scale), method,
                                 options)
    if not isinstance(dut, str):
        raise ValueError("a DUT axis mapping needs a triaxial reference: reference=(x, y, z channels)")
    options.setdefault("budget", _cli_budget())
    if not isinstance(path_or_record, (str, Path)):
        from vrelab.record import ChannelView

        return _reduce(ChannelView(path_or_record, dut, reference), method, **options)  # type: ignore[arg-type]
    with open_record(path_or_record, dut=dut, reference=reference, fs_hz=fs_hz, dut_scale=dut_scale,
                     reference_scale=reference_scale) as record:
        return _reduce(record, method, **options)  # type: ignore[arg-type]


# the CLI's names for a channel's units and sensitivity (vrelab analyze --dut-units lsb
# --dut-sensitivity 256000), taken by vrelab.analyze as keywords
_SCALE_KEYWORDS = {"dut": ("dut_units", "dut_sensitivity"), "reference": ("reference_units", "reference_sensitivity")}


def _scales_named_as_the_cli(options: dict[str, Any], dut_scale: Any, reference_scale: Any) -> tuple[Any, Any]:
    """``dut_units``/``dut_sensitivity`` (``reference_...``) popped from ``options`` into the
    channels' :class:`~vrelab.analysis.readers.Scale`, with the CLI's words for a bad pair; given
    beside ``dut_scale`` (``reference_scale``) they are refused, not silently preferred."""
    from vrelab.analysis.readers import Scale

    out = {"dut": dut_scale, "reference": reference_scale}
    for channel, (units_key, sens_key) in _SCALE_KEYWORDS.items():
        units, sens = options.pop(units_key, None), options.pop(sens_key, None)
        if units is None and sens is None:
            continue
        if out[channel] is not None:
            raise ValueError(f"give {channel}_scale or {units_key}/{sens_key}, not both")
        out[channel] = Scale.parse(units, sens, f"{channel}")
    return out["dut"], out["reference"]


def _check_keywords(options: Mapping[str, Any]) -> None:
    """An unknown keyword is a TypeError before any file is opened (as for any function)."""
    from vrelab.analysis.options import check_keywords

    check_keywords("analyze", (k for k in options if k not in _OPTION_OBJECTS))


def _cli_budget() -> Any:
    """The budget ``vrelab analyze`` makes without ``--u-*`` options: no Type B term declared,
    the record's own (Type A) u only, so that every level carries ``U_vre_g`` and ``k`` (GUM
    6.2.1, k from the Welch-Satterthwaite degrees of freedom) as the CLI prints them."""
    from vrelab.analysis.options import BudgetOptions
    from vrelab.gum import TypeB

    return BudgetOptions(TypeB())


# the keywords of vrelab.analysis.analyze that are not former flat keywords
_OPTION_OBJECTS = frozenset({"options", "fit", "budget", "given", "conditions", "provenance", "schedule"})


def _analyze_triaxial(source: Any, dut: Any, reference: Any, reading: tuple[Any, Any, Any], method: str,
                      options: dict[str, Any]) -> VreResult:
    """The triaxial case of :func:`analyze`: the channels by axis, the file opened with a
    reference channel per axis (``reference-x``, ...) and a DUT per axis (``dut:<axis>``)."""
    from vrelab.triaxial.analyze import Caller, reduce_triaxial
    from vrelab.triaxial.profile import AXES

    ref = dict(reference) if isinstance(reference, Mapping) else dict(zip(AXES, reference))
    if len(ref) != 3 or (not isinstance(reference, Mapping) and len(reference) != 3):
        raise ValueError(f"a triaxial reference needs three channels x, y, z, got {reference!r}")
    if not isinstance(dut, Mapping):
        raise ValueError(f"with a triaxial reference, name each DUT channel's axis: dut={{'z': {dut!r}}}")
    unknown = sorted(set(options) - {"options", "fit", "schedule", "provenance"})
    if unknown:
        raise ValueError(f"analyze with a triaxial reference does not take {', '.join(unknown)} (it takes options, "
                         "fit, schedule, provenance; the VRC is fitted against the total rms only)")
    kw = dict(options=options.get("options"), fit=options.get("fit"), caller=Caller(options.get("provenance")))
    if not isinstance(source, (str, Path)):
        return reduce_triaxial(source, ref, dict(dut), method, options.get("schedule"), **kw)  # type: ignore[arg-type]
    from vrelab.analysis.readers import open_record

    fs_hz, dut_scale, reference_scale = reading
    names = {**dict(dut), **{f"reference-{a}": ref[a] for a in AXES}}
    scales = {**{a: dut_scale for a in dut}, **{f"reference-{a}": reference_scale for a in AXES}}
    with open_record(source, names, None, fs_hz, scales) as record:
        return reduce_triaxial(record, {a: f"dut:reference-{a}" for a in AXES}, {a: f"dut:{a}" for a in dut},
                               method, options.get("schedule"), **kw)  # type: ignore[arg-type]


def campaign(manifest: str | Path, workers: int = 1, limit_g: float | None = None) -> Mapping[str, Any]:
    """Reduce every run of a campaign manifest (physics §4.1) and combine each channel's results.

    Parameters
    ----------
    manifest : str or Path
        The campaign's TOML manifest (checked whole before any run is reduced).
    workers : int
        Runs reduced at once, in processes.
    limit_g : float, optional
        A VRE limit [g]: each level gets a guarded-acceptance decision (physics §4.3).

    Returns
    -------
    dict
        The campaign document (``runs``, ``channels`` with ``vrc_by_freq``, ``k2_ug_per_g2``,
        ``k3_ug_per_g3``, ``rail_g``): what ``vrelab campaign --json`` prints and what
        :func:`vrelab.identify` takes. A run that failed is in it with its ``error``. To write
        a results folder (and then a report), use ``vrelab campaign MANIFEST --out DIR``.

    Examples
    --------
    A campaign of one run (``examples/campaign/one-run.toml``; the example campaign's whole
    manifest is ``examples/campaign/campaign.toml``):

    >>> import vrelab
    >>> doc = vrelab.campaign("examples/campaign/one-run.toml")
    >>> doc["n_runs"], doc["n_failed"], [c["channel"] for c in doc["channels"]]
    (1, 0, ['sn1'])
    >>> vrc = doc["channels"][0]["vrc_by_freq"][0]
    >>> print(f"{vrc['freq_hz']:.0f} Hz: VRC {vrc['vrc_ug_per_g2']['value']:.0f} ± {vrc['vrc_ug_per_g2']['u']:.0f} µg/g²")
    80 Hz: VRC 2853 ± 87 µg/g²
    """
    from vrelab.campaigns import campaign_doc, combine, read_manifest, run_campaign

    m = read_manifest(manifest)
    results = run_campaign(m, workers, None, None, limit_g)
    return campaign_doc(m, results, combine(results, m.channels))
