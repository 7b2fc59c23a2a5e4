"""Named profiles and environments shipped in ``vrelab/data``, and the one parser of a
profile given on the command line (a name, a file, ``F:P,F:P,...``, ``flat:F1-F2``,
``+sine:F:PEAK,...`` tones)."""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from vrelab import _validate as v
from vrelab.profiles.files import read_profile
from vrelab.profiles.shapes import Profile, RandomProfile, SineOnRandom, Tone, check_tone_count

# --- named profiles ---------------------------------------------------------------------------


def named_profiles() -> dict[str, str]:
    """Named profiles shipped in ``vrelab/data``: name -> path of its TOML file.

    Examples
    --------
    >>> from vrelab.profiles import named_profiles
    >>> sorted(named_profiles())[:2]
    ['adi-flat-50-2000', 'gevs-workmanship']
    """
    folder = resources.files("vrelab") / "data"
    out: dict[str, str] = {}
    for item in sorted(folder.iterdir(), key=lambda x: x.name):
        if item.name.endswith(".toml"):
            out[item.name[: -len(".toml")]] = str(item)
    return out


# The [environment] table of a named profile's file: what the standard says about it.
_ENV_TEXT_KEYS = ("title", "document", "table", "figure", "reproduced_from", "note")
_ENV_KEYS = (*_ENV_TEXT_KEYS, "stated_grms")


@dataclass(frozen=True)
class Environment:
    """A named vibration environment: a profile with where it comes from (the environments page).

    ``source`` names the document and its table or figure; ``stated_grms`` is the overall level
    the standard (or the public reproduction named in ``reproduced_from``) states, which may
    differ from the log-log area of the breakpoints (:attr:`grms`); ``note`` says why when it does.

    Examples
    --------
    >>> from vrelab.profiles import load_environment
    >>> env = load_environment("navmat-p9492")
    >>> print(env.title)
    NAVMAT P-9492 random screening spectrum
    >>> print(f"{env.grms:.2f} g rms over {env.band_hz[0]:.0f}-{env.band_hz[1]:.0f} Hz")
    6.06 g rms over 20-2000 Hz
    """

    name: str
    title: str
    source: str
    profile: Profile
    stated_grms: float | None = None
    reproduced_from: str | None = None
    note: str | None = None

    @property
    def grms(self) -> float:
        """Overall level of the breakpoints (and tones) by the log-log area formula [g rms]."""
        return self.profile.grms

    @property
    def band_hz(self) -> tuple[float, float]:
        return self.profile.band

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "title": self.title,
            "source": self.source,
            "grms": self.grms,
            "band_hz": list(self.band_hz),
            "stated_grms": self.stated_grms,
            "reproduced_from": self.reproduced_from,
            "note": self.note,
        }


def _environment_table(path: str) -> dict[str, Any]:
    """The checked ``[environment]`` table of a named profile's file (empty when it has none)."""
    with open(path, "rb") as fh:
        table = tomllib.load(fh).get("environment", {})
    if not isinstance(table, dict):
        raise ValueError(f"{path}: environment must be a table")
    unknown = sorted(set(table) - set(_ENV_KEYS))
    if unknown:
        raise ValueError(f"{path}: environment.{unknown[0]}: unknown key (known: {', '.join(_ENV_KEYS)})")
    for key in _ENV_TEXT_KEYS:
        if key in table and not isinstance(table[key], str):
            raise ValueError(f"{path}: environment.{key} must be a string, got {table[key]!r}")
    if "stated_grms" in table:
        table["stated_grms"] = v.positive_scalar(f"{path}: environment.stated_grms", table["stated_grms"])
    return table


def _citation(table: dict[str, Any]) -> str | None:
    """'document, table, figure' of an [environment] table (None without a document)."""
    parts = [table[k] for k in ("document", "table", "figure") if table.get(k)]
    return ", ".join(parts) if table.get("document") else None


def load_named_profile(name: str) -> Profile:
    """The named profile ``name`` (see :func:`named_profiles`).

    Examples
    --------
    >>> from vrelab.profiles import load_named_profile
    >>> print(f"{load_named_profile('gevs-workmanship').grms:.2f} g rms")
    6.78 g rms
    """
    return load_environment(name, what="profile").profile


