"""The package version, in a leaf module so every module can read it without importing the
front door (``vrelab/__init__``), which imports the others lazily: data flows one way."""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("vrelab")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"
