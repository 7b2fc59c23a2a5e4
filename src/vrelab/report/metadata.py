"""What a test report needs that no record holds: the laboratory, the item, the equipment, who signs.

``vrelab report DIR --metadata FILE.toml`` (and ``vrelab demo --metadata``) reads a TOML file
with the tables below; every key is optional, and the report says "not given" wherever one is
missing, never a guess. The structure follows what ISO/IEC 17025:2017 clause 7.8 asks a test
report to hold (laboratory, customer, unique identification of the report and of the item,
method, equipment, environmental conditions, deviations, who authorised it, date of issue) and
the test-report habits of IEEE Std 1293 (reference accelerometer and its calibration, fixture).

.. code-block:: toml

    report_number = "VRE-2025-014"
    paper = "A4"                     # or "letter"
    [laboratory]
    name = "Vibration Lab, Example GmbH"
    address = "Example Street 1, 12345 Example City"
    [item]                           # the device under test (every channel)
    manufacturer = "Analog Devices"
    model = "ADXL355"
    [items.sn1]                      # one channel's own values (its name in the results)
    serial = "SN 0001"
    [equipment]
    reference = "PCB 352C33"
    reference_serial = "LW12345"
    reference_calibration = "cert. 2024-118, 2024-11-02, due 2025-11-02"
    shaker = "LDS V406"
    daq = "NI 9234"
    [procedure]
    standard = "IEEE Std 1293-2018, sine method"
    [approval]
    prepared_by = "A. Tester"
    reviewed_by = "B. Reviewer"
    approved_by = "C. Manager"
    date = 2025-03-14

An unknown table or key, or a value of the wrong type, is a ``ValueError`` of one line naming
the file, the table and the key (the CLI prints it and exits with status 2).
"""

from __future__ import annotations

import datetime as _dt
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, Mapping

from vrelab._load import toml_load

__all__ = ["SCHEMA", "ReportMetadata", "load_metadata", "parse_metadata", "NOT_GIVEN"]

NOT_GIVEN = "not given"

# table -> key -> what it is (the one list of keys: validation, --help and the README's example
# follow it). "" is the file's top level. Keys ending in "date" or named "received" also take a
# TOML date.
SCHEMA: Mapping[str, Mapping[str, str]] = {
    "": {"report_number": "the report's unique identification", "title": "the report's title (--title wins)",
         "paper": 'the printed paper: "A4" (the default) or "letter"'},
    "laboratory": {"name": "laboratory name", "address": "laboratory address",
                   "accreditation": "accreditation body and number"},
    "customer": {"name": "customer name", "address": "customer address"},
    "item": {"name": "what the item is", "manufacturer": "manufacturer", "model": "model",
             "serial": "serial number", "description": "description", "condition": "condition on receipt",
             "received": "date of receipt", "range": "the range set for the test (when the results do not hold it)",
             "axis": "the axis tested (when the results do not hold it)",
             "odr": "output data rate (when the results do not hold it)",
             "bandwidth": "bandwidth (when the results do not hold it)"},
    "equipment": {"reference": "reference accelerometer (make, model)", "reference_serial": "its serial number",
                  "reference_calibration": "its calibration: certificate, date, due date",
                  "shaker": "shaker", "controller": "vibration controller", "daq": "data acquisition",
                  "fixture": "fixture (its lowest resonance)", "other": "other equipment"},
    "conditions": {"temperature": "ambient temperature", "humidity": "relative humidity", "notes": "other conditions"},
    "procedure": {"standard": "standard or method followed", "text": "the procedure",
                  "deviations": "deviations from the procedure",
                  "test_date": "date of the test (its last day; the reference's calibration is checked against it)"},
    "approval": {"prepared_by": "who prepared the report", "reviewed_by": "who reviewed it",
                 "approved_by": "who approved it", "date": "date of issue", "prepared_date": "date prepared",
                 "reviewed_date": "date reviewed", "approved_date": "date approved"},
}
# [items.<channel>] tables take the keys of [item].
_PER_CHANNEL = "items"


def _is_date_key(key: str) -> bool:
    return key.endswith("date") or key == "received"


def _toml_type(v: object) -> str:
    if isinstance(v, bool):
        return "boolean"
    for t, name in ((str, "string"), (int, "integer"), (float, "float"), (list, "array"), (dict, "table"),
                    (_dt.datetime, "date-time"), (_dt.date, "date"), (_dt.time, "time")):
        if isinstance(v, t):
            return name
    return type(v).__name__