def load_environment(name: str, what: str = "environment") -> Environment:
    """The named environment ``name``: its profile, title, source and stated grms.

    Every named profile is an environment; its file's ``[environment]`` table (``title``,
    ``document``, ``table``, ``figure``, ``stated_grms``, ``reproduced_from``, ``note``) says
    where it comes from. A profile without its own ``source`` takes the citation built from
    ``document``, ``table`` and ``figure``.

    Examples
    --------
    NAVMAT P-9492's random screen, 6.06 g rms:

    >>> from vrelab.profiles import load_environment
    >>> print(f"{load_environment('navmat-p9492').grms:.2f} g rms")
    6.06 g rms
    """
    known = named_profiles()
    if name not in known:
        raise ValueError(f"unknown {what} name {name!r}; known: {', '.join(known)}")
    path = known[name]
    table = _environment_table(path)
    prof = read_profile(path)
    cited = _citation(table)
    rnd = prof.random if isinstance(prof, SineOnRandom) else prof
    if rnd.name is None or rnd.source is None:
        rnd = RandomProfile(rnd.freq_hz, rnd.psd_g2_per_hz, rnd.name or name, rnd.source or cited)
        prof = SineOnRandom(rnd, prof.tones) if isinstance(prof, SineOnRandom) else rnd
    return Environment(
        name=name,
        title=table.get("title", name),
        source=cited or prof.source or "",
        profile=prof,
        stated_grms=table.get("stated_grms"),
        reproduced_from=table.get("reproduced_from"),
        note=table.get("note"),
    )


def environments() -> list[Environment]:
    """Every named environment (:func:`load_environment`), by name.

    Examples
    --------
    >>> from vrelab.profiles import environments
    >>> [env.name for env in environments()][:3]
    ['adi-flat-50-2000', 'gevs-workmanship', 'mil-std-810h-common-carrier-longitudinal']
    """
    return [load_environment(name) for name in named_profiles()]


_FORMS = (
    "a .csv/.toml file, an inline list F:P,F:P,... (Hz:g²/Hz), flat:F1-F2, "
    "or a named profile ({names}), optionally +sine:F:PEAK,... (Hz:g peak)"
)


def _number_pairs(text: str, what: str, form: str, units: str) -> list[tuple[float, float]]:
    """``A:B,A:B,...`` as number pairs; a bad item is named in the error, e.g.
    ``profile '20:x': item 0 '20:x' is not F:P numbers`` (``what`` = "profile", ``form`` = "F:P")."""
    pairs = []
    for i, token in enumerate(text.split(",")):
        parts = token.strip().split(":")
        if len(parts) != 2:
            raise ValueError(f"{what} {text!r}: item {i} {token.strip()!r} is not {form} ({units})")
        try:
            pairs.append((float(parts[0]), float(parts[1])))
        except ValueError:
            raise ValueError(f"{what} {text!r}: item {i} {token.strip()!r} is not {form} numbers") from None
    return pairs


def _parse_inline(spec: str) -> RandomProfile:
    pairs = _number_pairs(spec, "profile", "F:P", "Hz:g²/Hz")
    try:
        return RandomProfile(np.array([f for f, _ in pairs]), np.array([p for _, p in pairs]), source="inline")
    except ValueError as exc:
        raise ValueError(f"profile {spec!r}: {exc}") from None


def _parse_flat(spec: str) -> RandomProfile:
    body = spec.split(":", 1)[1].strip()
    lo_s, sep, hi_s = body.partition("-")
    try:
        if not sep:
            raise ValueError
        lo, hi = float(lo_s), float(hi_s)
    except ValueError:
        raise ValueError(f"profile {spec!r}: expected flat:F1-F2 (Hz), e.g. flat:50-2000") from None
    try:
        return RandomProfile.flat(lo, hi, name=f"flat-{lo:g}-{hi:g}", source="flat (unit PSD shape)")
    except ValueError as exc:
        raise ValueError(f"profile {spec!r}: {exc}") from None


#: Joins a profile and its sine tones on the command line: ``navmat-p9492+sine:120:0.5,240:0.2``.
TONES_MARK = "+sine:"


