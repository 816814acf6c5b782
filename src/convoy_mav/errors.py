"""The one error tree of convoy-mav.

Errors are split, as in h11, into *our* mistakes or bad input (the caller can
fix them) and *the peer* misbehaving (an autopilot or broker did something
unexpected)::

    ConvoyError
    ├── ConfigError            a config key or CLI value is invalid
    ├── PlanningError          the geometry asked for has no plan
    │   └── InfeasibleEntryError   an entry state outside the feasible set (eq. 8)
    └── AutopilotError         an autopilot refused, went silent or sent garbage
        └── LinkTimeout        no answer within the allowed time

Foreign exceptions (``OSError``, ``MqttError``) are translated at the adapter
that meets them, so callers only ever catch ``ConvoyError``.
"""

from __future__ import annotations

__all__ = [
    "AutopilotError",
    "ConfigError",
    "ConvoyError",
    "InfeasibleEntryError",
    "LinkTimeout",
    "PlanningError",
]


class ConvoyError(Exception):
    """Root of every error convoy-mav raises on purpose."""


class ConfigError(ConvoyError, ValueError):
    """A configuration key or command-line value is invalid.

    The message always names the key and the offending value, so the operator
    can fix the file without reading a traceback.
    """

    def __init__(self, key: str, value: object, reason: str) -> None:
        self.key = key
        self.value = value
        self.reason = reason
        super().__init__(f"{key} = {value!r}: {reason}")


class PlanningError(ConvoyError, ValueError):
    """The requested geometry admits no plan (e.g. a convoy faster than the UAVs)."""


class InfeasibleEntryError(PlanningError):
    """An entry state is not in the feasible entry set Λ of eq. (8)."""


class AutopilotError(ConvoyError):
    """An autopilot refused a command, vanished, or sent something unusable."""


class LinkTimeout(AutopilotError, TimeoutError):
    """An autopilot did not answer within the allowed time."""
