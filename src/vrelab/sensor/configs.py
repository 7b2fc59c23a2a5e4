"""The sensor's stage configurations: each declares its own fields and builds its runtime stages.

A :class:`~vrelab.sensor.loader.Sensor` is an ordered tuple of stage configurations (plus its
identity: name, range, axis, ODR, facts, covariance, uncertainty). Each configuration is a frozen
dataclass whose attributes are its rows of the field table: ``row(Field(...))`` gives an
attribute its file key, unit (in the key), kind, bounds and why, default, default fact and what
vrelab may do with it (identify, fit, sweep, assume a u; :class:`Field`). The field table
:data:`vrelab.sensor.fields.FIELDS` is the concatenation of the rows of
:data:`vrelab.sensor.fields.STAGES`, in stage order; the loader, the writer, the parameter lists,
the sweep lists and the presets' README block are views of it.

Each configuration turns itself into runtime stages (:mod:`vrelab.sensor.stages`) with
:meth:`StageConfig.build`; :meth:`Sensor.stages` walks the tuple in order (order is data)::

    Mount (MountTransmissibility) -> Mechanics (Resonator) -> Sense (Polynomial; three axes into one in the triaxial chain)
    -> Protection (OverRange) -> ProofMassClip (Clip at the proof mass) -> NoiseFloor (Noise)
    -> AntiAliasFilter (AntiAlias) -> OutputFilter (LowPass, AnalogLowPass without an ODR)
    -> HighPassFilter (HighPass) -> Bias (Offset, Drift) -> Sampling (Decimate to the ODR)
    -> Rails (Clip at the output) -> Resolution (Quantize)

A new parameter is one ``row`` on its stage; a new stage is one frozen subclass of
:class:`StageConfig` and one entry in :data:`vrelab.sensor.fields.STAGES`
(:func:`vrelab.sensor.fields.register_stage`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal, TypedDict, TypeGuard, Unpack

import numpy as np

from vrelab._format import field_label
from vrelab.units import UG_PER_G

if TYPE_CHECKING:
    from vrelab.sensor.base import Stage
    from vrelab.sensor.loader import Sensor

# a real number as a file or an attribute gives it (numpy's own included; a bool is none: is_number)
Real = float | np.integer[Any] | np.floating[Any]
Kind = Literal["positive", "finite", "non_negative", "order", "bool", "choice", "rails"]


@dataclass(frozen=True)
class Field:
    """One sensor parameter.

    Examples
    --------
    >>> from vrelab.sensor.configs import Mechanics
    >>> field = Mechanics.rows()[0]
    >>> print(field.key, "|", field.name, "|", field.kind)
    fn_hz | fn_hz | positive
    """

    key: str  # TOML key (in the file's units)
    name: str  # Sensor attribute (g, Hz, s; nonlinearity in 1/g^(n-1))
    kind: Kind
    default: Any  # when a file leaves it out (None: the element is absent)
    doc: str
    scale: float = 1.0  # attribute = file value / scale (µg/g² -> 1/g: 1e6)
    choices: tuple[str, ...] = ()
    upper: float | None = None  # largest allowed value, in the file's units
    why_upper: str = ""  # and why
    lower: float | None = None  # smallest allowed value, in the file's units (beyond the kind's own)
    why_lower: str = ""  # and why
    needs: str = ""  # the attribute without which this one has no effect ("": acts alone)
    identifiable: bool = False  # a campaign can estimate it (a covariance may name it)
    fitted: bool = False  # vrelab identify fits it (identifiable rows only)
    sweepable: bool = False  # a sweep's predict/simulate point may set it
    assumable: bool = False  # a file's [uncertainty] may give it an assumed standard u
    default_fact: str = ""  # the facts text of the default value ("": a file must mark it)
    elements: tuple[str, ...] = ()  # a rails pair's parameter names (low, high)

    @property
    def parameters(self) -> tuple[str, ...]:
        """The parameter names of this row: its key, or one per element of a rails pair."""
        return self.elements or (self.key,)

    @property
    def text_unit(self) -> str:
        """The unit a person reads, from the key's suffix (``µg/g²``; "" for a pure number)."""
        return field_label(self.key)[1] or ""

    @property
    def unit(self) -> str:
        """The unit in ASCII, as ``vrelab identify``'s JSON writes it (``ug/g^2``; ``1`` for a pure number)."""
        text = self.text_unit
        for a, b in (("µ", "u"), ("²", "^2"), ("³", "^3"), ("⁴", "^4"), ("√", "sqrt"), ("°", "deg")):
            text = text.replace(a, b)
        return text or "1"

    def parse(self, raw: object, where: str) -> Any:
        """A file's value as the attribute's value, or ``ValueError`` naming ``where`` and the key."""
        if self.kind == "bool":
            if not isinstance(raw, bool):
                raise ValueError(f"sensor {where}: {self.key} must be true or false, got {raw!r}")
            return raw
        if self.kind == "choice":
            if raw not in self.choices:
                raise ValueError(f"sensor {where}: {self.key} must be one of {', '.join(self.choices)}; got {raw!r}")
            return raw
        if self.kind == "rails":
            if not isinstance(raw, list) or len(raw) != 2:
                raise ValueError(f"sensor {where}: {self.key} must be [low, high], got {raw!r}")
            return tuple(_number(r, self.key, where) for r in raw)
        if self.kind == "order":
            if not isinstance(raw, int) or isinstance(raw, bool):
                raise ValueError(f"sensor {where}: {self.key} must be an integer, got {raw!r}")
            return raw
        return _number(raw, self.key, where) / self.scale

    def check(self, value: object, sensor: str) -> None:
        """Validate an attribute value (``None`` allowed where the default is None)."""
        if value is None and self.default is None:
            return
        bad = f"sensor {sensor}: {self.name}"
        if self.kind == "bool":
            if not isinstance(value, (bool, np.bool_)):
                raise ValueError(f"{bad} must be true or false, got {value!r}")
            return
        if self.kind == "choice":
            if value not in self.choices:
                raise ValueError(f"{bad} must be one of {', '.join(self.choices)}; got {value!r}")
            return
        if self.kind == "rails":
            rails = tuple(value) if isinstance(value, (tuple, list)) else ()
            if len(rails) != 2 or not all(is_number(r) and math.isfinite(r) for r in rails) or not rails[0] < rails[1]:
                raise ValueError(f"{bad} must be [low, high] with low < high, got {value!r}")
            for r in rails:
                self._check_bounds(r, sensor)
            return
        if self.kind == "order":
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"{bad} must be an integer >= 1, got {value!r}")
        elif not is_number(value) or not math.isfinite(value):
            raise ValueError(f"{bad} must be a {'number > 0' if self.kind == 'positive' else 'finite number'}, got {value!r}")
        elif self.kind == "positive" and value <= 0:
            raise ValueError(f"{bad} must be a number > 0, got {value!r}")
        elif self.kind == "non_negative" and value < 0:
            raise ValueError(f"{bad} must be >= 0, got {value!r}")
        self._check_bounds(value, sensor)

    def _check_bounds(self, value: Real, sensor: str) -> None:
        """The row's physical bounds (``lower``, ``upper``, in the file's units), naming the file key."""
        v = float(value) * self.scale
        # the unit's text only for the message: every sensor a propagation perturbs is checked here
        if self.upper is not None and v > self.upper:
            raise ValueError(f"sensor {sensor}: {self.key} must be at most {self.upper:g} ({self.why_upper}), "
                             f"got {v:g}{self._unit_suffix}")
        if self.lower is not None and v < self.lower:
            raise ValueError(f"sensor {sensor}: {self.key} must be at least {self.lower:g} ({self.why_lower}), "
                             f"got {v:g}{self._unit_suffix}")

    @property
    def _unit_suffix(self) -> str:
        return f" {self.text_unit}" if self.text_unit else ""

    def span(self) -> float:
        """The width of the row's physical bounds in the file's units (inf where one is open): a
        standard uncertainty wider than this is outside any physical bound (:func:`check_u`)."""
        lower = self.lower if self.lower is not None else (0.0 if self.kind in ("positive", "non_negative") else None)
        if self.upper is None or lower is None:
            return math.inf
        return self.upper - lower


