"""convoy-mav: keep a ground convoy under continuous UAV watch."""

from __future__ import annotations

__all__ = ["__version__"]

__version__ = "0.1.0"