def split_tones(spec: str) -> tuple[str, str | None]:
    """(profile part, tone list or None) of a profile string: ``"A+sine:T"`` -> ``("A", "T")``.

    Examples
    --------
    >>> from vrelab.profiles import split_tones
    >>> split_tones("flat:50-2000+sine:120:0.5"), split_tones("flat:50-2000")
    (('flat:50-2000', '120:0.5'), ('flat:50-2000', None))
    """
    i = spec.lower().rfind(TONES_MARK)
    if i < 0:
        return spec, None
    return spec[:i], spec[i + len(TONES_MARK):]


def parse_tones(text: str) -> tuple[Tone, ...]:
    """Tones from ``F:PEAK,F:PEAK,...`` (Hz : g peak), e.g. ``"120:0.5,240:0.2"``.

    Examples
    --------
    >>> from vrelab.profiles import parse_tones
    >>> [(t.freq_hz, t.peak_g) for t in parse_tones("120:0.5,240:0.2")]
    [(120.0, 0.5), (240.0, 0.2)]
    """
    if not text.strip():
        raise ValueError("sine tones: give F:PEAK pairs after '+sine:' (Hz:g peak), e.g. +sine:120:0.5,240:0.2")
    check_tone_count(text.count(",") + 1)
    return tuple(Tone(f, peak) for f, peak in _number_pairs(text, "sine tones", "F:PEAK", "Hz:g peak"))


def with_tones(profile: Profile, tones: Sequence[Tone]) -> SineOnRandom:
    """``profile`` with ``tones`` added (to those it already has).

    Examples
    --------
    >>> from vrelab import RandomProfile
    >>> from vrelab.profiles import Tone, with_tones
    >>> profile = with_tones(RandomProfile.flat(50.0, 2000.0).scaled_to(1.0), [Tone(120.0, 0.5)])
    >>> print(f"{profile.grms:.4f} g rms")
    1.0607 g rms
    """
    if isinstance(profile, SineOnRandom):
        return SineOnRandom(profile.random, profile.tones + tuple(tones), profile.name, profile.source)
    return SineOnRandom(profile, tuple(tones))


def parse_profile(spec: str) -> Profile:
    """A vibration profile from a command-line string (the CLI reference and the environments page).

    Accepted forms, tried in this order: a named profile (``navmat-p9492``), a file path
    (``.csv``/``.toml``; a TOML file with ``[[tone]]`` tables is sine-on-random),
    ``flat:F1-F2`` (a flat 1 g²/Hz shape, to be scaled to a grms), and an inline breakpoint list
    ``F:P,F:P,...`` (Hz:g²/Hz). Any of them followed by ``+sine:F:PEAK,F:PEAK,...`` (Hz : g
    peak) adds sine tones: a :class:`SineOnRandom`.

    Examples
    --------
    A flat random profile of 50-2000 Hz (its level is set where it is used), and a sine-on-random:

    >>> import vrelab
    >>> profile = vrelab.parse_profile("flat:50-2000")
    >>> print(type(profile).__name__, profile.freq_hz.min(), profile.freq_hz.max())
    RandomProfile 50.0 2000.0
    >>> print(type(vrelab.parse_profile("flat:50-2000+sine:120:0.5")).__name__)
    SineOnRandom
    """
    if not isinstance(spec, str) or not spec.strip():
        raise ValueError(f"profile must be {_FORMS.format(names=', '.join(named_profiles()))}; got {spec!r}")
    text = spec.strip()
    base, tones = split_tones(text)
    if tones is not None:
        if not base.strip():
            raise ValueError(f"profile {spec!r}: give a random profile before '+sine:', e.g. navmat-p9492+sine:120:0.5")
        try:
            return with_tones(parse_profile(base), parse_tones(tones))
        except ValueError as exc:
            msg = str(exc)
            raise ValueError(msg if spec in msg else f"profile {spec!r}: {msg}") from None
    names = named_profiles()
    if text in names:
        return load_named_profile(text)
    if Path(text).suffix.lower() in (".csv", ".toml") or Path(text).is_file():
        return read_profile(text)
    if text.lower().startswith("flat:"):
        return _parse_flat(text)
    if ":" in text:
        return _parse_inline(text)
    raise ValueError(f"unknown profile {spec!r}: give {_FORMS.format(names=', '.join(names))}")