def is_number(v: object) -> TypeGuard[Real]:
    """A real number (an int, a float or a numpy one; a bool is no number here)."""
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)


def _number(value: object, key: str, where: str) -> float:
    if not is_number(value):
        raise ValueError(f"sensor {where}: {key} must be a number, got {value!r}")
    return float(value)


# Default facts and bounds several rows share.
_ZERO = "assumption: 0 (not a datasheet value)"
_NO_CROSS_AXIS = "assumption: 0 (the axis feels only its own axis; no cross-axis sensitivity modelled)"
_NO_COUPLING = "assumption: 0 (no IEEE 1293 cross-coupling; not a datasheet value)"
# A cross-axis sensitivity [g/g], either sign: one bound, one owner (the rows of Sense).
_MAX_CROSS = 0.5
_WHY_CROSS = "a sensitivity to another axis above half the own one is no accelerometer axis"
_WHY_ORDER = "higher orders are no part's filter and lose precision as second-order sections"
# Physical bounds (file units), each with its reason: a value beyond them is a slip (a unit, an
# exponent), and the closed forms' arithmetic (squares, Hermite moments) overflows long before
# float64 does. An acceleration [g]: ten times the largest vibration or static field vrelab takes
# (vrelab._validate.MAX_ACCELERATION_G, pyroshock's 1e5 g), so a rail or threshold beyond it is
# never reached.
_MAX_G = 1e6
_WHY_G = "ten times the largest acceleration vrelab takes (1e5 g, pyroshock): never reached"
# A nonlinearity coefficient [µg/g^(n-1)]: 1e6 is k_n = 1 g^(1-n), the term as large as the linear
# one at 1 g; the transfer is then not monotonic beyond about ±0.5 g (dy/da = 1 + n·k_n·a^(n-1)
# vanishes), which is no accelerometer's over any range.
_MAX_K = 1e6
_WHY_K = "1e6 is the term as large as the linear one at 1 g: no accelerometer's transfer"
# A frequency [Hz]: the range vrelab's drives take (vrelab._validate.MIN_FREQ_HZ..MAX_FREQ_HZ).
_WHY_FREQ = "beyond any vibration test's frequencies"
# The mount is the user's (the board or bracket the part sits on), not the part's: absent, the
# part sits rigidly on the vibrating structure.
_RIGID = "assumption: no mount, the part rigidly on the vibrating structure (a board or bracket is the user's: mount_fn_hz, mount_q)"
_WHY_HOLD = "an over-range recovery is a circuit's (ADXL355: 0.5 ms); beyond 10 s the part is off, not protected"

# The kinds whose value is a number (or a pair of numbers): every file marks where it comes from.
NUMERIC_KINDS: tuple[Kind, ...] = ("positive", "finite", "non_negative", "order", "rails")


def row(f: Field) -> Any:
    """A stage configuration's attribute declared by its row: the row's default, the row in the
    attribute's metadata (:meth:`StageConfig.rows`).

    Examples
    --------
    A stage configuration of one's own declares each field by its row (a sketch; registering it
    puts it in every sensor, see :func:`vrelab.sensor.fields.register_stage`):

    >>> import dataclasses
    >>> from vrelab.sensor.configs import Field, StageConfig, row
    >>> @dataclasses.dataclass(frozen=True)
    ... class Cable(StageConfig):
    ...     cable_pf: float | None = row(Field("cable_pf", "cable_pf", "positive", None,
    ...                                        "the cable's capacitance [pF]"))
    >>> Cable().cable_pf, [f.key for f in Cable.rows()]
    (None, ['cable_pf'])
    """
    return dataclasses.field(default=f.default, metadata={"row": f})