@dataclass(frozen=True)
class ReportMetadata:
    """The validated metadata: one read-only mapping of strings per table (dates as ISO text),
    ``items`` per DUT channel, and where it came from."""

    tables: Mapping[str, Mapping[str, str]] = field(default_factory=dict)
    items: Mapping[str, Mapping[str, str]] = field(default_factory=dict)
    source: str | None = None

    def get(self, table: str, key: str) -> str | None:
        """The value of ``[table] key`` ("" for the top level), None when not given."""
        return self.tables.get(table, {}).get(key)

    def shown(self, table: str, key: str) -> str:
        """The value, or "not given"."""
        v = self.get(table, key)
        return NOT_GIVEN if v is None else v

    def item(self, channel: str | None, key: str) -> str | None:
        """``[items.<channel>] key``, else ``[item] key``, else None."""
        if channel is not None and key in self.items.get(channel, {}):
            return self.items[channel][key]
        return self.get("item", key)


def _value(where: str, table: str, key: str, v: object) -> str:
    name = f"[{table}] {key}" if table else key
    if isinstance(v, str):
        if not v.strip():
            raise ValueError(f"{where}: {name} is empty (leave the key out: the report then says '{NOT_GIVEN}')")
        return v
    if _is_date_key(key) and isinstance(v, (_dt.date, _dt.datetime)):
        return v.isoformat()
    want = "a string or a TOML date" if _is_date_key(key) else "a string"
    hint = f' (quote it: {key} = "{v}")' if isinstance(v, (int, float)) and not isinstance(v, bool) else ""
    raise ValueError(f"{where}: {name} must be {want}, got {_toml_type(v)}{hint}")


# The papers the printed report is laid out for (CSS @page size keywords).
PAPERS = ("A4", "letter")


def _checked(where: str, table: str, key: str, v: str) -> str:
    """A value with a closed set of choices (the paper), checked here so a typo is an error."""
    if table == "" and key == "paper":
        got = {p.lower(): p for p in PAPERS}.get(v.strip().lower())
        if got is None:
            raise ValueError(f"{where}: paper must be one of {', '.join(PAPERS)}, got {v!r}")
        return got
    return v


def _table(where: str, table: str, doc: Mapping[str, Any], keys: Mapping[str, str]) -> dict[str, str]:
    out = {}
    for key, v in doc.items():
        if key not in keys:
            name = f"[{table}]" if table else "the top level"
            raise ValueError(f"{where}: unknown key {key!r} in {name} (known: {', '.join(sorted(keys))})")
        out[key] = _value(where, table, key, v)
    return out


def parse_metadata(doc: Mapping[str, Any], source: str | None = None) -> ReportMetadata:
    """Validate a metadata document (the parsed TOML) against :data:`SCHEMA`.

    Raises ``ValueError`` (one line, naming ``source``, the table and the key) for an unknown
    table or key, a value of the wrong type, or an empty string.
    """
    where = f"report metadata {source}" if source else "report metadata"
    if not isinstance(doc, Mapping):
        raise ValueError(f"{where}: must be a table of tables, got {_toml_type(doc)}")
    tables: dict[str, dict[str, str]] = {"": {}}
    items: dict[str, dict[str, str]] = {}
    known = ", ".join(f"[{t}]" for t in [*SCHEMA, _PER_CHANNEL + ".<channel>"] if t)
    for name, sub in doc.items():
        if name in SCHEMA[""]:
            tables[""][name] = _checked(where, "", name, _value(where, "", name, sub))
        elif name == _PER_CHANNEL:
            if not isinstance(sub, Mapping):
                raise ValueError(f"{where}: items must be tables, one per channel ([items.<channel>]), got {_toml_type(sub)}")
            for channel, d in sub.items():
                if not isinstance(d, Mapping):
                    raise ValueError(f"{where}: [items] holds one table per channel ([items.{channel}]), "
                                     f"got {_toml_type(d)} for {channel!r}")
                items[str(channel)] = _table(where, f"items.{channel}", d, SCHEMA["item"])
        elif name in SCHEMA:
            if not isinstance(sub, Mapping):
                raise ValueError(f"{where}: {name} must be a table ([{name}]), got {_toml_type(sub)}")
            tables[name] = _table(where, name, sub, SCHEMA[name])
        elif isinstance(sub, Mapping):
            raise ValueError(f"{where}: unknown table [{name}] (known: {known})")
        else:
            raise ValueError(f"{where}: unknown key {name!r} at the top level (known: {', '.join(sorted(SCHEMA['']))}; "
                             f"tables {known})")
    frozen = {k: MappingProxyType(v) for k, v in tables.items()}
    return ReportMetadata(MappingProxyType(frozen), MappingProxyType({k: MappingProxyType(v) for k, v in items.items()}),
                          source)


def load_metadata(path: str | Path) -> ReportMetadata:
    """Read and validate a metadata TOML file (:func:`parse_metadata`); a missing or unreadable
    file, or one that is not TOML, is a one-line ``ValueError``."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            doc = toml_load(fh, f"report metadata {path}")
    except OSError as exc:
        raise ValueError(f"report metadata {path}: cannot read it ({exc.strerror or exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"report metadata {path}: not valid TOML ({str(exc).splitlines()[0]})") from None
    return parse_metadata(doc, str(path))
