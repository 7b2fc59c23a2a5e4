"""What a user sets for a reduction, its fits and its uncertainty budget (physics §4, §4.3).

Three frozen dataclasses, each checked once when it is made (a bad value: ``ValueError`` with
the words ``vrelab analyze`` prints for it):

* :class:`ReductionOptions`: how a record becomes VRE per level (band, settling trim, rail,
  profile, the physics §4.2 checks accepted on purpose, block size, progress, PSDs);
* :class:`FitOptions`: how the levels are fitted (static field, clipping model, k4, joint rail);
* :class:`BudgetOptions`: the Type B terms and the decision limit of physics §4.3.

The functions of :mod:`vrelab.analysis` take them as ``options=``, ``fit=`` and ``budget=``.
Their former flat keywords (``band_hz=``, ``static_g=``, ``typeb=``, ...) still work for one
release through :func:`from_keywords`, with a ``DeprecationWarning``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, fields, replace
from typing import TYPE_CHECKING, Any, Iterable, Mapping

from vrelab import _validate as V
from vrelab.models.kinds import DEFAULT_CLIP_KIND, KINDS
from vrelab.models.kinds import Kind as ClipKind
from vrelab.record import DEFAULT_SETTLE_S

if TYPE_CHECKING:
    from vrelab.gum import TypeB
    from vrelab.profiles import Profile

DEFAULT_BAND_HZ = (50.0, 2000.0)
# Samples per block read from a record: memory is bounded by it (2 MiB per float64 channel).
DEFAULT_BLOCK = 1 << 18
# Checks of physics §4.2 a user may accept on purpose (``accept=``; CLI ``--accept-<name>``).
ACCEPTABLE = ("unit-ratio", "channels", "method")


def check_band(band_hz: tuple[float, float]) -> tuple[float, float]:
    """A test band (f1, f2) in Hz with 0 < f1 < f2, both finite."""
    f1, f2 = (float(x) for x in band_hz)
    if not (0 < f1 < f2) or not (math.isfinite(f1) and math.isfinite(f2)):
        raise ValueError(f"band_hz must be F1:F2 with 0 < F1 < F2, got {f1:g}:{f2:g}")
    return f1, f2


def default_band(fs_hz: float, band_hz: tuple[float, float] | None = None, profile: Any = None) -> tuple[float, float]:
    """The test band: given, else the profile's band, else 50–2000 Hz; clamped to Nyquist."""
    if band_hz is None:
        band_hz = tuple(profile.band) if profile is not None and hasattr(profile, "band") else DEFAULT_BAND_HZ
    f1, f2 = check_band(band_hz)
    nyq = fs_hz / 2
    if f1 >= nyq:
        raise ValueError(f"band_hz lower edge {f1:g} Hz is not below Nyquist ({nyq:g} Hz at fs {fs_hz:g} Hz)")
    return f1, min(f2, nyq)


@dataclass(frozen=True)
class ReductionOptions:
    """How a record is reduced to VRE per level (physics §4).

    Attributes
    ----------
    band_hz : (f1, f2) or None
        Test band [Hz] of the random method's level (the reference's rms in it). None: the
        profile's band, else 50–2000 Hz; clamped to Nyquist when the record's rate is known.
    settle_s : float
        Settling time trimmed at both edges of every segment [s] (``--settle``).
    rail_g : float or None
        DUT samples at or beyond ±rail_g count as saturated, besides the rails found from the
        data (``--rail``).
    profile : RandomProfile or SineOnRandom, optional
        The random profile the test ran: the default band, and each random level's reference
        PSD is checked against its tolerance (physics §3).
    accept : frozenset of str
        physics §4.2 checks passed on purpose: a subset of :data:`ACCEPTABLE`.
    block_size : int
        Samples per block read from the record; memory is bounded by it.
    progress : bool
        A progress bar on stderr over the first pass.
    psd : bool
        Keep each random level's reference PSD (for the CLI's ``psd_levels.csv``).

    Examples
    --------
    The reduction's choices, here a band and a longer settling trim (the defaults otherwise):

    >>> from vrelab.analysis import ReductionOptions
    >>> options = ReductionOptions(band_hz=(20.0, 2000.0), settle_s=1.0)
    >>> options.band_hz, options.settle_s, options.rail_g
    ((20.0, 2000.0), 1.0, None)
    """

    band_hz: tuple[float, float] | None = None
    settle_s: float = DEFAULT_SETTLE_S
    rail_g: float | None = None
    profile: Profile | None = None
    accept: frozenset[str] = frozenset()
    block_size: int = DEFAULT_BLOCK
    progress: bool = False
    psd: bool = False

    def __post_init__(self) -> None:
        if self.band_hz is not None:
            object.__setattr__(self, "band_hz", check_band(self.band_hz))
        settle = float(self.settle_s) if _is_number(self.settle_s) else math.nan
        if not (math.isfinite(settle) and settle >= 0):
            raise ValueError(f"settle_s must be >= 0, got {settle if _is_number(self.settle_s) else self.settle_s!r}")
        object.__setattr__(self, "settle_s", settle)
        if self.rail_g is not None:
            object.__setattr__(self, "rail_g", V.positive_scalar("rail_g", self.rail_g))
        accept = frozenset([self.accept] if isinstance(self.accept, str) else self.accept)
        unknown = accept - set(ACCEPTABLE)
        if unknown:
            raise ValueError(f"accept: unknown check {sorted(unknown)[0]!r}; one of {', '.join(ACCEPTABLE)}")
        object.__setattr__(self, "accept", accept)
        block = int(self.block_size)
        if block < 1:
            raise ValueError(f"block_size must be >= 1, got {block}")
        object.__setattr__(self, "block_size", block)
        object.__setattr__(self, "progress", bool(self.progress))
        object.__setattr__(self, "psd", bool(self.psd))


