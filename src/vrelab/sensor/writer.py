"""Writing sensor files: the one writer of the presets' schema (``presets/README``).

Every sensor TOML vrelab writes goes through :func:`write_sensor_file` (an identified sensor,
:func:`vrelab.identify.write_sensor_file`): written beside its place, loaded back for each axis
it describes, then renamed into place, so a file that would not load is never left behind. The
values come from the field table (:data:`vrelab.sensor.fields.FIELDS`): :func:`file_values`
turns parameter values into file keys, :func:`sensor_document` a whole :class:`Sensor` into a
one-configuration file; a new row needs nothing here.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, Mapping

import tomli_w

from vrelab.sensor import fields
from vrelab.sensor.parameters import identifiable

if TYPE_CHECKING:
    from vrelab.sensor.loader import Sensor

# a value as a sensor file holds it: a number, a rails pair [low, high], an order, a choice or a flag
FileValue = float | int | str | bool | list[float]


def file_values(values: Mapping[str, float | None]) -> dict[str, float | list[float]]:
    """Parameter values (by parameter name, in its units: ``k2_ug_per_g2``, ``rail_low_g``, ...)
    as sensor-file keys and values: a rails pair's elements joined into ``[low, high]``; ``None``
    (an absent element) left out. A rails element without its partner raises ``ValueError``."""
    params = identifiable()
    out: dict[str, float | list[float]] = {}
    pairs: dict[str, list[float | None]] = {}
    for name, v in values.items():
        if name not in params:
            raise ValueError(f"unknown sensor parameter {name!r}; known: {', '.join(params)}")
        p = params[name]
        if p.rail is not None:
            pairs.setdefault(p.file_key, [None, None])[p.rail] = None if v is None else float(v)
        elif v is not None:
            out[p.file_key] = float(v)
    for key, (lo, hi) in pairs.items():
        if lo is None or hi is None:
            raise ValueError(f"{key}: both rails are needed to write it, got [{lo!r}, {hi!r}]")
        out[key] = [lo, hi]
    return out


def _file_value(f: fields.Field, v: Any) -> FileValue:
    if f.kind == "rails":
        return [float(v[0]) * f.scale, float(v[1]) * f.scale]
    if f.kind in ("choice", "bool"):
        as_is: str | bool = v  # the Sensor checked it (fields.Field.check): one of the choices, or a flag
        return as_is
    if f.kind == "order":
        return int(v)
    return float(v) * f.scale


def sensor_document(sensor: Sensor) -> dict[str, Any]:
    """One configuration of a sensor (its range, axis and ODR) as a sensor-file document: every
    row of the field table the sensor has (in the file's units), its facts, its assumed
    uncertainties and, on its axis, its covariance. :func:`vrelab.sensor.load_sensor` of the
    written file gives the same sensor values back."""
    from vrelab.sensor.loader import SCHEMA

    doc: dict[str, Any] = {"schema": SCHEMA, "name": sensor.name}
    if sensor.description:
        doc["description"] = sensor.description
    if sensor.source:
        doc["source"] = sensor.source
    doc["default_range_g"] = sensor.range_g
    if sensor.odr_hz is not None:
        doc["odrs_hz"] = [sensor.odr_hz]
    for f in fields.FIELDS:
        v = getattr(sensor, f.name)
        # a row that acts only with another (a hold with a threshold) is left out without it: the
        # loader refuses a field that has no effect (fields.idle)
        if v is not None and not (f.needs and getattr(sensor, f.needs) is None):
            doc[f.key] = _file_value(f, v)
    if sensor.uncertainty:
        doc["uncertainty"] = dict(sensor.uncertainty)
    doc["default_axis"] = sensor.axis
    axis: dict[str, Any] = {}
    if sensor.covariance is not None:
        axis["covariance"] = {"params": list(sensor.covariance["params"]),
                              "matrix": [list(row) for row in sensor.covariance["matrix"]]}
    doc["axes"] = {sensor.axis: axis}
    doc["facts"] = dict(sensor.facts)
    return doc


def write_sensor_file(path: str | Path, doc: Mapping[str, Any], header: str = "",
                      axes: Iterable[str] | None = None) -> Path:
    """Write ``doc`` as a sensor TOML to ``path`` (``header``: comment lines before it): written
    beside it, loaded for each of ``axes`` (default: the file's default axis), then renamed into
    place. A document that does not load raises that ``ValueError`` and leaves nothing behind."""
    from vrelab.sensor.loader import load_sensor

    path = Path(path)
    text = tomli_w.dumps(dict(doc))
    tmp = path.with_name(path.name + ".partial.toml")
    try:
        tmp.write_text(header + text, encoding="utf-8")
        for axis in (None,) if axes is None else tuple(axes):
            load_sensor(str(tmp), axis=axis)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path
