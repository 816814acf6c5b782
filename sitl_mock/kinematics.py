"""Point-mass flight physics of the mock: Dubins/unicycle aircraft and their guidance laws.

This module is the yardstick the product's coverage is judged against, so it errs on
the side of honesty: an aircraft can never turn tighter than its airframe allows, a
plane can never stop or hover, and wind blows everyone off the ground track it would
otherwise fly.

Design rules:
    * Pure: no I/O, no clock. Time advances only through ``Aircraft.step(dt)``.
    * One bound for everyone: ``|yaw_rate| <= speed / min_turn_radius`` at every step
      (with ``speed`` the smaller of the airspeeds at the step's two ends), never a
      jump to a setpoint. The one exception is a copter standing still in the air
      (speed 0): its velocity has no direction, so it points the next one anywhere.
    * Exact integration: speed and turn rate are held constant over a step and the
      position follows the exact circular arc, so a saturated turn is a circle of
      radius ``speed / max_turn_rate`` at any ``dt``; altitude follows the exact
      solution of the rate-limited first-order lag.
    * Guidance is a feed-forward + feedback law on the *course*: a desired ground
      velocity (or a vector field for circles) gives the desired course; its time
      derivative along the actual motion is fed forward as the turn rate, and the
      heading error is fed back with gain ``_K_HEADING``; the sum is saturated.
    * Planes fly a commanded airspeed (as TECS does), never a ground speed: a velocity
      target's magnitude is the airspeed, whatever the tracking error. So a plane
      closes along-track gaps only in turns, by cutting inside or flying wide; behind
      a reference that moves straight at the plane's airspeed, it stays behind.
    * Wind: courses are converted to headings through the wind triangle, so ground
      tracks are held; but a plane's ground speed varies around a circle, so a
      reference moving at constant ground speed is led and lagged by about
      ``wind * radius / airspeed``, and a ground circle tighter than
      ``min_turn_radius * (1 + wind / airspeed) ** 2`` saturates the turn downwind
      and is flown wide. Copters regulate ground velocity up to their airspeed, so
      they track exactly in any wind they can fly against.
    * ``step`` is the hot path (200 aircraft x 100 Hz in real time on one core): plain
      ``math`` on floats, no allocations; commands are digested once in ``command``.
"""

from __future__ import annotations

import math

from sitl_mock.airframe import (
    AircraftState,
    AirframeParams,
    Frame,
    Guidance,
    Idle,
    Loiter,
    Takeoff,
    TrackTarget,
)

__all__ = [
    "Aircraft",
    "AircraftState",
    "AirframeParams",
    "Frame",
    "Guidance",
    "Idle",
    "Loiter",
    "Takeoff",
    "TrackTarget",
]


_PI = math.pi
_TAU = 2.0 * math.pi
_HALF_PI = 0.5 * math.pi

