"""Provision an autopilot with a MAVLink 2 signing key (``convoy-mav sign-setup``).

The MAVLink way (``SETUP_SIGNING``), as MAVProxy's ``signing setup`` does: the
key travels in the clear, so do it over a link nobody else hears (USB, a
bench cable; ArduPilot accepts it on USB only). Then the vehicle signs, and
this checks it: a HEARTBEAT that passes the signature check must arrive.
"""

from __future__ import annotations

import asyncio
from typing import Any

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.errors import AutopilotError
from convoy_mav.mavlink import MavLink
from convoy_mav.mavlink.codec import GCS_COMPONENT, GCS_SYSTEM, MavCodec
from convoy_mav.mavlink.signing import Signing, timestamp_now

__all__ = ["provision_signing"]


async def provision_signing(
    connection: str, sysid: int, key: bytes, timeout: float = 10.0, *, source: int = GCS_SYSTEM
) -> str:
    """Send ``key`` to vehicle ``sysid`` at ``connection`` and confirm it signs with it.
    ``source`` is our system id (ArduPilot with MAV_OPTIONS bit 0 hears only its
    MAV_GCS_SYSID).

    Returns:
        One line saying what was done.

    Raises:
        AutopilotError: No HEARTBEAT from ``sysid``, or no signed one after the setup.
    """
    heard: asyncio.Queue[Any] = asyncio.Queue()

    def on_message(msg: Any) -> None:
        if msg.get_srcSystem() == sysid and msg.get_type() == "HEARTBEAT":
            heard.put_nowait(msg)

    codec = MavCodec(source, GCS_COMPONENT)
    async with MavLink(connection, on_message, codec=codec, name=f"sign-setup[{sysid}]") as link:
        try:
            async with asyncio.timeout(timeout):  # (see eventloop.wait_set)
                first = await heard.get()
        except TimeoutError:
            raise AutopilotError(f"{connection}: no HEARTBEAT from sysid {sysid}") from None
        link.send(
            mavlink.MAVLink_setup_signing_message(
                sysid, first.get_srcComponent(), list(key), timestamp_now()
            )
        )
        # from now on: signed, in and out
        link.codec = MavCodec(source, GCS_COMPONENT, signing=Signing(key))
        while not heard.empty():
            heard.get_nowait()
        try:
            async with asyncio.timeout(timeout):
                await heard.get()
        except TimeoutError:
            raise AutopilotError(
                f"{connection}: sysid {sysid} sent no HEARTBEAT signed with the key after "
                "SETUP_SIGNING (ArduPilot takes it over USB only)"
            ) from None
    return f"sysid {sysid} at {connection} signs with the key now"