@dataclass(frozen=True)
class StageConfig:
    """One stage of a sensor description: its fields (:meth:`rows`), their checks across fields
    (:meth:`validate`) and the runtime stages it stands for (:meth:`build`).

    Examples
    --------
    Each stage configuration declares its fields by their rows:

    >>> from vrelab.sensor.configs import Mechanics
    >>> [field.key for field in Mechanics.rows()]
    ['fn_hz', 'q']
    """

    @classmethod
    def rows(cls) -> tuple[Field, ...]:
        """The configuration's rows of the field table, in attribute order (each attribute is its row's name)."""
        out = []
        for a in dataclasses.fields(cls):
            f = a.metadata.get("row")
            if not isinstance(f, Field) or f.name != a.name:
                raise TypeError(f"stage {cls.__name__}: attribute {a.name} must be declared with row(Field(..., "
                                f"{a.name!r}, ...)), got {f!r}")
            out.append(f)
        return tuple(out)

    def resolved(self, sensor: Sensor) -> StageConfig:
        """The configuration with its defaults that depend on the sensor's identity filled in."""
        return self

    def validate(self, sensor: Sensor) -> None:
        """Checks across this stage's fields (each field's own bounds are its row's,
        :meth:`Field.check`); a ``ValueError`` naming the sensor and the fields."""

    def build(self, sensor: Sensor, factor: int) -> tuple[Stage, ...]:
        """The runtime stages (:mod:`vrelab.sensor.stages`) this configuration stands for, at a
        decimation ``factor`` to the ODR (1: rate-free or no ODR); () when it is absent."""
        return ()


# The stage configurations, in the order of the chain (runtime stages are imported where they
# are built: scipy stays out of the modules the CLI loads for every command).

@dataclass(frozen=True)
class Mount(StageConfig):
    """The PCB or bracket between the environment and the part (the article's package and
    mounting resonance): its base-excitation transmissibility at ``mount_fn_hz`` with
    ``mount_q`` on every vibration component (:class:`vrelab.sensor.mount.MountTransmissibility`,
    ``|T|² = (1 + (2ζr)²)/((1 − r²)² + (2ζr)²)``, r = f/fn, ζ = 1/(2Q)). Absent: a rigid mount.

    Examples
    --------
    An ADXL355 on a board at 500 Hz with Q 10, in a 0.2 g rms sine at 500 Hz: the part feels
    the sine ×sqrt(1 + Q²), so its VRE, ``k2·rms²·|H|²`` with the proof mass's H (physics
    §1.2), grows by ``1 + Q²`` = 101:

    >>> import vrelab
    >>> from vrelab.sensor.configs import Mount
    >>> mounted = vrelab.load_sensor("adxl355", range_g=8, axis="z", odr_hz=4000,
    ...                              overrides={"mount_fn_hz": 500.0, "mount_q": 10.0})
    >>> next(c for c in mounted.configs if isinstance(c, Mount))
    Mount(mount_fn_hz=500.0, mount_q=10.0)
    >>> rigid = vrelab.load_sensor("adxl355", range_g=8, axis="z", odr_hz=4000)
    >>> alone, on_board = (vrelab.predict(s, 500.0, [0.2], static_g=1.0).levels[0].vre_g for s in (rigid, mounted))
    >>> print(f"{alone * 1e6:.3f} µg rigid, {on_board * 1e6:.1f} µg mounted: ×{on_board / alone:.1f}")
    0.856 µg rigid, 86.5 µg mounted: ×101.0
    """

    mount_fn_hz: float | None = row(Field(
        "mount_fn_hz", "mount_fn_hz", "positive", None,
        "mount (PCB, bracket) resonance [Hz] (with mount_q; omit both for a rigid mount)",
        lower=1.0, why_lower="below 1 Hz a mount is a suspension, not a mount", upper=1e6,
        why_upper="a resonance above 1 MHz is no board's or bracket's", sweepable=True, assumable=True,
        default_fact=_RIGID))
    mount_q: float | None = row(Field(
        "mount_q", "mount_q", "positive", None, "quality factor of the mount resonance (its transmissibility peak)",
        lower=0.5, why_lower="below Q 0.5 the mount is overdamped: no resonance left to speak of",
        upper=1e3, why_upper="no bolted board or bracket rings that long (Steinberg: Q of PCBs about 10 to 50)",
        sweepable=True, assumable=True, default_fact=_RIGID))

    def validate(self, sensor: Sensor) -> None:
        if (self.mount_fn_hz is None) != (self.mount_q is None):
            raise ValueError(f"sensor {sensor.name}: mount_fn_hz and mount_q must be given together, got "
                             f"mount_fn_hz={self.mount_fn_hz!r}, mount_q={self.mount_q!r}")

    def build(self, sensor: Sensor, factor: int) -> tuple[Stage, ...]:
        from vrelab.sensor.mount import MountTransmissibility

        if self.mount_fn_hz is None or self.mount_q is None:
            return ()
        return (MountTransmissibility(self.mount_fn_hz, self.mount_q),)


