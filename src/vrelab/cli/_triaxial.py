"""What ``vrelab predict`` and ``vrelab simulate`` share for a triaxial vibration (physics §1.6): the
options, the one rule for the static field, the vibration's direction (``--direction`` or IEEE
1293's mount angle) and the triaxial ``--profile`` forms of :mod:`vrelab.triaxial.files`.

The static field is given once: ``--static G`` along the (first) DUT axis, or ``--static-vector
GX,GY,GZ`` in the part's frame; both together are refused (which one would a test engineer
expect to win?), neither is 1 g along the axis.
"""

from __future__ import annotations

import argparse
import math
from typing import Any

DEFAULT_STATIC_G = 1.0


def add_triaxial_arguments(p: argparse.ArgumentParser, axes: bool = False) -> None:
    """``--direction``, ``--mount-deg``, ``--mount-plane``, ``--static-vector`` (and, with
    ``axes``, ``--axes``); ``--static`` (:func:`vrelab.cli._common.add_sensor_arguments`) then
    defaults to None so that :func:`static_field` can refuse it beside ``--static-vector``."""
    t = p.add_argument_group("triaxial vibration (physics §1.6, IEEE 1293 cross-coupling)")
    t.add_argument("--direction", metavar="X,Y,Z",
                   help="the vibration along this direction in the part's frame (normalised; levels are its rms)")
    t.add_argument("--mount-deg", type=float, metavar="DEG",
                   help="IEEE 1293 mount angle: the vibration at DEG from the input axis toward --mount-plane's axis")
    t.add_argument("--mount-plane", choices=("ip", "io"),
                   help="with --mount-deg: toward the pendulous (ip, default) or output (io) axis")
    if axes:
        t.add_argument("--axes", metavar="LIST", help="the DUT axes, e.g. x,y,z (default --axis)")
    t.add_argument("--static-vector", metavar="GX,GY,GZ",
                   help="the static acceleration vector in the part's frame [g] (instead of --static along the axis; "
                   "not both)")
    p.set_defaults(static_g=None)  # so that --static and --static-vector together are refused


def static_field(args: argparse.Namespace) -> list[float] | None:
    """The ``--static-vector`` (None where not given); refuses it beside ``--static``, and sets
    ``args.static_g`` to its default (1 g) where ``--static`` is not given. Called once a run."""
    if args.static_vector is not None and args.static_g is not None:
        raise ValueError("give the static field once: --static (along the axis) or --static-vector (gx,gy,gz), not both")
    if args.static_g is None:
        args.static_g = DEFAULT_STATIC_G
    if args.static_vector is None:
        return None
    from vrelab import _validate as V

    g = vector(args.static_vector, "--static-vector")
    V.acceleration("--static-vector's magnitude", math.sqrt(sum(x * x for x in g)))  # the bound --static has
    return g


def static_vector(given: list[float] | None, static_g: float, input_axis: int) -> list[float]:
    """The static field in the part's frame: the ``--static-vector`` given, else ``--static``
    along the input axis (index of x, y, z)."""
    return given if given is not None else [float(static_g) if j == input_axis else 0.0 for j in range(3)]


def vector(text: str, name: str) -> list[float]:
    """Three finite numbers X,Y,Z from an option."""
    try:
        values = [float(x) for x in text.split(",")]
    except ValueError:
        values = []
    if len(values) != 3 or not all(math.isfinite(x) for x in values):
        raise ValueError(f"{name} must be three finite numbers X,Y,Z (the part's frame), got {text!r}")
    return values


def along(args: argparse.Namespace) -> bool:
    """Whether the options put a single-axis vibration along a direction (``--direction`` or
    ``--mount-deg``), checked: once, and ``--mount-plane`` only with ``--mount-deg``."""
    if args.mount_plane is not None and args.mount_deg is None:
        raise ValueError("--mount-plane needs --mount-deg (the angle of the input axis to the vibration)")
    if args.direction is not None and args.mount_deg is not None:
        raise ValueError("give the vibration's direction once: --direction or --mount-deg, not both")
    return args.direction is not None or args.mount_deg is not None


def direction_of(args: argparse.Namespace, triad: tuple[int, int, int]) -> list[float] | None:
    """The vibration's direction in the part's frame: ``--direction``, or IEEE 1293's mount angle
    of the input axis toward its pendulous (ip) or output (io) axis; None where neither is given."""
    from vrelab import _validate as V
    from vrelab.triaxial.profile import AXES, direction

    along(args)
    if args.direction is not None:
        return vector(args.direction, "--direction")
    if args.mount_deg is None:
        return None
    i, p, o = triad
    toward = AXES[o] if args.mount_plane == "io" else AXES[p]
    return [float(x) for x in direction(AXES[i], toward, V.mount_angle("--mount-deg", args.mount_deg))]


def is_triaxial_profile(spec: str | None) -> bool:
    """Whether a ``--profile`` names a triaxial vibration (``PROFILE@direction``, a triaxial file)."""
    if spec is None:
        return False
    from vrelab.triaxial.files import is_triaxial_spec

    return bool(is_triaxial_spec(spec))


def triaxial_profile(spec: str) -> Any:
    """The triaxial vibration a ``--profile`` names (:func:`vrelab.triaxial.files.parse_triaxial`)."""
    from vrelab.triaxial.files import parse_triaxial

    return parse_triaxial(spec)
