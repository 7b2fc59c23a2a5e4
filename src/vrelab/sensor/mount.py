"""The mount: a PCB or bracket between the environment and the part (the article's package and
mounting resonance), as one runtime stage.

The part sits on a board or bracket that rings at ``fn`` with quality factor ``Q``; the
environment shakes the board's base, and the part feels the board's motion. That is the
single-degree-of-freedom system under base excitation, whose absolute transmissibility is

``T(f) = (1 + j·2ζr) / (1 − r² + j·2ζr)``,  ``r = f/fn``, ``ζ = 1/(2Q)``,

``|T|² = (1 + (2ζr)²) / ((1 − r²)² + (2ζr)²)``

(D. S. Steinberg, *Vibration Analysis for Electronic Equipment*, 3rd ed., Wiley 2000, §2.9-2.10
"transmissibility" of a base-excited single-degree-of-freedom system; the same in any vibration
text, e.g. S. S. Rao, *Mechanical Vibrations*, §3.6, eq. 3.68). ``T(0) = 1``: the static field
passes unchanged; ``|T(fn)| = sqrt(1 + Q²) ≈ Q``; above ``sqrt(2)·fn`` the mount isolates.

A random environment's PSD reaches the part as ``S(f)·|T(f)|²``, a sine's amplitude as
``A·|T(f)|``: the prediction reads the stage's ``response`` as it reads every linear stage's
(:mod:`vrelab.prediction._stages`), the simulation runs its second-order section on the drive
with its state carried across blocks. A mechanical stage ahead of the proof mass, it is a
:class:`~vrelab.sensor.stages.Resonator` by kind (the proof mass's motion, what the over-range
trips on, includes it; the triaxial chain applies it to every component alike); it differs in
its zero, at ``s = −Q·ωn``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vrelab.sensor.stages import Resonator

ComplexArray = NDArray[np.complex128]


@dataclass(frozen=True)
class MountTransmissibility(Resonator):
    """The base-excitation transmissibility of a mount at ``fn_hz`` with ``q`` (module docstring:
    ``T = (1 + j·r/Q)/(1 − r² + j·r/Q)``, Steinberg §2.9).

    Discretised as the proof mass's resonance (matched-z poles, fitted numerator,
    :func:`vrelab.sensor.filtering.discretize_zpk`): the analog zero ``s = −Q·ωn`` is real and
    in the left half plane, away from the jω axis the fit weighs against.

    Examples
    --------
    A board at 500 Hz with Q 10: the static field passes (``|T(0)| = 1``), the resonance
    amplifies by ``sqrt(1 + Q²)`` = 10.0499, and ten times above it the board isolates,
    ``sqrt(1 + 1)/sqrt(99² + 1)`` = 0.0143 (r = 10, 2ζr = r/Q = 1):

    >>> from vrelab.sensor.mount import MountTransmissibility
    >>> mount = MountTransmissibility(500.0, 10.0)
    >>> print([f"{abs(t):.4f}" for t in mount.response([0.0, 500.0, 5000.0])])
    ['1.0000', '10.0499', '0.0143']
    """

    fusable_sos: ClassVar[bool] = True  # one sosfilt with a carried state (filtering.is_sos_filter)

    def response(self, f_hz: ArrayLike) -> ComplexArray:
        r = np.asarray(f_hz, dtype=float) / self.fn_hz
        damping = 1j * r / self.q  # j·2ζr with ζ = 1/(2Q)
        return np.asarray((1.0 + damping) / (1.0 - r**2 + damping), dtype=np.complex128)

    def analog_zpk(self) -> tuple[ComplexArray, ComplexArray, float]:
        # T(s) = (ωn/Q·s + ωn²)/(s² + ωn/Q·s + ωn²) = (ωn/Q)·(s + Q·ωn)/(s² + ωn/Q·s + ωn²)
        wn = 2 * np.pi * self.fn_hz
        poles = np.roots([1.0, wn / self.q, wn**2]).astype(complex)
        return np.array([-self.q * wn], dtype=complex), poles, wn / self.q
