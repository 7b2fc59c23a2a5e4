"""vrelab: vibration rectification error (VRE) of accelerometers.

Data flow, one module boundary per arrow::

    profiles -> synthesis -> sensor (chain of stages) -> record -> analysis -> fits -> report

``vrelab.models`` holds the pure analytic physics used at every step.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("vrelab")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