@dataclass(frozen=True)
class Mechanics(StageConfig):
    """The proof mass's resonance (physics §1.3): a second-order resonator at ``fn_hz`` with ``q``.

    Examples
    --------
    The ADXL355's proof mass:

    >>> import vrelab
    >>> from vrelab.sensor.configs import Mechanics
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> mechanics = next(c for c in sensor.configs if isinstance(c, Mechanics))
    >>> print(mechanics.fn_hz, mechanics.q)
    2400.0 1.5
    """

    fn_hz: float | None = row(Field(
        "fn_hz", "fn_hz", "positive", None,
        "proof-mass resonance [Hz] (with q; omit both for none)", upper=1e6, lower=0.1,
        why_lower="an accelerometer works below its resonance: a proof mass resonating below 0.1 Hz is a "
        "seismometer's",
        why_upper="a resonance above 1 MHz is beyond any accelerometer's; it would only make the simulation rate run away",
        sweepable=True, identifiable=True, fitted=True, assumable=True))
    q: float | None = row(Field(
        "q", "q", "positive", None, "quality factor of the resonance (the gain at fn_hz)",
        lower=0.01, why_lower="below 0.01 a mass is so overdamped that no resonance is left to speak of",
        upper=1e5, why_upper="vacuum-packaged MEMS resonators reach 1e4 to 1e5; no accelerometer's proof mass beyond",
        sweepable=True, identifiable=True, fitted=True, assumable=True))

    def validate(self, sensor: Sensor) -> None:
        if (self.fn_hz is None) != (self.q is None):
            raise ValueError(f"sensor {sensor.name}: fn_hz and q must be given together, got fn_hz={self.fn_hz!r}, "
                             f"q={self.q!r}")

    def build(self, sensor: Sensor, factor: int) -> tuple[Stage, ...]:
        from vrelab.sensor.stages import Resonator

        return () if self.fn_hz is None or self.q is None else (Resonator(self.fn_hz, self.q),)


def _cross_axis(axis: str) -> Any:
    return row(Field(f"cross_axis_{axis}", f"cross_axis_{axis}", "finite", 0.0,
                     f"cross-axis sensitivity to {axis} [g/g] (0 on the {axis} axis itself)",
                     upper=_MAX_CROSS, why_upper=_WHY_CROSS, lower=-_MAX_CROSS, why_lower=_WHY_CROSS,
                     sweepable=True, assumable=True, default_fact=_NO_CROSS_AXIS))


class _Flags(TypedDict, total=False):
    """A nonlinearity row's flags beyond the defaults (:class:`Field`'s booleans)."""

    identifiable: bool
    fitted: bool
    sweepable: bool
    assumable: bool


def _k(n: int, doc: str, **flags: Unpack[_Flags]) -> Any:
    key = f"k{n}_ug_per_g{n}"
    return row(Field(key, f"k{n}_per_g{n - 1 if n > 2 else ''}", "finite", 0.0, doc, scale=UG_PER_G,
                     default_fact=_ZERO, lower=-_MAX_K, upper=_MAX_K, why_lower=_WHY_K, why_upper=_WHY_K, **flags))


def _coupling(jk: str, doc: str, fitted: bool = True) -> Any:
    return row(Field(f"k{jk}_ug_per_g2", f"k{jk}_per_g", "finite", 0.0, doc,
                     scale=UG_PER_G, lower=-_MAX_K, upper=_MAX_K, why_lower=_WHY_K, why_upper=_WHY_K,
                     identifiable=True, fitted=fitted, sweepable=True, assumable=True, default_fact=_NO_COUPLING))


@dataclass(frozen=True)
class Sense(StageConfig):
    """What the axis senses: three axes into one (physics §1.2, §1.6; IEEE Std 1293-1998's model equation).

    ``u = w · b`` with ``w`` the axis's cross-axis sensitivity row (1 on its own axis), then
    ``y = u + k2·u² + k3·u³ + k4·u⁴ + Kip·b_i·b_p + Kio·b_i·b_o + Kpp·b_p² + Koo·b_o² + Kpo·b_p·b_o``
    on the triad (i, p, o) = (the input axis, ``pendulous_axis``, the third). Along the input
    axis only (the single-axis chain) that is the :class:`~vrelab.sensor.stages.Polynomial` in
    ``u``; :func:`vrelab.triaxial.chain.triaxial_chain` adds the rest. Kip, Kio, Kpp, Koo are
    fitted by ``vrelab identify`` from a campaign's mount-angle runs (IEEE 1293's IP and IO
    planes); Kpo needs a p-o plane mount, which those runs do not excite: identifiable, not fitted.

    Examples
    --------
    The ADXL355's z axis: what it senses, and the stage it builds (the polynomial on the sensed
    acceleration; the preset's k2 of 20 µg/g²):

    >>> import vrelab
    >>> from vrelab.sensor.configs import Sense
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> config = next(c for c in sensor.configs if isinstance(c, Sense))
    >>> config.input_axis, config.k2_per_g
    (None, 2e-05)
    >>> [type(stage).__name__ for stage in config.build(sensor, 16)]
    ['Polynomial']
    """

    input_axis: str | None = row(Field(
        "input_axis", "input_axis", "choice", None,
        "which of the part's x, y, z this axis senses (default: the axis's own name; an identified file "
        "names its axes by campaign channel)", choices=("x", "y", "z")))
    pendulous_axis: str | None = row(Field(
        "pendulous_axis", "pendulous_axis", "choice", None,
        "IEEE 1293 pendulous axis p (default: the next axis, x->y->z->x); o is the third", choices=("x", "y", "z")))
    cross_axis_x: float = _cross_axis("x")
    cross_axis_y: float = _cross_axis("y")
    cross_axis_z: float = _cross_axis("z")
    k2_per_g: float = _k(2, "second-order nonlinearity k2 = K2/K1 [µg/g²] (the VRC)",
                         sweepable=True, identifiable=True, fitted=True, assumable=True)
    k3_per_g2: float = _k(3, "third-order nonlinearity k3 [µg/g³]",
                          sweepable=True, identifiable=True, fitted=True, assumable=True)
    k4_per_g3: float = _k(4, "fourth-order nonlinearity k4 [µg/g⁴]")
    kip_per_g: float = _coupling("ip", "cross-coupling Kip, output per a_i·a_p [µg/g²]")
    kio_per_g: float = _coupling("io", "cross-coupling Kio, output per a_i·a_o [µg/g²]")
    kpp_per_g: float = _coupling("pp", "cross-axis nonlinearity Kpp, output per a_p² [µg/g²]")
    koo_per_g: float = _coupling("oo", "cross-axis nonlinearity Koo, output per a_o² [µg/g²]")
    kpo_per_g: float = _coupling("po", "cross-coupling Kpo, output per a_p·a_o [µg/g²]", fitted=False)
    nonlinearity_pct_fs: float | None = row(Field(
        "nonlinearity_pct_fs", "nonlinearity_pct_fs", "positive", None,
        "datasheet nonlinearity [% of the nominal range]: bounds k2 and k3 where the file gives them no u "
        "(|k2| ≤ 2·NL/FS, |k3| ≤ 4·NL/FS², rectangular; nonlinearity_u)", upper=100.0,
        why_upper="a deviation from the line beyond the full scale itself is no accelerometer's",
        default_fact="assumption: not given (no k2, k3 bound from a datasheet nonlinearity)"))

    def validate(self, sensor: Sensor) -> None:
        own = sensor.sensed_axis
        if own is None:
            return
        mine = getattr(self, f"cross_axis_{own}")
        if mine != 0:
            raise ValueError(f"sensor {sensor.name}: cross_axis_{own} must be 0 on the {own} axis "
                             f"(its own sensitivity is 1 by definition), got {mine!r}")
        if self.pendulous_axis == own:
            raise ValueError(f"sensor {sensor.name}: pendulous_axis must be another axis than the input axis "
                             f"{own}, got {self.pendulous_axis!r}")

    def build(self, sensor: Sensor, factor: int) -> tuple[Stage, ...]:
        from vrelab.sensor.stages import Polynomial

        k = (self.k2_per_g, self.k3_per_g2, self.k4_per_g3)
        return (Polynomial(*k),) if any(k) else ()


