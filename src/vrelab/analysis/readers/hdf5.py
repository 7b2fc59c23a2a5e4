"""HDF5 through h5py (datasets read by slices; vrelab's own records carry their schedule and meta)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vrelab._budget import memory_budget_bytes
from vrelab._load import json_loads
from vrelab.analysis.readers._base import (
    DT_KEYS,
    FS_KEYS,
    HDF5_MAGIC,
    MAX_CHANNELS,
    ArraySource,
    column_channels,
    register,
)
from vrelab.record import Schedule


def _stated_rate(obj: Any) -> float | None:
    """The rate an HDF5 object's own attributes state (``fs_hz``..., or the inverse of ``dt``...)."""
    keys = set(obj.attrs.keys())  # one listing, rather than a lookup per candidate key
    for k in FS_KEYS:
        if k in keys:
            return float(np.asarray(obj.attrs[k]).ravel()[0])
    for k in DT_KEYS:
        if k in keys:
            dt = float(np.asarray(obj.attrs[k]).ravel()[0])
            return 1.0 / dt if dt > 0 else None
    return None


def _find_rate_h5(obj: Any, groups: dict[str, float | None] | None = None) -> float | None:
    """The rate of a dataset: its own attributes', else the nearest enclosing group's (each
    group's looked up once in ``groups``: a file of many datasets shares a few groups)."""
    groups = {} if groups is None else groups
    fs = _stated_rate(obj)
    if fs is not None:
        return fs
    name = obj.name
    while name != "/":
        name = name.rsplit("/", 1)[0] or "/"
        if name not in groups:
            groups[name] = _stated_rate(obj.file[name])
        if groups[name] is not None:
            return groups[name]
    return None


# a filtered chunk may take this fraction of the memory budget (see _chunk_refusal)
CHUNK_BUDGET_FRACTION = 64


def _text(name: Any) -> str:
    return name.decode(errors="replace") if isinstance(name, bytes) else str(name)


def _elsewhere(d: Any) -> tuple[str, tuple[str, ...]] | None:
    """Where a dataset's samples live when not in its file's own bytes: HDF5 external storage
    (raw bytes of other files, ``H5Pset_external``) or a virtual dataset (datasets of other files,
    ``"."`` for its own); None when they are in the file. Both are read by HDF5 from wherever the
    names point (``/etc/passwd`` as well), so a file cannot be trusted to hold its own data."""
    ext = d.external
    if ext:
        return "external", tuple(dict.fromkeys(_text(e[0]) for e in ext))
    if d.is_virtual:
        return "virtual", tuple(dict.fromkeys(_text(m.file_name) for m in d.virtual_sources()))
    return None


def _pandas_block(name: str, d: Any) -> dict[str, tuple[Any, Any]] | None:
    """A pandas DataFrame's block (``DataFrame.to_hdf``, fixed format: the frame's group has
    ``pandas_type = 'frame'``, ``blockN_values`` holds columns named by ``blockN_items``), as
    channels ``<group>/<column>``; None for any other dataset. pandas stores a block transposed
    (``transposed`` attribute: rows are samples, one column per item), pandas/io/pytables.py
    ``write_array``."""
    grp, _, leaf = name.rpartition("/")
    if not (leaf.startswith("block") and leaf.endswith("_values")) or d.ndim != 2:
        return None
    parent = d.parent
    if _text(parent.attrs.get("pandas_type", b"")) != "frame":
        return None
    items = parent.get(leaf.replace("_values", "_items"))
    if items is None or items.ndim != 1:
        return None
    names = [_text(x) for x in items[()]]
    by_col = bool(d.attrs.get("transposed", False))
    if len(names) != (d.shape[1] if by_col else d.shape[0]) or len(set(names)) != len(names):
        return None
    prefix = f"{grp}/" if grp else ""
    return {f"{prefix}{n}": (d, ("col" if by_col else "row", i)) for i, n in enumerate(names)}


