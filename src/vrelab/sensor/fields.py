"""The one table of sensor fields: TOML parsing, validation, the ``Sensor``, the parameters and the schema docs.

Each row says how a value is written in a sensor file (its key, in the file's units), what the
:class:`~vrelab.sensor.loader.Sensor` holds (its attribute, in g and Hz), what is allowed, its
default when a file leaves it out, what it means, and what the rest of vrelab may do with it:

* ``identifiable``: a campaign can estimate it; it has a parameter name (the file key; a rails
  pair has one per element, ``elements``) that an identified file's covariance, ``vrelab
  identify``'s JSON and :func:`vrelab.sensor.parameters.with_parameters` use. ``fitted``: of
  those, the ones ``vrelab identify`` fits today (:data:`vrelab.sensor.parameters.PARAMETERS`).
* ``sweepable``: a sweep's ``predict``/``simulate`` point may set it (``[grid]``, ``[fixed]``,
  ``[montecarlo]``, by its file key; :func:`sweepable`).
* ``assumable``: a sensor file's ``[uncertainty]`` table may give it an assumed standard
  uncertainty (:data:`vrelab.sensor.parameters.ASSUMABLE`).
* ``default_fact``: the ``facts`` text of the value when a file leaves it at its default (a
  preset then need not repeat it).

The loader parses and checks a file by this table, ``Sensor`` validates itself by it,
:mod:`vrelab.sensor.parameters`, the sweep's parameter lists and the sensor-file writer
(:mod:`vrelab.sensor.writer`) are views of it, and ``presets/README`` documents every row (a
test holds the README to :func:`schema_text`; :func:`update_readme` rewrites that block:
``python -c "from vrelab.sensor.fields import update_readme; update_readme()"``). A new sensor
parameter is one ``row`` on its stage configuration (:mod:`vrelab.sensor.configs`: the rows live
on the stages; :data:`FIELDS` is their concatenation in stage order, :data:`STAGES`), and its
closed form in :mod:`vrelab.predict` where it has one.
"""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path
from typing import Any, Iterable, Iterator, Mapping

# (Field, Kind, is_number and NUMERIC_KINDS live with the stages' rows; imported from here as before)
from vrelab.sensor.configs import DEFAULT_STAGES, StageConfig
from vrelab.sensor.configs import NUMERIC_KINDS as NUMERIC_KINDS
from vrelab.sensor.configs import Field as Field
from vrelab.sensor.configs import Kind as Kind
from vrelab.sensor.configs import is_number as is_number

# The stage configurations of a sensor, in chain order: the one place the order lives
# (Sensor.stages walks it; register_stage adds one).
STAGES: tuple[type[StageConfig], ...] = DEFAULT_STAGES


def rows_of(stages: Iterable[type[StageConfig]]) -> tuple[Field, ...]:
    """The field table of ``stages``: their rows, concatenated in stage order (a key or an
    attribute declared twice raises)."""
    out = tuple(f for s in stages for f in s.rows())
    for what in ("key", "name"):
        seen = [getattr(f, what) for f in out]
        twice = sorted({k for k in seen if seen.count(k) > 1})
        if twice:
            raise ValueError(f"sensor stages declare the field {what} {', '.join(twice)} twice")
    return out


# The field table: every stage's rows, in stage order (a test may patch it; the views below read
# it at call time).
FIELDS: tuple[Field, ...] = rows_of(STAGES)


def register_stage(stage: type[StageConfig], after: type[StageConfig] | None = None) -> None:
    """Add a stage configuration to :data:`STAGES` (after ``after``; at the end when None) and its
    rows to :data:`FIELDS`: the loader, the writer, the parameter lists, the sweep lists and
    :func:`schema_text` then know its fields, and every Sensor built after this has the stage.

    Examples
    --------
    See :func:`stage_registered` for a stage registered for a ``with`` block only (how a test
    adds one); the stages in order:

    >>> from vrelab.sensor import fields
    >>> [stage.__name__ for stage in fields.STAGES][:4]
    ['Mount', 'Mechanics', 'Sense', 'Protection']
    """
    global STAGES, FIELDS
    order = list(STAGES)
    if stage in order:
        raise ValueError(f"stage {stage.__name__} is registered already")
    if after is not None and after not in order:
        raise ValueError(f"stage {after.__name__} is not registered; registered: {', '.join(s.__name__ for s in order)}")
    order.insert(len(order) if after is None else order.index(after) + 1, stage)
    rows = rows_of(order)  # checks the new rows against the others before anything changes
    STAGES, FIELDS = tuple(order), rows