def nonlinearity_bounds(pct_fs: float, fs_g: float) -> tuple[float, float]:
    """The largest |k2| [1/g] and |k3| [1/g²] a datasheet nonlinearity of ±``pct_fs`` % of the
    full scale ``fs_g`` [g] allows, each term taken alone.

    Nonlinearity is the largest deviation of the transfer from its best-fit straight line over
    ±FS, in % of FS (the ADXL355 datasheet's "% FS"), i.e. ``NL·FS`` [g] with ``NL = pct_fs/100``.
    The straight line closest in the largest deviation (the minimax, Chebyshev line) to
    ``k2·x²`` on [-FS, FS] is ``k2·FS²/2``: ``x² - FS²/2`` equioscillates at -FS, 0, FS with
    deviation ``FS²/2``; to ``k3·x³`` it is ``(3/4)·k3·FS²·x``: ``x³ - (3/4)FS²·x = FS³·T3(x/FS)/4``
    (Chebyshev's T3) deviates by ``FS³/4``. So ``|k2|·FS²/2 ≤ NL·FS`` and ``|k3|·FS³/4 ≤ NL·FS``:

        |k2| ≤ 2·NL/FS,    |k3| ≤ 4·NL/FS².

    The minimax line is the conservative reading: any other line (a least-squares one, an
    end-point one) deviates more from the same term, so the same NL bounds k2 tighter (a
    least-squares line leaves ``2·k2·FS²/3``: |k2| ≤ 1.5·NL/FS). tests/test_parts_library.py
    holds the bound against a numerical minimax fit (scipy.optimize.linprog)."""
    nl = pct_fs / 100.0
    return 2.0 * nl / fs_g, 4.0 * nl / fs_g**2


def nonlinearity_u(pct_fs: float | None, fs_g: float) -> dict[str, float]:
    """The assumed standard uncertainties of k2 and k3 [µg/g², µg/g³, the file's units] that a
    datasheet nonlinearity implies (:func:`nonlinearity_bounds`), each bound ±a read as
    rectangular (GUM 4.3.7: u = a/√3); {} without a nonlinearity."""
    if pct_fs is None:
        return {}
    k2, k3 = nonlinearity_bounds(pct_fs, fs_g)
    return {"k2_ug_per_g2": k2 * UG_PER_G / math.sqrt(3.0), "k3_ug_per_g3": k3 * UG_PER_G / math.sqrt(3.0)}


_NEEDS_THRESHOLD = "overrange_threshold_g"


