"""The clipping model's kind, its one owner: what a sample beyond a rail becomes (physics §1.1).

* ``censored`` (physical saturation, the default): the sample reads as the rail;
* ``truncated`` (the article's model): the sample is discarded.

A leaf module: :mod:`vrelab.models.clipping` re-exports these, and every other module (the
memoryless chain, fits, the reduction, predict, identify, the shaker, the sweep and the CLI)
takes its default from :data:`DEFAULT_CLIP_KIND` rather than writing it again.
"""

from __future__ import annotations

from typing import Final, Literal

Kind = Literal["censored", "truncated"]
KINDS: tuple[Kind, ...] = ("censored", "truncated")
DEFAULT_CLIP_KIND: Final[Kind] = "censored"
