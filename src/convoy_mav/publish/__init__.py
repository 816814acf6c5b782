"""Publishing the service's state to the outside world (MQTT).

:mod:`.topics` is pure (topic names, JSON payloads, input validation);
:mod:`.mqtt` is the asyncio adapter around aiomqtt 2.5.
"""

from __future__ import annotations

from convoy_mav.publish.mqtt import MqttPublisher
from convoy_mav.publish.topics import (
    ALARM,
    COMMAND,
    COMMANDS,
    CONVOY_POSITION,
    COVERAGE,
    STATUS,
    BadPayload,
    alarm_payload,
    coverage_payload,
    parse_command,
    parse_convoy_position,
    status_payload,
    vehicle_payload,
    vehicle_topic,
)

__all__ = [
    "ALARM",
    "COMMAND",
    "COMMANDS",
    "CONVOY_POSITION",
    "COVERAGE",
    "STATUS",
    "BadPayload",
    "MqttPublisher",
    "alarm_payload",
    "coverage_payload",
    "parse_command",
    "parse_convoy_position",
    "status_payload",
    "vehicle_payload",
    "vehicle_topic",
]