def _chunk_refusal(d: Any) -> str | None:
    """Why a dataset in filtered (compressed) chunks is not read: a chunk is inflated whole by
    any read that touches it, so a 2 MB file whose one chunk inflates to 1 GiB asks for 1 GiB
    per read. A chunk may take 1/64 of the memory budget (:func:`vrelab._budget.memory_budget_bytes`:
    62.5 MB by default, 7.8 M float64 samples, far above the 1 MiB HDF5 advises and h5py's
    own chunking picks), so that a record's few channels, each holding a chunk in HDF5's
    cache, stay well inside the budget. None: it may be read."""
    from vrelab._budget import human_bytes, memory_budget_bytes

    if d.chunks is None or d.id.get_create_plist().get_nfilters() == 0:
        return None
    size = math.prod(d.chunks) * d.dtype.itemsize
    limit = memory_budget_bytes() / CHUNK_BUDGET_FRACTION
    if size <= limit:
        return None
    return (f"is stored in compressed chunks of {human_bytes(size)} each, inflated whole by any read: beyond the "
            f"{human_bytes(limit)} a chunk may take (1/{CHUNK_BUDGET_FRACTION} of the memory budget, "
            "VRELAB_MEMORY_BUDGET_GB); rechunk the file (h5repack -l CHUNK=65536) or raise the budget")


def _open_dataset(f: Any, name: str) -> Any:
    """Dataset ``name`` of file ``f``, without a chunk cache when its chunks are stored unfiltered
    (uncompressed): HDF5 then reads a stretch straight from the file into the array, where through
    the cache it first copies every chunk the read touches whole (a plausibility probe of 8192
    samples copied a chunk of 65536, and the first pass paid a second copy of every block; the 2 h
    bench record, bench/bench_analyze_hdf5.py: its whole read about 0.55 -> 0.45 s of CPU, its 120
    probes 64 -> 30 ms). Filtered chunks keep the file's cache (:class:`Hdf5Source`): each is
    inflated once, not once per read that touches it."""
    import h5py

    d = f[name]
    if d.chunks is None or d.id.get_create_plist().get_nfilters() != 0:
        return d
    path = d.name.encode("utf-8")
    del d  # closed first: a second handle on an open dataset shares its chunk cache
    dapl = h5py.h5p.create(h5py.h5p.DATASET_ACCESS)
    dapl.set_chunk_cache(0, 0, 1.0)
    return h5py.Dataset(h5py.h5d.open(f.id, path, dapl))


