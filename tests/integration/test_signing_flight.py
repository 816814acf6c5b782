"""A signed fleet: the mock's aircraft and the service sign with one key (MAVLink 2).

The mission flies as unsigned (ground truth at the paper's figure); a stranger's
unsigned DO_SET_MODE, sent straight to an aircraft, is refused by it and changes
nothing; nothing the service received failed its signature check.
"""

from __future__ import annotations

import asyncio
import hashlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.app import ConvoyService
from convoy_mav.demo import SCENARIOS, run_demo
from convoy_mav.errors import AutopilotError
from convoy_mav.mavlink.signing import load_key
from convoy_mav.provision import provision_signing
from sitl_mock import MockFleet
from tests.conftest import StartMock
from tests.hostspeed import host_speedup
from tests.mavclient import MavClient

pytestmark = pytest.mark.integration

SPEEDUP = host_speedup(25.0)
DURATION = 300.0


async def test_a_signed_fleet_flies_and_refuses_a_strangers_mode_command(tmp_path: Path) -> None:
    key_file = tmp_path / "fleet.key"
    key_file.write_text("correct horse battery staple\n")  # a passphrase (MAVProxy style)
    marks: dict[str, Any] = {}

    async def stranger(fleet: MockFleet, service: ConvoyService) -> None:
        while service.monitor.protect_start is None or fleet.now < 150.0:
            await asyncio.sleep(0.01)
        port = int(fleet.endpoint(1).connect.rsplit(":", 1)[1])
        gcs = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=200)
        try:
            for _ in range(5):
                gcs.mav.command_long_send(
                    1, 1, mavlink.MAV_CMD_DO_SET_MODE, 0,
                    mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4, 3, 0, 0, 0, 0,
                )  # fmt: skip
                await asyncio.sleep(0.05)
            await asyncio.sleep(0.5)
            marks["refused"] = fleet.link(1).counters["bad_signature"]
            marks["mode"] = service.vehicles[1].mode
        finally:
            gcs.close()

    result = await run_demo(
        SCENARIOS["stationary"], duration=DURATION, speedup=SPEEDUP, during=stranger,
        signing_key_file=str(key_file),
    )  # fmt: skip
    report = result.report.to_dict()
    assert marks.get("refused", 0) >= 5, marks  # (the mock counts them: it checks too)
    assert marks["mode"] == "OFFBOARD"
    assert not [a for a in report["alarms"] if a["kind"] == "uav_taken"]
    for v in report["vehicles"]:
        assert v["rejected"]["unsigned"] == 0 and v["rejected"]["bad_signature"] == 0, v
    assert result.truth is not None and result.truth.fraction >= 0.99, result.truth
    assert (tmp_path / "fleet.key.state.json").exists()  # timestamps kept for a restart


async def test_sign_setup_provisions_the_mock_and_it_then_refuses_unsigned_frames(
    start_mock: StartMock, mav_client: Callable[..., MavClient], tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:  # fmt: skip
    fleet = await start_mock()
    key_file = tmp_path / "uav1.key"
    key_file.write_text(hashlib.sha256(b"bench").hexdigest() + "\n")
    connect = fleet.endpoint(1).connect
    # (the CLI runs its own event loop: from this one, call what it calls)
    line = await provision_signing(connect, 1, load_key("k", file=str(key_file)), timeout=5.0)
    assert "signs with the key now" in line
    link = fleet.link(1)
    assert link.signing_key == hashlib.sha256(b"bench").digest()
    assert link.counters["signing_setup"] == 1
    stranger = mav_client(fleet.endpoint(1).port, source_system=201)
    before = link.counters["bad_signature"]
    stranger.hello()  # unsigned
    await asyncio.sleep(0.2)
    assert link.counters["bad_signature"] == before + 1
    with pytest.raises(AutopilotError, match="no HEARTBEAT"):  # nobody there
        await provision_signing("udpout:127.0.0.1:9", 1, b"k" * 32, timeout=0.3)
