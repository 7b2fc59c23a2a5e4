"""A campaign's document (the CLI reference: ``results.json``) and its folder."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping, Sequence

from vrelab._io import sha256_file
from vrelab._version import __version__

if TYPE_CHECKING:
    pass

from vrelab.campaigns.manifest import Manifest
from vrelab.campaigns.runs import RunResult
from vrelab.campaigns.summary import ChannelSummary


def campaign_doc(manifest: Manifest, results: Sequence[RunResult], summaries: Sequence[ChannelSummary],
                 command: str | None = None) -> dict[str, Any]:
    """The campaign's JSON (the CLI reference): ``runs`` and ``channels``.

    Examples
    --------
    >>> from vrelab.campaigns.document import campaign_doc
    >>> from vrelab.campaigns.manifest import read_manifest
    >>> from vrelab.campaigns.runs import run_campaign
    >>> from vrelab.campaigns.summary import combine
    >>> manifest = read_manifest("examples/campaign/one-run.toml")
    >>> results = run_campaign(manifest)
    >>> doc = campaign_doc(manifest, results, combine(results, ["sn1"]))
    >>> doc["kind"], doc["n_runs"], [c["channel"] for c in doc["channels"]]
    ('campaign', 1, ['sn1'])
    """
    runs = []
    for rr in results:
        r = rr.run
        d: dict[str, Any] = {
            "index": r.index, "file": _rel(r.file, manifest.path.parent), "label": r.label,
            "status": "ok" if rr.ok else "failed", "error": rr.error, "folder": rr.folder,
            "method": rr.results[0][1].method if rr.results else r.method,
            # what identification needs of the run beyond its levels (vrelab.identify): the drive's
            # spectrum shape and the declared Type B budget
            "profile": profile_document(r.profile), "budget": dict(r.budget),
            "channels": [],
        }  # fmt: skip
        for name, res in rr.results:
            rd = res.to_dict()
            d["channels"].append({"channel": name, "static_g": r.static_g[name],
                                  **(r.mount[name].to_dict() if name in r.mount else {}), **{k: rd[k] for k in (
                                      "levels", "fit", "fits", "warnings", "notices", "conditions")},
                                  **({"noise": rd["noise"]} if "noise" in rd else {})})
        runs.append(d)
    n_failed = sum(1 for rr in results if not rr.ok)
    return {
        "kind": "campaign",
        "name": manifest.name,
        "description": manifest.description,
        "runs": runs,
        "channels": [s.to_dict() for s in summaries],
        "n_runs": len(results),
        "n_failed": n_failed,
        "provenance": {
            "vrelab_version": __version__,
            "manifest": manifest.path.name,
            "manifest_sha256": sha256_file(manifest.path),
            **({"command": command} if command else {}),
        },
    }


def profile_document(spec: str | None) -> dict[str, Any] | None:
    """A run's profile as the campaign document keeps it: the spec and the breakpoints (so a
    campaign folder is self-contained: its profile files need not travel with it).

    Examples
    --------
    >>> from vrelab.campaigns.document import profile_document
    >>> doc = profile_document("flat:50-2000")
    >>> doc["spec"], sorted(doc)
    ('flat:50-2000', ['band_hz', 'breakpoints', 'grms', 'kind', 'name', 'slopes_db_per_oct', 'source', 'spec'])
    """
    if spec is None:
        return None
    from vrelab.profiles import parse_profile

    return {"spec": spec, **parse_profile(spec).to_dict()}


def _rel(p: Path, base: Path) -> str:
    try:
        return str(p.relative_to(base))
    except ValueError:
        return str(p)


def write_campaign(stage: Path, manifest: Manifest, results: Sequence[RunResult],
                   summaries: Sequence[ChannelSummary], doc: Mapping[str, Any]) -> None:
    """``results.json`` (the document), ``levels.csv`` of every level of every run and channel;
    the run folders were written by :func:`run_campaign`.

    Examples
    --------
    >>> from pathlib import Path
    >>> from vrelab.campaigns.document import campaign_doc, write_campaign
    >>> from vrelab.campaigns.manifest import read_manifest
    >>> from vrelab.campaigns.runs import run_campaign
    >>> from vrelab.campaigns.summary import combine
    >>> manifest = read_manifest("examples/campaign/one-run.toml")
    >>> results = run_campaign(manifest)
    >>> summaries = combine(results, ["sn1"])
    >>> Path("out").mkdir()
    >>> write_campaign(Path("out"), manifest, results, summaries, campaign_doc(manifest, results, summaries))
    >>> sorted(p.name for p in Path("out").iterdir())
    ['levels.csv', 'results.json']
    """
    from vrelab._io import write_json, write_levels_table
    from vrelab.folder import LEVELS, RESULTS

    write_json(stage / RESULTS, dict(doc))
    groups = [({"run": rr.run.index, "label": rr.run.label, "channel": name, "static_g": rr.run.static_g[name],
                "method": res.method}, res)
              for rr in results for name, res in rr.results]
    if groups:
        write_levels_table(stage / LEVELS, groups)
