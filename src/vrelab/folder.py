"""A results folder: the one owner of its file names, of how it is written and how it is read.

``vrelab simulate --out DIR``, ``vrelab analyze --out DIR``, the demo and ``vrelab sweep --out
DIR`` write folders; ``vrelab report DIR`` reads them. Each file's name lives here and nowhere
else, so a writer and a reader cannot drift apart:

======================  ===========================================================  =========
file                    what                                                          written by
======================  ===========================================================  =========
``results.json``        :meth:`vrelab.results.VreResult.to_dict` (the ``--json``)      simulate, analyze, demo
                        or, several DUTs: ``channels`` (one sub-folder each)         analyze ``--dut a,b``
                        or a campaign's ``runs`` and ``channels``                    campaign
``levels.csv``          one row per level (:func:`vrelab._io.write_levels_csv`)       simulate, analyze, demo
``prediction.json``     the analytic prediction for the same conditions               simulate, demo
``record.h5``           the raw record (HDF5, channels ``dut`` and ``reference``)    simulate ``--record``
``envelope.csv``        per analysis window: time, rms, DUT mean, segment label      analyze
``psd.csv``             reference PSD against the profile                             analyze (random)
``psd_levels.csv``      reference PSD per level                                       analyze (random)
``result.nc``           the sweep's xarray Dataset                                   sweep
``report.html``         the report                                                   report, demo
``summary.json``        the demo's numbers against the article's                     demo
``identification.json`` each channel's identified model (what ``--json`` prints)     identify
``sensor.toml``         the identified sensor file (``--sensor`` with ``--axis CH``)  identify
======================  ===========================================================  =========

Writing goes through :func:`vrelab._io.output_dir` (a folder is written completely or not at
all, and only a folder that is empty, new or vrelab's own: its ``.vrelab-output`` lists every
entry vrelab wrote; never one holding an input of the run); reading refuses a missing or
malformed file with one line naming it.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, Mapping, Sequence

from vrelab._io import write_json, write_levels_csv, write_levels_table
from vrelab._load import json_loads

# the folder's names, re-exported (their owner is _names; `X as X` makes it explicit for mypy)
from vrelab._names import ENVELOPE as ENVELOPE
from vrelab._names import IDENTIFICATION as IDENTIFICATION
from vrelab._names import IDENTIFIED_SENSOR as IDENTIFIED_SENSOR
from vrelab._names import KNOWN_NAMES as KNOWN_NAMES
from vrelab._names import LEVELS as LEVELS
from vrelab._names import OPAQUE_DIRS as OPAQUE_DIRS
from vrelab._names import PREDICTION as PREDICTION
from vrelab._names import PSD as PSD
from vrelab._names import PSD_LEVELS as PSD_LEVELS
from vrelab._names import RECORD as RECORD
from vrelab._names import REPORT as REPORT
from vrelab._names import RESULT_FILES as RESULT_FILES
from vrelab._names import RESULTS as RESULTS
from vrelab._names import SUMMARY as SUMMARY
from vrelab._names import SWEEP_FILES as SWEEP_FILES
from vrelab._names import SWEEP_RESULT as SWEEP_RESULT
from vrelab.results import VreResult

FolderKind = Literal["result", "sweep", "channels", "campaign", "identification"]


FOLDER_NAME_MAX = 100


def channel_folder_names(names: Sequence[str]) -> dict[str, str]:
    """A sub-folder name per channel (or run): its name with anything but letters, digits,
    ``.``, ``_``, ``-`` replaced, made unique."""
    out: dict[str, str] = {}
    used: set[str] = set()
    for name in names:
        # at most FOLDER_NAME_MAX characters: a file system takes 255 bytes a name (a 400-character
        # run label failed the campaign with ENAMETOOLONG); names cut alike are made unique below
        base = re.sub(r"[^A-Za-z0-9._-]+", "_", str(name))[:FOLDER_NAME_MAX].strip("._") or "channel"
        cand, i = base, 2
        while cand.lower() in used:
            cand, i = f"{base}_{i}", i + 1
        used.add(cand.lower())
        out[name] = cand
    return out


def write_channels(folder: str | Path, results: Sequence[tuple[str, VreResult]], doc: Mapping[str, Any],
                   lead: Mapping[str, Mapping[str, Any]] | None = None) -> dict[str, Path]:
    """Several channels' results into ``folder``: ``results.json`` (``doc``), ``levels.csv`` of
    all of them (first column ``channel``, then ``lead[name]``'s keys) and one sub-folder per
    channel written by :func:`write_result`. Returns name -> sub-folder."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    subs = channel_folder_names([n for n, _ in results])
    out: dict[str, Path] = {}
    for name, res in results:
        out[name] = folder / subs[name]
        write_result(out[name], res)
    write_json(folder / RESULTS, dict(doc))
    write_levels_table(folder / LEVELS, [({"channel": n, **dict((lead or {}).get(n, {}))}, r) for n, r in results])
    return out


def write_result(folder: str | Path, result: VreResult, prediction: Mapping[str, Any] | None = None) -> None:
    """``results.json``, ``levels.csv`` and, when given, ``prediction.json`` into ``folder``.

    ``folder`` is a staging folder of :func:`vrelab._io.output_dir` (or one the caller owns);
    each file is itself written atomically.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    write_json(folder / RESULTS, result.to_dict())
    write_levels_csv(folder / LEVELS, result)
    if prediction is not None:
        write_json(folder / PREDICTION, dict(prediction))


@dataclass(frozen=True)
class ResultsFolder:
    """What a results folder holds, read back (``result`` is None for a sweep folder)."""

    path: Path
    kind: FolderKind
    result: VreResult | None = None
    prediction: Mapping[str, Any] | None = None
    doc: Mapping[str, Any] | None = None  # results.json of a several-channel or campaign folder

    def file(self, name: str) -> Path | None:
        """``path/name`` when that file exists, else None."""
        p = self.path / name
        return p if p.is_file() else None


def read_folder(folder: str | Path) -> ResultsFolder:
    """Read a results folder: a simulate/analyze/demo result, or a sweep.

    Raises ``ValueError`` (one line, naming the folder or file) when the folder is missing,
    holds neither ``results.json`` nor ``result.nc``, or a file is not what it should be.
    """
    path = Path(folder)
    if not path.is_dir():
        raise ValueError(f"report: not a folder: {path}")
    if not (path / RESULTS).exists():
        if (path / SWEEP_RESULT).exists():
            return ResultsFolder(path, "sweep")
        if (path / IDENTIFICATION).is_file():
            doc = _read_json(path / IDENTIFICATION)
            if not isinstance(doc, dict) or not isinstance(doc.get("channels"), list):
                raise ValueError(f"report: {path / IDENTIFICATION} is not a vrelab identification (no channels)")
            return ResultsFolder(path, "identification", doc=doc)
        raise ValueError(
            f"report: no {RESULTS} (simulate/analyze --out), no {SWEEP_RESULT} (sweep --out) and no {IDENTIFICATION} "
            f"(identify --out) in {path}"
        )
    doc = _read_json(path / RESULTS) if (path / RESULTS).is_file() else None
    if isinstance(doc, dict) and isinstance(doc.get("runs"), list):
        return ResultsFolder(path, "campaign", doc=doc)
    if isinstance(doc, dict) and isinstance(doc.get("channels"), list) and "levels" not in doc:
        return ResultsFolder(path, "channels", doc=doc)
    return ResultsFolder(path, "result", load_results(path), _load_prediction(path))


def _read_json(f: Path) -> Any:
    try:
        return json_loads(f.read_text(encoding="utf-8"), f"report: {f}")
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"report: {f} is not valid JSON ({str(exc).splitlines()[0]})") from None


def load_results(folder: str | Path) -> VreResult:
    """Read ``folder/results.json``; a missing or malformed file is a one-line ``ValueError``."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"report: not a folder: {folder}")
    f = folder / RESULTS
    if not f.is_file():
        raise ValueError(f"report: no {RESULTS} in {folder} (run simulate/analyze with --out {folder} first)")
    doc = _read_json(f)
    if not isinstance(doc, dict):
        raise ValueError(f"report: {f} must hold a JSON object, got {type(doc).__name__}")
    try:
        result = VreResult.from_dict(doc)
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise ValueError(f"report: {f} is not a vrelab results file ({type(exc).__name__}: {exc})") from None
    if result.method not in ("random", "sine"):
        raise ValueError(f"report: {f}: method must be random or sine, got {result.method!r}")
    return result


def _load_prediction(folder: Path) -> Mapping[str, Any] | None:
    f = folder / PREDICTION
    if not f.is_file():
        return None
    doc = _read_json(f)
    levels = doc.get("levels") if isinstance(doc, dict) else None
    if not isinstance(doc, dict) or not isinstance(levels, list) or not all(isinstance(lv, dict) for lv in levels):
        raise ValueError(f"report: {f} is not a vrelab prediction (needs a list of level objects under 'levels')")
    return doc