@dataclass(frozen=True)
class Protection(StageConfig):
    """The over-range protection on |proof-mass motion| (physics §1.3; the ADXL355's 0.5 ms hold).

    Examples
    --------
    The ADXL355's over-range protection: its threshold, its 0.5 ms hold, and the stage it builds:

    >>> import vrelab
    >>> from vrelab.sensor.configs import Protection
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> config = next(c for c in sensor.configs if isinstance(c, Protection))
    >>> config.overrange_threshold_g, config.overrange_hold_s
    (8.0, 0.0005)
    >>> [type(stage).__name__ for stage in config.build(sensor, 16)]
    ['OverRange']
    """

    overrange_threshold_g: float | None = row(Field(
        "overrange_threshold_g", "overrange_threshold_g", "positive", None,
        "over-range trip level on |proof-mass motion| [g] (omit for none)", upper=_MAX_G, why_upper=_WHY_G,
        identifiable=True, fitted=True, assumable=True))
    overrange_hold_s: float | None = row(Field(
        "overrange_hold_s", "overrange_hold_s", "positive", None, "how long the output is held after a trip [s]",
        upper=10.0, why_upper=_WHY_HOLD, needs=_NEEDS_THRESHOLD, assumable=True))
    overrange_value_g: float = row(Field(
        "overrange_value_g", "overrange_value_g", "finite", 0.0, "what the output reads while held [g]",
        lower=-_MAX_G, upper=_MAX_G, why_lower=_WHY_G, why_upper=_WHY_G, needs=_NEEDS_THRESHOLD,
        default_fact="assumption: 0 g (mid-scale) while held; used only with an over-range threshold"))
    overrange_float_tau_s: float = row(Field(
        "overrange_float_tau_s", "overrange_float_tau_s", "non_negative", 0.0,
        "time constant of the float toward overrange_value_g [s] (0: a jump)", upper=10.0, why_upper=_WHY_HOLD,
        needs=_NEEDS_THRESHOLD, default_fact="assumption: 0 (a jump); used only with an over-range threshold"))
    overrange_retrigger: bool = row(Field(
        "overrange_retrigger", "overrange_retrigger", "bool", True,
        "a hold re-arms while the input stays beyond the threshold", needs=_NEEDS_THRESHOLD))

    def validate(self, sensor: Sensor) -> None:
        if self.overrange_threshold_g is not None and self.overrange_hold_s is None:
            raise ValueError(f"sensor {sensor.name}: overrange_hold_s is required with overrange_threshold_g")

    def build(self, sensor: Sensor, factor: int) -> tuple[Stage, ...]:
        from vrelab.sensor.stages import OverRange

        if self.overrange_threshold_g is None or self.overrange_hold_s is None:
            return ()
        return (OverRange(self.overrange_threshold_g, float(self.overrange_hold_s), self.overrange_value_g,
                          self.overrange_retrigger, self.overrange_float_tau_s),)


@dataclass(frozen=True)
class ProofMassClip(StageConfig):
    """The rails at the proof mass (``clip_position = "proof-mass"``; the rails are :class:`Rails`'s).

    Examples
    --------
    Absent unless the rails sit at the proof mass (``clip_position = "proof-mass"``); the
    ADXL355's are at the output, so it builds no stage:

    >>> import vrelab
    >>> from vrelab.sensor.configs import ProofMassClip
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> config = next(c for c in sensor.configs if isinstance(c, ProofMassClip))
    >>> [type(stage).__name__ for stage in config.build(sensor, 16)]
    []
    """

    def build(self, sensor: Sensor, factor: int) -> tuple[Stage, ...]:
        from vrelab.sensor.stages import Clip

        return (Clip(*sensor.rails_g),) if sensor.clip_position == "proof-mass" else ()


@dataclass(frozen=True)
class NoiseFloor(StageConfig):
    """White noise of the data-sheet density, added before the filters so the output shows it in band.

    Examples
    --------
    The ADXL355's noise density and the stage it builds:

    >>> import vrelab
    >>> from vrelab.sensor.configs import NoiseFloor
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> config = next(c for c in sensor.configs if isinstance(c, NoiseFloor))
    >>> config.noise_ug_per_rthz
    22.5
    >>> [type(stage).__name__ for stage in config.build(sensor, 16)]
    ['Noise']
    """

    noise_ug_per_rthz: float = row(Field(
        "noise_ug_per_rthz", "noise_ug_per_rthz", "non_negative", 0.0, "noise density [µg/√Hz]",
        upper=1e7, why_upper="10 g/√Hz buries any vibration test's signal: no sensor's noise",
        default_fact="assumption: noiseless"))

    def build(self, sensor: Sensor, factor: int) -> tuple[Stage, ...]:
        from vrelab.sensor.stages import Noise

        return (Noise(self.noise_ug_per_rthz),) if self.noise_ug_per_rthz > 0 else ()


@dataclass(frozen=True)
class AntiAliasFilter(StageConfig):
    """The analog anti-alias Butterworth low-pass before the ADC.

    Examples
    --------
    The ADXL355's analog anti-alias filter before its ADC:

    >>> import vrelab
    >>> from vrelab.sensor.configs import AntiAliasFilter
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> config = next(c for c in sensor.configs if isinstance(c, AntiAliasFilter))
    >>> config.anti_alias_hz, config.anti_alias_order
    (1500.0, 2)
    >>> [type(stage).__name__ for stage in config.build(sensor, 16)]
    ['AntiAlias']
    """

    anti_alias_hz: float | None = row(Field(
        "anti_alias_hz", "anti_alias_hz", "positive", None, "analog anti-alias corner [Hz] (omit for none)",
        lower=1e-6, why_lower=_WHY_FREQ, upper=1e7, why_upper=_WHY_FREQ, assumable=True))
    anti_alias_order: int | None = row(Field(
        "anti_alias_order", "anti_alias_order", "order", None,
        "anti-alias Butterworth order (default 2)", upper=12, why_upper=_WHY_ORDER, needs="anti_alias_hz",
        assumable=True))

    def build(self, sensor: Sensor, factor: int) -> tuple[Stage, ...]:
        from vrelab.sensor.stages import AntiAlias

        return () if self.anti_alias_hz is None else (AntiAlias(self.anti_alias_hz, self.anti_alias_order or 2),)