@dataclass(frozen=True)
class FitOptions:
    """How the levels are fitted (:func:`vrelab.fits.fit_levels`).

    Attributes
    ----------
    static_g : float or None
        Static field along the DUT axis [g] for the rail fit (``--static``). None: the DUT's
        mean reading at the baselines.
    clip_kind : {"censored", "truncated"}
        Clipping model of the rail fit (``--kind``).
    k4 : bool
        Add a rms⁴ term to the VRC fit (``--k4``).
    rail_with_vrc : bool
        Fit the rail jointly with a VRC·rms² term (``--rail-vrc``; :func:`vrelab.fits.fit_rail`).

    Examples
    --------
    The static field the run was at (axis up, +1 g) and the clipping model to fit:

    >>> from vrelab.analysis import FitOptions
    >>> fit = FitOptions(static_g=1.0, clip_kind="censored")
    >>> fit.static_g, fit.k4
    (1.0, False)
    """

    static_g: float | None = None
    clip_kind: ClipKind = DEFAULT_CLIP_KIND
    k4: bool = False
    rail_with_vrc: bool = False

    def __post_init__(self) -> None:
        if self.static_g is not None:
            object.__setattr__(self, "static_g", V.finite_scalar("static_g", self.static_g))
        V.one_of("clip_kind", self.clip_kind, KINDS)
        object.__setattr__(self, "k4", bool(self.k4))
        object.__setattr__(self, "rail_with_vrc", bool(self.rail_with_vrc))


@dataclass(frozen=True)
class BudgetOptions:
    """The GUM budget of physics §4.3.

    Attributes
    ----------
    typeb : vrelab.gum.TypeB or None
        Type B inputs (reference and DUT sensitivity, static field, thermal offset): added to
        every level's and fitted parameter's uncertainty, with ``U_vre_g`` and ``k``.
    limit_g : float or None
        A VRE limit [g] (``--limit``): each level gets a guarded-acceptance decision.

    With neither, no budget is made (:attr:`wanted` is False).

    Examples
    --------
    The Type B inputs and a VRE limit for the decisions:

    >>> from vrelab import TypeB
    >>> from vrelab.analysis import BudgetOptions
    >>> budget = BudgetOptions(typeb=TypeB(u_reference_pct=1.0), limit_g=0.005)
    >>> budget.limit_g, budget.typeb.u_reference_pct
    (0.005, 1.0)
    """

    typeb: TypeB | None = None
    limit_g: float | None = None

    def __post_init__(self) -> None:
        if self.limit_g is not None:
            object.__setattr__(self, "limit_g", V.positive_scalar("limit_g", self.limit_g))

    @property
    def wanted(self) -> bool:
        return self.typeb is not None or self.limit_g is not None


def _is_number(x: Any) -> bool:
    try:
        float(x)
    except (TypeError, ValueError):
        return False
    return True


# The former flat keywords of reduce / analyze / analyze_channels -> (which options, its field).
# a former flat keyword whose field has another name
RENAMED_KEYWORDS = {"fit_k4": "k4"}


def check_keywords(where: str, keywords: Iterable[str]) -> None:
    """A former flat keyword that names no field of the three options is a ``TypeError``, as for
    any function (:func:`from_keywords`; ``vrelab.analyze`` asks before it opens a file)."""
    known = {f.name for cls in (ReductionOptions, FitOptions, BudgetOptions) for f in fields(cls)}
    for key in keywords:
        if RENAMED_KEYWORDS.get(key, key) not in known:
            raise TypeError(f"{where}() got an unexpected keyword argument {key!r}")


def from_keywords(
    where: str,
    keywords: Mapping[str, Any],
    options: ReductionOptions | None = None,
    fit: FitOptions | None = None,
    budget: BudgetOptions | None = None,
) -> tuple[ReductionOptions, FitOptions, BudgetOptions]:
    """The three options with the former flat keywords of ``where`` applied (deprecated: one
    ``DeprecationWarning`` per call that uses them); an unknown keyword is a ``TypeError`` as
    for any function."""
    options = options if options is not None else ReductionOptions()
    fit = fit if fit is not None else FitOptions()
    budget = budget if budget is not None else BudgetOptions()
    if not keywords:
        return options, fit, budget
    check_keywords(where, keywords)
    groups: list[tuple[Any, dict[str, Any]]] = [(options, {}), (fit, {}), (budget, {})]
    for key, value in keywords.items():
        name = RENAMED_KEYWORDS.get(key, key)
        obj, changes = next(g for g in groups if name in {f.name for f in fields(g[0])})
        changes[name] = frozenset(value) if name == "accept" else value
    warnings.warn(
        f"{where}(): the keywords {', '.join(sorted(keywords))} are deprecated and will be removed in the next "
        "release; pass options=ReductionOptions(...), fit=FitOptions(...), budget=BudgetOptions(...) "
        "(vrelab.analysis.options)",
        DeprecationWarning,
        stacklevel=3,
    )
    out = [replace(obj, **changes) if changes else obj for obj, changes in groups]
    return out[0], out[1], out[2]


__all__ = [
    "ACCEPTABLE",
    "DEFAULT_BAND_HZ",
    "DEFAULT_BLOCK",
    "BudgetOptions",
    "FitOptions",
    "ReductionOptions",
    "check_band",
    "check_keywords",
    "default_band",
    "from_keywords",
]