_K_HEADING = 1.5
"""1/s: heading-error feedback; fast against the position loops, slow against 1/dt."""
_K_TRACK = 0.3
"""1/s: a position error of x metres asks for x * _K_TRACK m/s toward the reference."""
_PLANE_CORRECTION = 0.5
"""A plane's position correction is capped at this fraction of the reference speed, so
its wanted course never points back against the reference: far behind or ahead, it
flies alongside and gains or loses ground in the turns instead of looping."""
_FAR_RADII = 2.0
_FAR_CAP_GAIN = 4.0
"""Further than _FAR_RADII min turn radii from its reference, a plane's correction cap
grows in proportion, up to _FAR_CAP_GAIN times: far away it pursues the reference's
position rather than copying its motion (which would drift it downwind forever)."""
_K_HOLD = 0.8
"""1/s: copter position hold / fly-to gain (copters can brake, so it can be stiffer)."""
_LOITER_SHARPNESS = 1.0
"""Vector-field slope: at one capture length off the circle the field points 45 deg in."""
_L1_S = 0.3183 * 0.75 * 15.0
"""s: the capture length of a loiter is the smaller of its radius and this times the
speed (at least the turn radius): ArduPlane's L1 distance, ``damping * period * V / pi``
with SITL's ``NAVL1_PERIOD`` 15 and the default damping 0.75 (79 m at 22 m/s). A plane
a few L1 distances off a km-wide loiter turns onto it in seconds (its PD on the radial
error has the period's time scale, whatever the radius), not over a km."""
_CAPTURE_EASE = 2.0
"""Capture lengths off its loiter beyond which a plane flies straight at the centre, as
L1's capture law has it from about one L1 distance out (``AP_L1_Control::update_loiter``);
the vector field is eased into that line over twice the length, so a plane turning no
tighter than the mock's turn radius meets the circle as smoothly as it did before."""
_COPTER_STOP_ANGLE = 0.25 * math.pi
"""A copter whose velocity points further than this from the wanted one brakes first."""
_HOLD_DEADBAND = 0.05
"""m: a holding copter closer than this to its point stops correcting (no dithering)."""
_TAKEOFF_TOLERANCE = 0.05
"""Takeoff is complete within this fraction of the climb (at least _TAKEOFF_MIN_TOL)."""
_TAKEOFF_MIN_TOL = 0.5
_LANDED_TOL = 0.05
"""m above ground at which an aircraft commanded Idle counts as landed."""
_OMEGA_WINDOW = 2.0
"""s: two velocity targets further apart than this say nothing about the turn rate."""

# Horizontal guidance modes, digested from the Guidance value by Aircraft.command().
_M_GROUND = 0  # Idle: stay put on the ground; land if airborne
_M_TRACK = 1  # TrackTarget with velocity (and maybe position): track a moving reference
_M_LOITER = 2  # fly a circle (Loiter, plane position-only target, end of plane takeoff)
_M_HOLD = 3  # copter: fly to a point and hover there
_M_STRAIGHT = 4  # plane with nothing to steer by: keep the course
_M_TAKEOFF = 5  # Takeoff until the target altitude is reached


def _wrap(angle: float) -> float:
    """Wrap to (-pi, pi]."""
    if -_PI < angle <= _PI:
        return angle
    angle = (angle + _PI) % _TAU - _PI
    return _PI if angle == -_PI else angle


def _finite(value: float | None) -> float | None:
    return value if value is not None and math.isfinite(value) else None


