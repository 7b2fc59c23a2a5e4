"""The labelled result: an xarray Dataset over the sweep's axes, and a flat CSV of the same.

Dimensions are the grid axes in file order, preceded by ``unit`` for a Monte Carlo lot (whose
drawn parameters become coordinates along ``unit``). Every variable a point returned becomes a
float array over all dimensions (NaN where the point failed); ``status`` ("ok", "failed",
"missing") and ``error`` ("" when ok) are string arrays over the same dimensions. Nothing about
the run (backend, times, worker count) goes in the Dataset, so the same file gives the same
Dataset however it was computed; that goes in ``sweep.json``.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

import numpy as np

from vrelab._version import __version__
from vrelab.sweep.checkpoint import PointRecord
from vrelab.sweep.spec import SweepSpec

if TYPE_CHECKING:
    import xarray as xr

# Units and descriptions of the variables the built-in point kinds return (CF-style attrs).
VARIABLE_ATTRS: dict[str, dict[str, str]] = {
    "vre_g": {"units": "g", "long_name": "vibration rectification error"},
    "u_vre_g": {"units": "g", "long_name": "standard uncertainty of the VRE (k = 1)"},
    "tilt_error_deg": {"units": "degree", "long_name": "tilt error the VRE reads as"},
    "vibration_off_g": {"units": "g", "long_name": "vibration-off reading, the VRE's reference point"},
    "vre_clip_g": {"units": "g", "long_name": "VRE from the rails (clipping)"},
    "vre_poly_g": {"units": "g", "long_name": "VRE from the scale-factor nonlinearity"},
    "vre_overrange_g": {"units": "g", "long_name": "VRE from over-range protection"},
    "rms_mass_g": {"units": "g", "long_name": "vibration rms at the proof mass"},
    "rms_out_g": {"units": "g", "long_name": "vibration rms at the output rails"},
    "rms_measured_g": {"units": "g", "long_name": "vibration rms measured on the reference"},
    "vrc_ug_per_g2": {"units": "ug/g^2", "long_name": "vibration rectification coefficient"},
    "n_saturated": {"units": "1", "long_name": "DUT samples at a rail"},
    "valid": {"units": "1", "long_name": "1 where the prediction's models hold, 0 where they do not"},
}


def _import_xarray() -> Any:
    try:
        import xarray
    except ImportError:
        raise ValueError("sweep results need xarray and h5netcdf: pip install 'vrelab[sweep]'") from None
    return xarray


def variable_names(spec: SweepSpec, records: Mapping[int, PointRecord]) -> list[str]:
    """Output variables: those the file lists, else every name any point returned (first seen)."""
    if spec.variables is not None:
        return list(spec.variables)
    names: dict[str, None] = {}
    for i in sorted(records):
        names.update(dict.fromkeys(records[i].values))
    return list(names)


def to_dataset(spec: SweepSpec, records: Mapping[int, PointRecord]) -> Any:
    """The sweep as an ``xarray.Dataset`` (points not in ``records`` have status "missing")."""
    xr = _import_xarray()
    shape, dims = spec.shape, spec.dims
    names = variable_names(spec, records)
    taken = set(dims) | {d.param for d in spec.distributions} | {"status", "error"}
    clash = sorted(taken & set(names))
    if clash:
        raise ValueError(
            f"output variable {clash[0]!r} has the name of a sweep axis or parameter: "
            "rename it in the point function, or leave it out with output.variables"
        )
    data = {n: np.full(spec.n_points, np.nan) for n in names}
    status = np.full(spec.n_points, "missing", dtype=object)
    error = np.full(spec.n_points, "", dtype=object)
    for i, r in records.items():
        status[i] = r.status
        error[i] = r.error or ""
        for n in names:
            if n in r.values:
                data[n][i] = r.values[n]
    coords: dict[str, Any] = {name: (name, _coord(values)) for name, values in spec.grid}
    if spec.units is not None:
        coords["unit"] = ("unit", np.arange(spec.units))
        draws = [spec.unit_params(u) for u in range(spec.units)]
        for d in spec.distributions:
            coords[d.param] = ("unit", np.array([p[d.param] for p in draws]), {"long_name": f"drawn: {d.to_dict()}"})
    variables: dict[str, Any] = {n: (dims, data[n].reshape(shape), VARIABLE_ATTRS.get(n, {})) for n in names}
    variables["status"] = (dims, status.reshape(shape).astype(str))
    variables["error"] = (dims, error.reshape(shape).astype(str))
    attrs: dict[str, Any] = {
        "title": spec.name,
        "kind": spec.kind,
        "seed": spec.seed,
        "fingerprint": spec.fingerprint(),
        "spec_json": json.dumps(spec.to_dict(), sort_keys=True),
        "source": f"vrelab {__version__} sweep",
    }
    for k, v in spec.fixed.items():
        attrs[f"fixed_{k}"] = v if not isinstance(v, bool) else int(v)
    return xr.Dataset(variables, coords=coords, attrs=attrs)


def _coord(values: tuple[Any, ...]) -> np.ndarray:
    if all(isinstance(v, str) for v in values):
        return np.array(values, dtype=str)
    return np.array(values, dtype=float)


def write_netcdf(ds: xr.Dataset, path: Path) -> None:
    ds.to_netcdf(path, engine="h5netcdf")


def require_zarr() -> None:
    try:
        import zarr  # noqa: F401
    except ImportError:
        raise ValueError("output.formats: zarr needs the zarr package (pip install zarr)") from None


def write_zarr(ds: xr.Dataset, path: Path) -> None:
    require_zarr()
    ds.to_zarr(path, mode="w")


def flat_rows(spec: SweepSpec, records: Mapping[int, PointRecord]) -> tuple[list[str], list[dict[str, Any]]]:
    """One row per point, in index order: index, the axes, the drawn parameters, the outputs."""
    names = variable_names(spec, records)
    units = [spec.unit_params(u) for u in range(spec.units or 0)]
    mc = [d.param for d in spec.distributions]
    header = ["index", *spec.dims, *mc, *names, "status", "error"]
    rows = []
    for i in range(spec.n_points):
        pos = np.unravel_index(i, spec.shape) if spec.shape else ()
        row: dict[str, Any] = {"index": i}
        axes = list(pos)
        if spec.units is not None:
            u = int(axes.pop(0))
            row["unit"] = u
            row.update(units[u])
        for (name, values), j in zip(spec.grid, axes):
            row[name] = values[int(j)]
        r = records.get(i)
        for n in names:
            row[n] = r.values.get(n, math.nan) if r is not None else math.nan
        row["status"] = r.status if r is not None else "missing"
        row["error"] = (r.error or "") if r is not None else ""
        rows.append(row)
    return header, rows


def write_csv(spec: SweepSpec, records: Mapping[int, PointRecord], path: Path) -> None:
    header, rows = flat_rows(spec, records)
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=header)
        w.writeheader()
        for row in rows:
            # repr keeps every bit of a float: the CSV reads back to the same numbers
            w.writerow({k: repr(v) if isinstance(v, float) else v for k, v in row.items()})
