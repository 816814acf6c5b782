"""sitl_mock: a multi-vehicle mock autopilot speaking real MAVLink over UDP."""
