"""The identified sensor as a sensor file (physics §6.1)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from vrelab.identification.api import Identification
from vrelab.sensor.parameters import PARAMETERS, TABLE
from vrelab.sensor.writer import file_values


def sensor_file_document(ident: Identification) -> dict[str, Any]:
    """The identified sensor as a sensor-file document (the presets' schema, physics §6.1).

    The base sensor's file is the template: its other ranges, ODRs and filters stay as they
    are. Each channel becomes ``[axes.<channel>]`` holding every identifiable parameter
    (identified, or the base's value where the campaign could not determine it), its own
    ``facts`` (``"identified from <campaign>, ± u"`` or ``"from base sensor ..."``) and the
    covariance of the identified ones. The tested range's table loses the keys the axes now
    set, so they win there (resolution: top level < axis < range); other ranges keep the base's
    rails and threshold (they were not tested).

    Examples
    --------
    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> import vrelab
    >>> base = vrelab.load_sensor("ideal", range_g=2)
    >>> from vrelab.identification.channel import identify_channel
    >>> from vrelab.identification.sensor_file import sensor_file_document
    >>> ident = vrelab.Identification("two runs", "ideal", base, (identify_channel("sn1", obs, base),), "censored")
    >>> doc = sensor_file_document(ident)
    >>> axis = doc["axes"]["sn1"]
    >>> print(doc["name"], f"{axis['k2_ug_per_g2']:.1f} {axis['k3_ug_per_g3']:.1f}")
    ideal-identified 100.0 10.0
    >>> print(axis["facts"]["k2_per_g"])
    identified from two runs, 100 ± 3.6 µg/g²
    """
    from vrelab.sensor.loader import read_spec

    data, _origin = read_spec(ident.base_spec)
    base = ident.base
    out: dict[str, Any] = {k: v for k, v in data.items() if k not in ("name", "description", "source", "axes",
                                                                     "default_axis", "facts")}
    out["schema"] = data.get("schema", 1)
    out["name"] = f"{base.name}-identified"
    out["description"] = f"{base.name} with its VRE model identified from campaign {ident.campaign!r} by vrelab identify"
    out["source"] = f"vrelab identify: campaign {ident.campaign!r} on base sensor {ident.base_spec}"
    out["default_range_g"] = base.range_g
    out["default_axis"] = ident.channels[0].channel
    keys = {TABLE[n].file_key for n in PARAMETERS}
    out.pop("uncertainty", None)  # resolved per axis below (an identified parameter carries its covariance instead)
    ranges = data.get("ranges")
    if isinstance(ranges, dict):
        from vrelab.sensor import load_sensor

        tested = next((k for k in ranges if math.isclose(float(k), base.range_g, rel_tol=1e-6)), None)
        out["ranges"] = {}
        for k, t in ranges.items():
            if k == tested:
                out["ranges"][k] = {kk: vv for kk, vv in t.items() if kk not in keys and kk != "uncertainty"}
            else:  # an untested range keeps the base's rails, never the tested range's identified ones
                rails = load_sensor(ident.base_spec, range_g=float(k), axis=base.axis, odr_hz=base.odr_hz).rails_g
                out["ranges"][k] = {**t, "rails_g": [float(rails[0]), float(rails[1])]}
    base_axis = (data.get("axes") or {}).get(base.axis, {})
    base_facts = dict(base.facts)
    facts_top = {k: v for k, v in (data.get("facts") or {}).items()}
    if facts_top:
        out["facts"] = facts_top
    axes: dict[str, Any] = {}
    for cm in ident.channels:
        t = {k: v for k, v in base_axis.items() if k not in keys and k != "uncertainty"}
        f: dict[str, str] = {}
        # the base's assumed u of what the campaign did not identify (its filters, its threshold), and the
        # profile u of a resonance the runs only bound
        unc = {n: u for n, u in base.uncertainty.items() if n not in PARAMETERS or cm.parameters.get(n) is None}
        for n, (u, _why) in cm.assumed.items():
            if u is not None:
                unc[n] = float(u)
        for n in PARAMETERS:
            v = cm.values[n]
            e = cm.parameters[n]
            fk = TABLE[n].fact_key
            if e is not None:
                src = f"identified from {ident.campaign}, {e.value:.6g} ± {e.u:.2g} {TABLE[n].text_unit}".rstrip()
            elif n in cm.assumed and cm.assumed[n][1].startswith("fitted"):
                src = f"assumption: {cm.assumed[n][1]}; {v:.6g} ± {unc[n]:.2g} {TABLE[n].text_unit} (profile)".rstrip()
            else:
                src = (f"assumption, from base sensor {ident.base_spec} ({cm.reasons.get(n, 'not identified')})"
                       + (f", u {unc[n]:.3g} {TABLE[n].text_unit}".rstrip() if n in unc else ", no stated u")
                       + f": {base_facts.get(fk, 'unmarked')}")
            f[fk] = f"{f[fk]}; {_side(n)}: {src}" if fk in f else (f"{_side(n)}: {src}" if TABLE[n].rail is not None else src)
        t.update(file_values({n: cm.values[n] for n in PARAMETERS}))
        # the part's axis the channel measured (the base sensor's): the identified axis is named
        # by its channel, and a triaxial prediction needs its IEEE 1293 triad
        if base.input_axis is not None:  # given by --base-axis or the base file, never the default axis
            t["input_axis"] = base.input_axis
        t["facts"] = f
        if cm.covariance is not None:
            t["covariance"] = {"params": list(cm.covariance[0]), "matrix": [[float(c) for c in row]
                                                                           for row in cm.covariance[1]]}
        if unc:
            t["uncertainty"] = unc
        axes[cm.channel] = t
    out["axes"] = axes
    return out


def _side(name: str) -> str:
    rail = TABLE[name].rail
    return name if rail is None else ("lower", "upper")[rail]


def write_sensor_file(path: str | Path, ident: Identification) -> Path:
    """Write :func:`sensor_file_document` as TOML to ``path`` by the one sensor-file writer
    (:func:`vrelab.sensor.writer.write_sensor_file`: loaded for each channel before it is renamed
    into place, so a file that would not load is never left behind).

    Examples
    --------
    The identified sensor written as a sensor file, and loaded back as any sensor is:

    >>> import numpy as np
    >>> from vrelab.identification.observation import Observation
    >>> rms = np.array([0.2, 0.4, 0.6])
    >>> def sine_run(run, g0, vrc):
    ...     return Observation(run, f"run {run}", "sine", g0, 80.0, None, rms, vrc * 1e-6 * rms**2, np.full(3, 2e-6))
    >>> obs = [sine_run(1, 1.0, 130.0), sine_run(2, -1.0, 70.0)]
    >>> import vrelab
    >>> base = vrelab.load_sensor("ideal", range_g=2)
    >>> from vrelab.identification.channel import identify_channel
    >>> from vrelab.identification.sensor_file import write_sensor_file
    >>> ident = vrelab.Identification("two runs", "ideal", base, (identify_channel("sn1", obs, base),), "censored")
    >>> path = write_sensor_file("sn1.toml", ident)
    >>> print(f"{vrelab.load_sensor(str(path)).k2_per_g * 1e6:.1f} µg/g²")
    100.0 µg/g²
    """
    from vrelab.sensor.writer import write_sensor_file as write

    doc = sensor_file_document(ident)
    header = (f"# Identified by vrelab from campaign {ident.campaign!r} (physics §6.1): one [axes.<channel>] per channel,\n"
              "# every number's source in its facts, the identified parameters' covariance beside them.\n"
              "# Use it as --sensor with --axis <channel> in predict, simulate and sweep.\n")
    return write(path, doc, header, axes=[cm.channel for cm in ident.channels])
