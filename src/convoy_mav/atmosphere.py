"""The standard atmosphere, for what autopilots scale by air density.

ArduPlane's L1 controller flies every loiter at its commanded radius times
``EAS2TAS^2`` (``AP_L1_Control::loiter_radius``, with ``NAVL1_LIM_BANK`` at its default
0), so that the bank angle of a loiter stays the same as the air thins. At an airfield
600 m above the sea that is 6-7 % wider: a 2 km loiter flown 130-160 m outside the arc
it was laid on. ``EAS2TAS`` is ``sqrt(rho0 / rho)``; ArduPilot takes ``rho`` from the
1976 standard atmosphere at the aircraft's altitude (``AP_Baro::get_EAS2TAS``), as here.
"""

from __future__ import annotations

import math

__all__ = ["density_ratio", "eas2tas", "eas2tas_squared", "l1_loiter_scale"]

_T0 = 288.15  # K, sea-level temperature
_LAPSE = 0.0065  # K/m, troposphere
_EXPONENT = 9.80665 * 0.0289644 / (8.31446 * _LAPSE) - 1.0  # g M / (R L) - 1 = 4.2559
_TROPOPAUSE = 11_000.0  # m: the lapse-rate model holds below it


def density_ratio(amsl: float) -> float:
    """rho / rho0 of the standard atmosphere ``amsl`` metres above mean sea level.

    Raises:
        ValueError: ``amsl`` is not finite, or outside -500 m to the tropopause.
    """
    if not (math.isfinite(amsl) and -500.0 <= amsl <= _TROPOPAUSE):
        raise ValueError(f"altitude must be finite, -500 to 11000 m AMSL, got {amsl!r}")
    return float((1.0 - _LAPSE * amsl / _T0) ** _EXPONENT)


def eas2tas_squared(amsl: float) -> float:
    """``EAS2TAS^2 = rho0 / rho`` at ``amsl``: how much wider ArduPlane flies a loiter."""
    return 1.0 / density_ratio(amsl)


def eas2tas(amsl: float) -> float:
    """``EAS2TAS = sqrt(rho0 / rho)`` at ``amsl``: true airspeed per equivalent airspeed,
    what ArduPlane's TECS flies a commanded airspeed at (``_TAS_dem = _EAS_dem * EAS2TAS``)."""
    return math.sqrt(eas2tas_squared(amsl))


def l1_loiter_scale(amsl: float) -> float:
    """How much wider than commanded ArduPlane's L1 flies a loiter at ``amsl``:
    ``EAS2TAS^2`` there, or 1.0 where the standard atmosphere gives no answer (an
    altitude outside the troposphere, or not finite: left unscaled, not refused)."""
    try:
        return eas2tas_squared(amsl)
    except ValueError:
        return 1.0
