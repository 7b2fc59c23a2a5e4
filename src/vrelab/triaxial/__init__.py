"""Beyond one axis (SPEC 1.6): triaxial vibration and the IEEE 1293 cross-coupling terms.

:class:`TriaxialProfile` is random vibration along x, y and z as a 3×3 cross-spectral
density matrix; :class:`TriaxialSine` a sine along a direction; :func:`direction` the unit
vector of a mount angle.
"""

from vrelab.triaxial.profile import AXES, TriaxialProfile, TriaxialSine, direction

__all__ = ["AXES", "TriaxialProfile", "TriaxialSine", "direction"]