@contextmanager
def stage_registered(stage: type[StageConfig], after: type[StageConfig] | None = None) -> Iterator[None]:
    """:func:`register_stage` for the ``with`` block only (a test's fixture stage).

    Examples
    --------
    A stage of one's own, in every sensor for the ``with`` block only:

    >>> import dataclasses
    >>> import vrelab
    >>> from vrelab.sensor.configs import Field, Mechanics, StageConfig, row
    >>> from vrelab.sensor import fields
    >>> @dataclasses.dataclass(frozen=True)
    ... class Cable(StageConfig):
    ...     cable_pf: float | None = row(Field("cable_pf", "cable_pf", "positive", None,
    ...                                        "the cable's capacitance [pF]"))
    >>> with fields.stage_registered(Cable, after=Mechanics):
    ...     print([stage.__name__ for stage in fields.STAGES][:3])
    ['Mount', 'Mechanics', 'Cable']
    >>> Cable in fields.STAGES
    False
    """
    global STAGES, FIELDS
    before = STAGES, FIELDS
    register_stage(stage, after)
    try:
        yield
    finally:
        STAGES, FIELDS = before


# Views of the table, read at call time (so a row added to FIELDS, even patched in by a test,
# reaches every user without a second list to keep in step).

def by_key() -> dict[str, Field]:
    """The rows by file key."""
    return {f.key: f for f in FIELDS}


def by_name() -> dict[str, Field]:
    """The rows by ``Sensor`` attribute."""
    return {f.name: f for f in FIELDS}


def numeric() -> tuple[str, ...]:
    """The ``Sensor`` attributes of the numeric rows (each one a file marks in ``facts``)."""
    return tuple(f.name for f in FIELDS if f.kind in NUMERIC_KINDS)


def sweepable() -> tuple[Field, ...]:
    """The rows a sweep's predict/simulate point may set, by file key."""
    return tuple(f for f in FIELDS if f.sweepable)


def idle(values: Mapping[str, Any], given: Iterable[str]) -> list[Field]:
    """The rows among ``given`` (attribute names a file or a user set) that have no effect given
    the others: their ``needs`` attribute is absent (None) in ``values`` (the resolved attributes).
    A sensor file means what it says: the loader refuses each, naming it."""
    chosen = set(given)
    return [f for f in FIELDS if f.needs and f.name in chosen and values.get(f.needs) is None]


def _flags(f: Field) -> str:
    flags = ("I" if f.fitted else "i" if f.identifiable else "") + ("s" if f.sweepable else "") + ("u" if f.assumable else "")
    return flags or "-"


def schema_text() -> str:
    """The value keys as the presets README lists them (a test holds the README to this;
    :func:`update_readme` rewrites the README's copy).

    Examples
    --------
    >>> from vrelab.sensor.fields import schema_text
    >>> print(schema_text().splitlines()[0])
    Value keys (top level, `[axes.*]` or `[ranges.*]`), from vrelab/sensor/fields.py: each stage's fields
    """
    pairs = "; ".join(f"{f.key} holds the parameters {' and '.join(f.elements)}" for f in FIELDS if f.elements)
    lines = [
        "Value keys (top level, `[axes.*]` or `[ranges.*]`), from vrelab/sensor/fields.py: each stage's fields",
        f"(vrelab/sensor/configs.py), in chain order ({' -> '.join(s.__name__ for s in STAGES)}).",
        "Flags: i identifiable (a campaign's covariance may name it; I: `vrelab identify` fits it), s a sweep may",
        f"set it (by the key), u an `[uncertainty]` table may give it an assumed standard uncertainty; {pairs}.",
        "",
    ]
    for f in FIELDS:
        default = "absent" if f.default is None else repr(f.default).lower() if isinstance(f.default, bool) else f"{f.default!r}"
        bound = (f"; within {f.lower:g}..{f.upper:g}" if f.lower is not None and f.upper is not None
                 else f"; at most {f.upper:g}" if f.upper is not None else f"; at least {f.lower:g}" if f.lower is not None
                 else "")
        keys = {g.name: g.key for g in FIELDS}
        bound += f"; only with {keys.get(f.needs, f.needs)}" if f.needs else ""
        lines.append(f"    {f.key:<24} {f.kind:<13} default {default:<14} {_flags(f):<4} {f.doc}{bound}")
    return "\n".join(lines) + "\n"


def update_readme() -> Path:
    """Rewrite the presets README's copy of :func:`schema_text` (after a row changed)."""
    path = Path(__file__).with_name("presets") / "README"
    text = path.read_text(encoding="utf-8")
    start = text.index("Value keys (top level")
    rows = text.index("\n\n", start) + 2
    end = text.index("\n\n", rows) + 1
    path.write_text(text[:start] + schema_text() + text[end:], encoding="utf-8")
    return path