@dataclass(frozen=True)
class OutputFilter(StageConfig):
    """The band-limit at the output (physics §1.3): with an ODR the part's digital low-pass
    (:class:`~vrelab.sensor.stages.LowPass`), without one (an analog part: the ADXL354's overall
    bandwidth) an analog output filter of the same order and family
    (:class:`~vrelab.sensor.stages.AnalogLowPass`). Either way it limits what reaches the output rails.

    Examples
    --------
    The ADXL355's digital low-pass at 4 kHz ODR (corner ODR/4):

    >>> import vrelab
    >>> from vrelab.sensor.configs import OutputFilter
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> config = next(c for c in sensor.configs if isinstance(c, OutputFilter))
    >>> config.bandwidth_hz, config.lowpass_order
    (1000.0, 4)
    >>> [type(stage).__name__ for stage in config.build(sensor, 16)]
    ['LowPass']
    """

    bandwidth_hz: float | None = row(Field(
        "bandwidth_hz", "bandwidth_hz", "positive", None,
        "output low-pass corner [Hz] (or bandwidth_per_odr × ODR): the digital low-pass below ODR/2, or without "
        "an ODR the analog output filter", lower=1e-6, why_lower=_WHY_FREQ, upper=1e7, why_upper=_WHY_FREQ,
        assumable=True))
    lowpass_order: int | None = row(Field(
        "lowpass_order", "lowpass_order", "order", None,
        "output low-pass order (default 4)", upper=12, why_upper=_WHY_ORDER, needs="bandwidth_hz", assumable=True))
    lowpass_kind: Literal["butterworth", "bessel", "sinc"] = row(Field(
        "lowpass_kind", "lowpass_kind", "choice", "butterworth",
        "output low-pass family: butterworth, bessel, or sinc (a sinc^N decimator, N = lowpass_order, default 3; "
        "needs an ODR)", choices=("butterworth", "bessel", "sinc"), needs="bandwidth_hz"))
    lowpass_corner: Literal["-3dB", "-6dB"] = row(Field(
        "lowpass_corner", "lowpass_corner", "choice", "-3dB",
        "the gain bandwidth_hz is given at, as the datasheet states it: -3dB (|H| = 1/√2) or -6dB (|H| = 1/2)",
        choices=("-3dB", "-6dB"), needs="bandwidth_hz"))

    def validate(self, sensor: Sensor) -> None:
        odr, bw = sensor.odr_hz, self.bandwidth_hz
        if bw is None:
            return
        if self.lowpass_kind == "sinc":
            # a sinc decimator's corner may sit at the output's Nyquist (the ADXL380's 4 kHz at 8 kHz):
            # its nulls at the multiples of 1/T, not the corner, keep the aliases out
            if odr is None:
                raise ValueError(f"sensor {sensor.name}: lowpass_kind = sinc is a decimation filter: it needs odrs_hz "
                                 "(an analog part's output filter is butterworth or bessel)")
            if not bw <= odr / 2:
                raise ValueError(f"sensor {sensor.name}: bandwidth_hz must be at most ODR/2 = {odr / 2:g} Hz for a sinc "
                                 f"decimator, got {bw!r}")
        elif odr is not None and not bw < odr / 2:
            raise ValueError(
                f"sensor {sensor.name}: bandwidth_hz must be below ODR/2 = {odr / 2:g} Hz for a {self.lowpass_kind} "
                f"low-pass (lowpass_kind = sinc for a decimator whose corner reaches ODR/2), got {bw!r}")

    def filter(self, corner_hz: float, odr_hz: float | None) -> Stage:
        """The output filter whose gain at ``corner_hz`` [Hz] is the ``lowpass_corner`` convention's:
        digital with an ODR (a sinc^N decimator, :class:`~vrelab.sensor.sinc.SincLowPass`, or
        :class:`~vrelab.sensor.stages.LowPass`), analog without. A -6 dB Butterworth or Bessel
        corner becomes its -3 dB design corner (:func:`vrelab.sensor.sinc.corner_factor`)."""
        from vrelab.sensor.sinc import SincLowPass, corner_factor
        from vrelab.sensor.stages import AnalogLowPass, LowPass

        if self.lowpass_kind == "sinc":
            return SincLowPass(corner_hz, self.lowpass_order or 3, self.lowpass_corner)
        order = self.lowpass_order or 4
        design = corner_hz / corner_factor(self.lowpass_kind, order, self.lowpass_corner)
        if odr_hz is not None:
            return LowPass(design, order, self.lowpass_kind)
        return AnalogLowPass(design, order, self.lowpass_kind)

    def build(self, sensor: Sensor, factor: int) -> tuple[Stage, ...]:
        return () if self.bandwidth_hz is None else (self.filter(self.bandwidth_hz, sensor.odr_hz),)


@dataclass(frozen=True)
class HighPassFilter(StageConfig):
    """A first-order high-pass at the output (an AC-coupled part).

    Examples
    --------
    Off in the ADXL355 (no stage):

    >>> import vrelab
    >>> from vrelab.sensor.configs import HighPassFilter
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> config = next(c for c in sensor.configs if isinstance(c, HighPassFilter))
    >>> config.highpass_hz
    >>> [type(stage).__name__ for stage in config.build(sensor, 16)]
    []
    """

    highpass_hz: float | None = row(Field(
        "highpass_hz", "highpass_hz", "positive", None, "high-pass corner [Hz] (omit: off)",
        lower=1e-6, why_lower=_WHY_FREQ, upper=1e7, why_upper=_WHY_FREQ))

    def build(self, sensor: Sensor, factor: int) -> tuple[Stage, ...]:
        from vrelab.sensor.stages import HighPass

        return () if self.highpass_hz is None else (HighPass(self.highpass_hz),)


