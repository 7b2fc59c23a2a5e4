"""IEEE 1293's cross-coupling terms of one sensing axis: the one table (physics §1.6).

The model equation of an axis on its triad (i, p, o) = (input, pendulous, output) adds to
``u + k2·u² + k3·u³ + k4·u⁴`` one term per row of :data:`CROSS_TERMS`,

    ``Kip·b_i·b_p + Kio·b_i·b_o + Kpp·b_p² + Koo·b_o² + Kpo·b_p·b_o``

(IEEE Std 1293-1998, model equation; K in µg/g² there and in a sensor file, 1/g on a
:class:`~vrelab.sensor.Sensor`). Every user reads this table: the triaxial chain and the
triaxial prediction (:data:`vrelab.triaxial.chain.CROSS_TERMS`, the Sensor attributes and the
triad positions each multiplies), identification (:data:`FITTED`: the terms a mount-angle
campaign fits, in the order of its JSON and covariance) and the sensor file's field table
(its ``k.._ug_per_g2`` rows, checked against this one by tests/test_cross_terms.py). A new
cross term is one row here (and its field row, until the field table is derived from stages).

References
----------
.. [1] IEEE Std 1293-1998, IEEE Standard Specification Format Guide and Test Procedure for
   Linear, Single-Axis, Nongyroscopic Accelerometers: the model equation, and the cross-coupling
   coefficients measured with the input axis at 0°, ±45° and 90° to the vibration in the IP and
   IO planes.
"""

from __future__ import annotations

from dataclasses import dataclass

from vrelab.units import UG_PER_G

# the triad's axes by position: 0 = input i, 1 = pendulous p, 2 = output o
TRIAD = "ipo"


@dataclass(frozen=True)
class CrossTerm:
    """One cross term ``K_ab·b_a·b_b`` of the model equation.

    ``axes``: the two triad positions it multiplies (0 = i, 1 = p, 2 = o). ``plane``: the mount
    plane (``"ip"`` or ``"io"``, the campaign's ``mount_plane``) whose runs identification fits
    it from; None where it does not fit it, and ``why_not_fitted`` says why.
    """

    axes: tuple[int, int]
    plane: str | None
    why_not_fitted: str | None = None
    # a sensor file's value [µg/g²] per the Sensor attribute's [1/g]
    scale: float = UG_PER_G
    unit: str = "ug/g^2"

    @property
    def name(self) -> str:
        """The pair of triad letters: ``"ip"``, ``"pp"``, ..."""
        return TRIAD[self.axes[0]] + TRIAD[self.axes[1]]

    @property
    def label(self) -> str:
        """IEEE 1293's symbol: ``"Kip"``."""
        return "K" + self.name

    @property
    def attr(self) -> str:
        """The :class:`~vrelab.sensor.Sensor` attribute [1/g]: ``"kip_per_g"``."""
        return f"k{self.name}_per_g"

    @property
    def key(self) -> str:
        """The sensor file's key and identification's parameter name [µg/g²]: ``"kip_ug_per_g2"``."""
        return f"k{self.name}_ug_per_g2"

    @property
    def product(self) -> str:
        """The product it multiplies, in the direction cosines d: ``"d_i·d_p"``, ``"d_p²"``."""
        a, b = (TRIAD[k] for k in self.axes)
        return f"d_{a}²" if a == b else f"d_{a}·d_{b}"

    @property
    def fitted(self) -> bool:
        return self.plane is not None


# The model equation's order (IEEE 1293): the input axis's products first, then the squares.
CROSS_TERMS: tuple[CrossTerm, ...] = (
    CrossTerm((0, 1), "ip"),
    CrossTerm((0, 2), "io"),
    CrossTerm((1, 1), "ip"),
    CrossTerm((2, 2), "io"),
    CrossTerm((1, 2), None, "Kpo needs a run mounted in the p-o plane, which the IP and IO mount-angle runs "
              "(IEEE 1293) do not excite"),
)  # fmt: skip

# The mount planes identification fits in, in its order.
PLANES: tuple[str, ...] = ("ip", "io")

# The terms identification fits, plane by plane (IP, then IO) and within a plane in the table's
# order: Kip, Kpp, Kio, Koo, the order of its JSON, covariance and least-squares columns.
FITTED: tuple[CrossTerm, ...] = tuple(t for plane in PLANES for t in CROSS_TERMS if t.plane == plane)


def by_key() -> dict[str, CrossTerm]:
    """The rows by sensor-file key (``"kip_ug_per_g2"``)."""
    return {t.key: t for t in CROSS_TERMS}


__all__ = ["CrossTerm", "CROSS_TERMS", "FITTED", "PLANES", "TRIAD", "by_key"]