@register
class Hdf5Source(ArraySource):
    fmt = "hdf5"
    extensions = (".h5", ".hdf5", ".hdf", ".he5", ".nc")

    @classmethod
    def can_open(cls, head: bytes) -> bool:
        return head.startswith(HDF5_MAGIC)

    def __init__(self, path: Path, matlab: bool = False) -> None:
        import h5py

        super().__init__(path)
        if matlab:
            self.fmt = "mat-v7.3"  # type: ignore[misc]  # this instance's format name: MATLAB v7.3 is HDF5
        try:
            # a chunk cache that holds one chunk of the largest size read (a chunk larger than the
            # cache is inflated again for every block read from it)
            self.f = h5py.File(path, "r", rdcc_nbytes=int(memory_budget_bytes() / CHUNK_BUDGET_FRACTION))
        except OSError as exc:
            raise ValueError(f"{path.name}: cannot open as HDF5 (truncated or corrupt file?): {exc}") from None
        names: list[str] = []
        total = 0

        def visit(name: str, info: Any) -> None:
            nonlocal total
            if info.type == h5py.h5o.TYPE_DATASET:
                total += 1
                if len(names) < MAX_CHANNELS:
                    names.append(name)

        try:  # names only (no object per dataset): a file of 10^5 datasets is counted in a second
            h5py.h5o.visit(self.f.id, visit, info=True)
            dsets = [_open_dataset(self.f, n) for n in names]
        except (OSError, RuntimeError, KeyError) as exc:
            raise ValueError(f"{path.name}: cannot read HDF5 structure (truncated or corrupt file?): {exc}") from None
        if total > len(names):
            self.unlisted = total - len(names)
            self.notes.append(f"{total} datasets: the first {len(names)} indexed, {self.unlisted} more not listed "
                              "(name one by its full path to read it)")
        self._groups: dict[str, float | None] = {}
        rates: set[float] = set()
        for d in dsets:
            rate = self._index(d)
            if rate:
                rates.add(rate)
        if self.fs_hz is None and rates:
            if len(rates) > 1:
                raise ValueError(f"{path.name}: channels have different sample rates: {sorted(rates)}")
            self.fs_hz = rates.pop()
        if "meta" in self.f.attrs:
            try:
                self.meta = dict(json_loads(self.f.attrs["meta"], "attribute 'meta'"))
            except (TypeError, ValueError):
                self.notes.append("attribute 'meta' is not JSON: ignored")

    def _index(self, d: Any) -> float | None:
        """Make dataset ``d``'s channels (or take it as the schedule, the file's rate); the rate
        its attributes or its groups' state."""
        name = d.name.lstrip("/")
        where = _elsewhere(d)
        if where and [f for f in where[1] if f != "."] and (name == "schedule" or d.size <= 1):
            self.notes.append(f"dataset {name!r} keeps its values in another file ({', '.join(where[1])}): not read")
            return None
        if name == "schedule" or name.startswith("#refs#") or d.dtype.kind not in "biuf":
            if name == "schedule" and d.ndim == 2 and d.shape[1] == 4:
                self.schedule = Schedule.from_array(d[()]) if d.shape[0] else None
            return None
        if d.size <= 1:
            if name.split("/")[-1] in FS_KEYS:
                self.fs_hz = float(np.asarray(d[()]).ravel()[0])
            return None
        leaf = name.rsplit("/", 1)[-1]
        if leaf in ("axis0", "axis1") and _text(d.parent.attrs.get("pandas_type", b"")) == "frame":
            return None  # a pandas frame's column names and index, not signals
        made = _pandas_block(name, d) or column_channels(name, d)
        self.add(made)
        chans = [c for c in made if c in self.specs]
        if not chans:
            return None
        if where:
            self.elsewhere.update({c: where for c in chans})
        why = _chunk_refusal(d)
        if why:
            self.unreadable.update({c: why for c in chans})
        keys = set(d.attrs.keys())
        unit = next((d.attrs[k] for k in ("unit", "units", "unit_string") if k in keys), None)
        if isinstance(unit, bytes):
            unit = unit.decode(errors="replace")
        if isinstance(unit, str) and unit.strip():
            for c in chans:
                self.units[c] = unit.strip()
        return _find_rate_h5(d, self._groups)

    def find(self, name: str) -> bool:
        """A dataset beyond the ones indexed (a file of more than :data:`MAX_CHANNELS`), by its
        exact path: indexed now; False when there is none by that path."""
        import h5py

        d = self.f.get(name.lstrip("/"))
        if not isinstance(d, h5py.Dataset) or d.name.lstrip("/") in self.specs:
            return False
        rate = self._index(d)
        if rate and self.fs_hz is not None and rate != self.fs_hz:
            self.rates.update({c: rate for c in self.specs if c == d.name.lstrip("/") or c.startswith(d.name.lstrip("/") + "/")})
        elif rate and self.fs_hz is None:
            self.fs_hz = rate
        return True

    def read(self, name: str, start: int, stop: int) -> NDArray[Any]:
        why = self.refusal(name, "channel")
        if why:  # open_record refuses these first; never read another file's bytes
            raise ValueError(why)
        try:
            return super().read(name, start, stop)
        except OSError as exc:
            raise ValueError(f"{self.path.name}: cannot read {name!r} at samples {start}-{stop} (truncated file?): {exc}") from None

    def close(self) -> None:
        self.f.close()