@dataclass(frozen=True)
class Bias(StageConfig):
    """The 0 g offset and a slow linear drift (warm-up, temperature), added before the output rails.
    No preset sets a drift: 0 unless a file or ``dataclasses.replace`` sets it.

    Examples
    --------
    The ADXL355 preset's 0 g offset and drift (zero unless set), and the stages they build:

    >>> import vrelab
    >>> from vrelab.sensor.configs import Bias
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> config = next(c for c in sensor.configs if isinstance(c, Bias))
    >>> config.offset_g, config.drift_g_per_s
    (0.0, 0.0)
    >>> [type(stage).__name__ for stage in config.build(sensor, 16)]
    []
    """

    offset_g: float = row(Field(
        "offset_g", "offset_g", "finite", 0.0, "0 g offset [g], added before the output rails", sweepable=True,
        lower=-_MAX_G, upper=_MAX_G, why_lower=_WHY_G, why_upper=_WHY_G,
        default_fact="assumption: 0 g offset 0 (a parameter)"))
    drift_g_per_s: float = row(Field(
        "drift_g_per_s", "drift_g_per_s", "finite", 0.0, "slow linear output drift [g/s]",
        lower=-_MAX_G, upper=_MAX_G, why_lower=_WHY_G + " in a second", why_upper=_WHY_G + " in a second",
        default_fact="assumption: 0 (no bias drift simulated unless set; a parameter)"))

    def build(self, sensor: Sensor, factor: int) -> tuple[Stage, ...]:
        from vrelab.sensor.stages import Drift, Offset

        return (((Offset(self.offset_g),) if self.offset_g else ())
                + ((Drift(self.drift_g_per_s),) if self.drift_g_per_s else ()))


@dataclass(frozen=True)
class Sampling(StageConfig):
    """The decimation from the simulation rate to the ODR (the ODR is the sensor's identity: chosen
    from the file's list when it loads).

    Examples
    --------
    The decimation from the simulation rate to the ADXL355's 4 kHz ODR (16 from 64 kHz):

    >>> import vrelab
    >>> from vrelab.sensor.configs import Sampling
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> config = next(c for c in sensor.configs if isinstance(c, Sampling))
    >>> [type(stage).__name__ for stage in config.build(sensor, 16)]
    ['Decimate']
    """

    def build(self, sensor: Sensor, factor: int) -> tuple[Stage, ...]:
        from vrelab.sensor.stages import Decimate

        return (Decimate(factor),) if factor > 1 else ()


@dataclass(frozen=True)
class Rails(StageConfig):
    """The digital full scale and the rails: at the output (after the low-pass, which is why a
    narrower bandwidth rectifies less) or at the proof mass (:class:`ProofMassClip`).

    Examples
    --------
    The ADXL355's ±2 g range: its digital full scale (2.048 g) and where the rails are:

    >>> import vrelab
    >>> from vrelab.sensor.configs import Rails
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> config = next(c for c in sensor.configs if isinstance(c, Rails))
    >>> config.full_scale_g, config.clip_position
    (2.048, 'output')
    >>> [type(stage).__name__ for stage in config.build(sensor, 16)]
    ['Clip']
    """

    # full_scale_g and rails_g are None only until the Sensor resolves them (resolved): a Sensor's
    # are numbers
    full_scale_g: float = row(Field(
        "full_scale_g", "full_scale_g", "positive", None, "digital full scale [g] (default: the nominal range)",
        upper=_MAX_G, why_upper=_WHY_G))
    rails_g: tuple[float, float] = row(Field(
        "rails_g", "rails_g", "rails", None, "[low, high] clip levels [g] (default ±full_scale_g)",
        elements=("rail_low_g", "rail_high_g"), lower=-_MAX_G, upper=_MAX_G, why_lower=_WHY_G, why_upper=_WHY_G,
        identifiable=True, fitted=True, assumable=True))
    clip_position: Literal["output", "proof-mass"] = row(Field(
        "clip_position", "clip_position", "choice", "output",
        "where the rails sit: output (after the low-pass) or proof-mass", choices=("output", "proof-mass")))

    def resolved(self, sensor: Sensor) -> Rails:
        """The full scale defaults to the nominal range, the rails to ±full scale (floats)."""
        fs = sensor.range_g if self.full_scale_g is None else self.full_scale_g
        rails = self.rails_g
        if rails is None and is_number(fs):
            rails = (-float(fs), float(fs))
        if isinstance(rails, (tuple, list)) and len(rails) == 2 and all(is_number(r) for r in rails):
            rails = (float(rails[0]), float(rails[1]))
        return dataclasses.replace(self, full_scale_g=fs, rails_g=rails)

    def build(self, sensor: Sensor, factor: int) -> tuple[Stage, ...]:
        from vrelab.sensor.stages import Clip

        if self.clip_position != "output" or self.rails_g is None:
            return ()
        return (Clip(*self.rails_g),)


@dataclass(frozen=True)
class Resolution(StageConfig):
    """Rounding to the output's LSB.

    Examples
    --------
    The ADXL355's LSB at ±2 g (1/256000 g):

    >>> import vrelab
    >>> from vrelab.sensor.configs import Resolution
    >>> sensor = vrelab.load_sensor("adxl355", range_g=2, axis="z", odr_hz=4000)
    >>> config = next(c for c in sensor.configs if isinstance(c, Resolution))
    >>> config.lsb_g
    3.90625e-06
    >>> [type(stage).__name__ for stage in config.build(sensor, 16)]
    ['Quantize']
    """

    lsb_g: float | None = row(Field(
        "lsb_g", "lsb_g", "positive", None, "output resolution [g] (omit for none)", upper=_MAX_G, why_upper=_WHY_G))

    def build(self, sensor: Sensor, factor: int) -> tuple[Stage, ...]:
        from vrelab.sensor.stages import Quantize

        return () if self.lsb_g is None else (Quantize(self.lsb_g),)


# The stages of every sensor description, in chain order (vrelab.sensor.fields.STAGES starts as this).
DEFAULT_STAGES: tuple[type[StageConfig], ...] = (
    Mount, Mechanics, Sense, Protection, ProofMassClip, NoiseFloor, AntiAliasFilter, OutputFilter, HighPassFilter, Bias,
    Sampling, Rails, Resolution,
)
