"""The MAVLink edge: connection strings, the pure codec and the asyncio link.

``ConnectionSpec`` and ``MavCodec`` are pure (no sockets, no asyncio) and are
imported eagerly; ``MavLink`` is imported on first use, so pure code importing
this package (or ``convoy_mav.mavlink.autopilots``) does not pull in asyncio.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from convoy_mav.mavlink.codec import MavCodec, Message
from convoy_mav.mavlink.connection import ConnectionSpec

if TYPE_CHECKING:
    from convoy_mav.mavlink.link import MavLink

__all__ = ["ConnectionSpec", "MavCodec", "MavLink", "Message"]


def __getattr__(name: str) -> Any:
    if name == "MavLink":
        from convoy_mav.mavlink.link import MavLink  # noqa: PLC0415 - lazy on purpose

        return MavLink
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