class Aircraft:
    """One simulated aircraft: its limits, its state and the guidance it flies.

    On the ground only ``Takeoff`` moves it (a plane is launched at cruise speed);
    any other guidance waits there, wind or not. ``Idle`` in the air lands: a copter
    straight down where it is, a plane gliding ahead at minimum airspeed; touchdown
    zeroes the speed and clears ``airborne``. Guidance without a velocity of its own
    flies at the cruise speed of ``set_speed`` (default: ``params.airspeed``).

    Args:
        params: The airframe.
        state: Initial state; mutated in place by ``step``.
        ground_down: World ``down`` of the ground under the aircraft. Defaults to the
            initial ``down`` if the aircraft starts on the ground, else 0.
    """

    __slots__ = (
        "_alt_rate",
        "_climb_cmd",
        "_clock",
        "_copter",
        "_cruise",
        "_far",
        "_ground_down",
        "_guidance",
        "_inv_rmin",
        "_k_track",
        "_lag2",
        "_mode",
        "_omega",
        "_pe",
        "_pn",
        "_radius",
        "_sign",
        "_t_cmd",
        "_takeoff_complete",
        "_target_down",
        "_track_cap",
        "_track_speed",
        "_ve",
        "_vmax",
        "_vmin",
        "_vn",
        "_we",
        "_wn",
        "params",
        "state",
    )

    def __init__(
        self, params: AirframeParams, state: AircraftState, *, ground_down: float | None = None
    ) -> None:
        self.params = params
        self.state = state
        if ground_down is None:
            ground_down = 0.0 if state.airborne else state.down
        self._ground_down = ground_down
        self._copter = params.frame == "copter"
        self._inv_rmin = 1.0 / params.min_turn_radius
        self._lag2 = 0.0 if self._copter else params.loiter_lag**2
        self._far = _FAR_RADII * params.min_turn_radius
        if self._copter:
            self._vmin, self._vmax = 0.0, params.airspeed
        else:
            self._vmin = params.min_airspeed_ratio * params.airspeed
            self._vmax = params.max_airspeed_ratio * params.airspeed
        self._wn = params.wind_north
        self._we = params.wind_east
        self._cruise = params.airspeed
        self._clock = 0.0
        self._t_cmd = 0.0
        self._guidance: Guidance = Idle()  # so an aircraft created in the air lands
        self._mode = _M_GROUND
        self._pn, self._pe = state.north, state.east
        self._vn = self._ve = 0.0
        self._omega = 0.0
        self._k_track = 0.0
        self._track_speed = params.airspeed
        self._track_cap = 0.0
        self._radius = params.min_turn_radius
        self._sign = 1.0
        self._target_down = ground_down
        self._alt_rate = False
        self._climb_cmd = 0.0
        self._takeoff_complete = False

    # ------------------------------------------------------------------ queries
    @property
    def guidance(self) -> Guidance:
        """The guidance last passed to ``command`` (``Idle()`` at first)."""
        return self._guidance

    @property
    def max_turn_rate(self) -> float:
        """The turn-rate bound at the current airspeed (rad/s)."""
        return self.state.speed * self._inv_rmin

    @property
    def ground_down(self) -> float:
        """World ``down`` of the ground: the aircraft never goes below it."""
        return self._ground_down

    @property
    def takeoff_complete(self) -> bool:
        """True once the current ``Takeoff`` reached its altitude (plane now loiters)."""
        return self._takeoff_complete

    @property
    def target_down(self) -> float:
        """The altitude (world ``down``) the aircraft is currently heading for."""
        return self._target_down

    # ----------------------------------------------------------------- commands
    def scale_airspeed_range(self, scale: float) -> None:
        """Fly the airframe's airspeed range (stall to maximum) ``scale`` times faster.

        Where the firmware reckons airspeeds as equivalent airspeeds (ArduPlane),
        both ends are so too: a wing stalls at a dynamic pressure, so through air
        thinner than at sea level its range is ``EAS2TAS`` faster in true airspeed.
        """
        if not self._copter:
            p = self.params
            self._vmin = p.min_airspeed_ratio * p.airspeed * scale
            self._vmax = p.max_airspeed_ratio * p.airspeed * scale

    def set_speed(self, speed: float) -> None:
        """Set the cruise airspeed (DO_CHANGE_SPEED), clamped to the airframe's range.

        It applies to every guidance without a velocity (loiter, fly-to, takeoff);
        a velocity target brings its own speed.

        Raises:
            ValueError: ``speed`` is negative or not finite.
        """
        if not (math.isfinite(speed) and speed >= 0.0):
            raise ValueError(f"speed must be >= 0 and finite, got {speed!r}")
        self._cruise = min(max(speed, self._vmin), self._vmax)

    def command(self, guidance: Guidance) -> None:
        """Fly ``guidance`` from now on (latest wins).

        Repeating the current guidance (a retransmitted command, a setpoint streamed
        faster than it changes, guidance re-derived every step) is a no-op, so a
        reference keeps moving and a finished takeoff is not restarted.
        """
        if guidance == self._guidance:
            return
        previous = self._guidance
        self._guidance = guidance
        self._takeoff_complete = False
        s = self.state
        if isinstance(guidance, TrackTarget):
            self._command_track(guidance, previous)
        elif isinstance(guidance, Loiter):
            self._set_altitude(guidance.down)
            self._set_circle(guidance.north, guidance.east, guidance.radius, guidance.clockwise)
        elif isinstance(guidance, Takeoff):
            self._set_altitude(guidance.down)
            self._mode = _M_TAKEOFF
            self._pn, self._pe = s.north, s.east
        else:
            self._mode = _M_GROUND
            self._alt_rate = False
            self._target_down = self._ground_down
            self._pn, self._pe = s.north, s.east

    def _set_altitude(self, down: float) -> None:
        self._alt_rate = False
        self._target_down = min(down, self._ground_down)

    def _set_circle(self, north: float, east: float, radius: float, clockwise: bool) -> None:
        if self._copter and radius == 0.0:
            self._set_hold(north, east)
            return
        self._mode = _M_LOITER
        self._pn, self._pe = north, east
        self._radius = max(radius, self.params.min_turn_radius)
        self._sign = 1.0 if clockwise else -1.0

    def _set_hold(self, north: float, east: float) -> None:
        if self._copter:
            self._mode = _M_HOLD
            self._pn, self._pe = north, east
        else:
            self._set_circle(north, east, self.params.min_turn_radius, True)

    def _command_track(self, target: TrackTarget, previous: Guidance) -> None:
        down, vd = _finite(target.down), _finite(target.vd)
        if down is not None:
            self._set_altitude(down)
        elif vd is not None:
            self._alt_rate = True
            self._climb_cmd = min(max(-vd, -self.params.max_climb_rate), self.params.max_climb_rate)
        elif self._alt_rate:  # a climb rate is not left running by a target that omits it
            self._set_altitude(self.state.down)
        north, east = _finite(target.north), _finite(target.east)
        vn, ve = _finite(target.vn), _finite(target.ve)
        s = self.state
        if vn is not None and ve is not None:
            speed = math.hypot(vn, ve)
            if north is not None and east is not None:
                if speed < 1e-6:  # a point, not a moving reference
                    self._set_hold(north, east)
                    return
                self._pn, self._pe, self._k_track = north, east, _K_TRACK
            else:
                self._k_track = 0.0
            self._mode = _M_TRACK
            self._vn, self._ve = vn, ve
            self._omega = self._reference_turn_rate(vn, ve, speed, previous)
            self._t_cmd = self._clock  # the reference is at (north, east) now
            self._track_speed = speed
            self._track_cap = self._vmax if self._copter else _PLANE_CORRECTION * speed
        elif north is not None and east is not None:
            self._set_hold(north, east)
        elif self._mode in (_M_GROUND, _M_TAKEOFF):
            # Nothing to steer by: a plane keeps its course, a copter stops and hovers.
            if self._copter:
                self._set_hold(s.north, s.east)
            else:
                self._mode = _M_STRAIGHT

    def _reference_turn_rate(self, vn: float, ve: float, speed: float, previous: Guidance) -> float:
        """Turn rate of a streamed reference, from the course change since the last target.

        The product samples circular arcs, so two consecutive velocities pin the arc's
        turn rate; it is bounded by what the airframe could fly at that speed.
        """
        if not isinstance(previous, TrackTarget) or speed < 1e-6:
            return 0.0
        pvn, pve = _finite(previous.vn), _finite(previous.ve)
        elapsed = self._clock - self._t_cmd
        if pvn is None or pve is None or not 0.0 < elapsed <= _OMEGA_WINDOW:
            return 0.0
        if math.hypot(pvn, pve) < 1e-6:
            return 0.0
        turn = _wrap(math.atan2(ve, vn) - math.atan2(pve, pvn))
        bound = speed * self._inv_rmin
        return min(max(turn / elapsed, -bound), bound)

    # -------------------------------------------------------------------- physics
    def step(self, dt: float) -> None:
        """Advance the aircraft by ``dt`` seconds of sim time.

        Raises:
            ValueError: ``dt`` is negative or not finite.
        """
        if not 0.0 < dt < math.inf:
            if dt == 0.0:
                return
            raise ValueError(f"dt must be positive and finite, got {dt!r}")
        s = self.state
        now = self._clock  # guidance looks at the step's start, physics integrates over it
        self._clock = now + dt
        mode = self._mode
        copter = self._copter
        if not s.airborne:
            if mode != _M_TAKEOFF:
                s.speed = s.yaw_rate = s.climb_rate = 0.0
                return
            s.airborne = True
            if not copter:
                s.speed = max(s.speed, self._cruise)  # hand or catapult launch
        yaw = s.yaw
        v0 = s.speed
        v0 = max(v0, self._vmin)  # a flying plane is never slower than its minimum airspeed
        wn = self._wn
        we = self._we
        cy = math.cos(yaw)
        sy = math.sin(yaw)
        gn = v0 * cy + wn
        ge = v0 * sy + we

        # --- horizontal guidance: wanted ground course chi and its rate along the motion
        chi = chi_rate = 0.0
        steer = True  # False: no course wanted, fly straight
        vcmd = self._cruise
        air_n = air_e = 0.0  # copters: wanted air velocity ...
        acc_n = acc_e = 0.0  # ... and its rate of change
        if mode == _M_TRACK:
            vn = self._vn
            ve = self._ve
            omega = self._omega
            tau = now - self._t_cmd
            k = self._k_track
            if omega == 0.0:
                rn = self._pn + vn * tau
                re = self._pe + ve * tau
                an = ae = 0.0
            else:  # the reference keeps turning at the rate its last targets turned
                sh = math.sin(0.5 * omega * tau)
                ch = math.cos(0.5 * omega * tau)
                sn = 2.0 * sh * ch  # sin(omega tau)
                vers = 2.0 * sh * sh  # 1 - cos(omega tau), without cancellation
                c = 1.0 - vers
                rn = self._pn + (vn * sn - ve * vers) / omega
                re = self._pe + (vn * vers + ve * sn) / omega
                vn, ve = vn * c - ve * sn, vn * sn + ve * c
                an = -omega * ve
                ae = omega * vn
            # wanted ground velocity = feed-forward + saturated position correction (u)
            un = k * (rn - s.north)
            ue = k * (re - s.east)
            dun = k * (vn - gn)
            due = k * (ve - ge)
            uu = un * un + ue * ue
            cap = self._track_cap
            if uu > cap * cap:
                norm = math.sqrt(uu)
                if not copter:  # far off, the reference's position matters more than its motion
                    far = norm / (k * self._far)
                    if far > 1.0:
                        cap *= far if far < _FAR_CAP_GAIN else _FAR_CAP_GAIN
                f = cap / norm if norm > cap else 1.0
                proj = (un * dun + ue * due) / uu
                dun = f * (dun - un * proj)
                due = f * (due - ue * proj)
                un *= f
                ue *= f
            dn = vn + un
            de = ve + ue
            m2 = dn * dn + de * de
            if copter:
                air_n = dn - wn
                air_e = de - we
                acc_n = an + dun
                acc_e = ae + due
            else:
                vcmd = self._track_speed
                if m2 > 1e-12:
                    chi = math.atan2(de, dn)
                    chi_rate = (dn * (ae + due) - de * (an + dun)) / m2
                else:
                    steer = False
        elif mode == _M_LOITER:
            # Vector field around the circle (Nelson et al. 2007): tangent on it, 45 deg
            # inward one capture length outside; its derivative along the motion is fed
            # forward. A plane further out than ``_CAPTURE_EASE`` capture lengths flies
            # straight at the centre, as ArduPlane's L1 does (``update_loiter``: its
            # capture law holds while ``xtrackErrCirc * Kx`` outweighs ``V * Kv``, that
            # is beyond ``V * Kv / Kx``, one L1 distance), and the field is eased into
            # that line in between, its slope kept at both ends. (The field alone still
            # pointed 13 deg off the centre of a straight leg's carrot, 600 m ahead: the
            # mock's planes drifted 26 m off their legs in the median, SITL's 2.4 m.)
            rn = s.north - self._pn
            re = s.east - self._pe
            d2 = rn * rn + re * re
            if d2 < 1e-6:  # at the centre: any way out will do
                rn = cy * 1e-3
                re = sy * 1e-3
                d2 = 1e-6
            d = math.sqrt(d2)
            sign = self._sign
            radius = self._radius
            if self._lag2:  # the navigation controller's overshoot: R + (V T)^2 / R
                radius += self._lag2 * v0 * v0 / radius
            capture = max(self.params.min_turn_radius, _L1_S * v0)
            kc = _LOITER_SHARPNESS / (radius if radius < capture else capture)
            off = d - radius
            if copter or off <= 0.0:
                x = kc * off
                inward = math.atan(x)
                slope = kc / (1.0 + x * x)
            elif off < _CAPTURE_EASE * capture:  # (L1's circle mode, eased into its line in)
                x = kc * off
                u = off / (_CAPTURE_EASE * capture)
                w = u * u * (3.0 - 2.0 * u)  # (smoothstep: the field's slope kept at both ends)
                field = math.atan(x)
                inward = field + (_HALF_PI - field) * w
                slope = kc / (1.0 + x * x) * (1.0 - w) + (_HALF_PI - field) * 6.0 * u * (
                    1.0 - u
                ) / (_CAPTURE_EASE * capture)
            else:  # L1's capture: straight at the centre
                inward = _HALF_PI
                slope = 0.0
            chi = math.atan2(re, rn) + sign * (_HALF_PI + inward)
            chi_rate = (rn * ge - re * gn) / d2 + sign * slope * (rn * gn + re * ge) / d
            if copter:
                c = vcmd * math.cos(chi)
                sn = vcmd * math.sin(chi)
                air_n = c - wn
                air_e = sn - we
                acc_n = -sn * chi_rate
                acc_e = c * chi_rate
        elif copter:
            # Fly-to and hover (also takeoff and landing): brake so as to stop on the point.
            en = self._pn - s.north
            ee = self._pe - s.east
            dist = math.sqrt(en * en + ee * ee)
            if dist > _HOLD_DEADBAND:
                want = min(vcmd, _K_HOLD * dist, math.sqrt(self.params.max_accel * dist)) / dist
                air_n = want * en - wn
                air_e = want * ee - we
            else:
                air_n = -wn
                air_e = -we
        else:  # plane flying straight: takeoff climb-out, glide to land, nothing to steer by
            steer = False
            if mode == _M_GROUND:
                vcmd = self._vmin

        # --- yaw-rate command: course feed-forward + heading feedback
        snap = False
        if copter:
            vcmd = math.sqrt(air_n * air_n + air_e * air_e)
            rate = 0.0
            if steer and vcmd > 1e-3:
                chi = math.atan2(air_e, air_n)
                chi_rate = (air_n * acc_e - air_e * acc_n) / (vcmd * vcmd)
                if v0 == 0.0:
                    snap = True  # at rest the velocity can start out in any direction
                else:
                    err = _wrap(chi - yaw)
                    if err > _COPTER_STOP_ANGLE or err < -_COPTER_STOP_ANGLE:
                        vcmd = 0.0  # brake (turning meanwhile), then start out the right way
                    rate = chi_rate + _K_HEADING * err
        elif steer:
            if wn != 0.0 or we != 0.0:
                # Wind triangle: the heading whose air velocity plus wind has course chi,
                # and its rate: course rate * ground speed / along-course airspeed.
                c = math.cos(chi)
                sn = math.sin(chi)
                cross = (c * we - sn * wn) / v0
                if cross >= 1.0 or cross <= -1.0:
                    chi -= math.copysign(_HALF_PI, cross)
                else:
                    along = v0 * math.sqrt(1.0 - cross * cross)
                    chi_rate *= (along + c * wn + sn * we) / along
                    chi -= math.asin(cross)
            rate = chi_rate + _K_HEADING * _wrap(chi - yaw)
        else:
            rate = 0.0
        if vcmd < self._vmin:
            vcmd = self._vmin
        elif vcmd > self._vmax:
            vcmd = self._vmax

        # --- speed (acceleration-limited), then the turn-rate bound
        dv = self.params.max_accel * dt
        if vcmd > v0 + dv:
            v1 = v0 + dv
        elif vcmd < v0 - dv:
            v1 = v0 - dv
            if v1 < 1e-9:
                v1 = 0.0  # no rounding dust: "at rest" means exactly 0
        else:
            v1 = vcmd
        bound = (v1 if v1 < v0 else v0) * self._inv_rmin
        if rate > bound:
            rate = bound
        elif rate < -bound:
            rate = -bound
        if snap:
            yaw = chi
            cy = math.cos(yaw)
            sy = math.sin(yaw)
            rate = 0.0

        # --- exact arc integration at constant turn rate and mean speed
        # (the chord of the arc, along the mean heading: no cancellation for small turns)
        vm = 0.5 * (v0 + v1)
        turn = rate * dt
        if -1e-9 < turn < 1e-9:
            chord = vm * dt
        else:
            sh = math.sin(0.5 * turn)
            ch = math.cos(0.5 * turn)
            chord = 2.0 * vm * sh / rate
            cy, sy = cy * ch - sy * sh, sy * ch + cy * sh
        s.north += chord * cy + wn * dt
        s.east += chord * sy + we * dt
        yaw += turn
        s.yaw = yaw if -_PI < yaw <= _PI else _wrap(yaw)
        s.speed = v1
        s.yaw_rate = rate

        self._step_altitude(dt)
        if mode == _M_TAKEOFF:
            self._check_takeoff()

    def _step_altitude(self, dt: float) -> None:
        s = self.state
        d0 = s.down
        limit = self.params.max_climb_rate
        if self._alt_rate:
            d1 = d0 - self._climb_cmd * dt
            self._target_down = d1 = min(d1, self._ground_down)
        else:
            target = self._target_down
            err = d0 - target  # > 0: below the target, climb
            if err == 0.0:
                s.climb_rate = 0.0
                return
            tc = self.params.altitude_time_constant
            edge = limit * tc  # beyond this error the climb-rate limit binds
            if err > edge or err < -edge:
                sat_time = ((err if err > 0.0 else -err) - edge) / limit
                if sat_time >= dt:
                    d1 = d0 - limit * dt if err > 0.0 else d0 + limit * dt
                else:
                    rest = edge if err > 0.0 else -edge
                    d1 = target + rest * math.exp((sat_time - dt) / tc)
            else:
                d1 = target + err * math.exp(-dt / tc)
                if -1e-9 < d1 - target < 1e-9:
                    d1 = target
        d1 = min(d1, self._ground_down)
        s.down = d1
        s.climb_rate = (d0 - d1) / dt
        if self._mode == _M_GROUND and d1 >= self._ground_down - _LANDED_TOL:
            s.down = self._ground_down  # touchdown: the roll-out is not modelled
            s.airborne = False
            s.speed = s.climb_rate = 0.0

    def _check_takeoff(self) -> None:
        s = self.state
        climb = self._ground_down - self._target_down
        tol = max(_TAKEOFF_TOLERANCE * climb, _TAKEOFF_MIN_TOL)
        if abs(s.down - self._target_down) > tol:
            return
        self._takeoff_complete = True
        if self._copter:
            self._set_hold(self._pn, self._pe)
        else:
            # Enter a clockwise circle tangent to the current track: no kink at the switch.
            r = self.params.min_turn_radius
            self._set_circle(
                s.north - r * math.sin(s.yaw), s.east + r * math.cos(s.yaw), r, clockwise=True
            )
