"""``vrelab compare``'s engine: which part, range and output rate holds a budget in a vibration.

* :mod:`~vrelab.comparison.candidates`: the candidates, the budget (a VRE or a tilt error, and
  the conversion between them), the static fields of a tilt range;
* :mod:`~vrelab.comparison.run`: :func:`compare` (each candidate a :func:`vrelab.predict`
  through the sweep's engine), judged with its expanded uncertainty;
* :mod:`~vrelab.comparison.results`: :class:`Comparison`, :class:`CandidateRow`;
* :mod:`~vrelab.comparison.page`: the HTML page.

Names are imported on first use, as :mod:`vrelab` does.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from vrelab._lazy import lazy_getattr

if TYPE_CHECKING:
    from vrelab.comparison.candidates import Budget as Budget
    from vrelab.comparison.candidates import Candidate as Candidate
    from vrelab.comparison.results import CandidateRow as CandidateRow
    from vrelab.comparison.results import Comparison as Comparison
    from vrelab.comparison.run import compare as compare

# name -> module, imported on first use
_LAZY: dict[str, str] = {
    "compare": "vrelab.comparison.run",
    "Comparison": "vrelab.comparison.results",
    "CandidateRow": "vrelab.comparison.results",
    "Candidate": "vrelab.comparison.candidates",
    "Budget": "vrelab.comparison.candidates",
}

__all__ = list(_LAZY)
__getattr__ = lazy_getattr(__name__, _LAZY, globals())
