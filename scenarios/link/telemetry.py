"""The vehicle's telemetry over MAVLink: encoders from the simulation, decoders into the estimator's messages.

Encoders turn the simulated truth (the autopilot's estimate stands in for it) and the geofence unit's sensor
outputs (:mod:`geofence.estimation.measurements`: what the unit's own sensors would measure) into pymavlink
message objects; decoders turn received messages back into :class:`GpsFix`, :class:`AirData`,
:class:`AttitudeSample` and the autopilot's :class:`VehicleState`. Each field is written once here.

==================  ======================================================================================
message             fields (quantisation of the decoded value)
==================  ======================================================================================
ATTITUDE            the AHRS roll, pitch, yaw in rad (float32, about 1e-7 rad); yaw sent in [-pi, pi),
                    decoded to [0, 2 pi); time_boot_ms = round(t_s * 1000). The tick's frame marker.
GLOBAL_POSITION_INT lat/lon 1e-7 deg (half an LSB: 5e-8 deg), alt mm MSL, relative_alt mm above home (the
                    frame origin), vx/vy/vz cm/s NED (0.5 cm/s), hdg cdeg.
GPS_RAW_INT         one per delivered fix; time_usec = its time of validity; fix_type 3 (0 without a fix);
                    lat/lon 1e-7 deg, alt = alt_ellipsoid mm (the geoid separation is taken as 0, as the
                    simulated receiver does); vel cm/s and cog cdeg (the horizontal velocity within
                    0.5 cm/s + vel * 0.005 deg in rad); eph/epv cm and h_acc/v_acc mm from the receiver's
                    accuracy. No vertical velocity exists in the message: the decoder takes it from the caller
                    (the newest GLOBAL_POSITION_INT ``vz``).
SCALED_PRESSURE     press_abs hPa = ISA pressure of the barometer's altitude (float32: under 1 mm of
                    altitude), press_diff hPa = the pitot's dynamic pressure at sea-level density, temperature
                    cdegC of the ISA at that altitude.
VFR_HUD             airspeed = the pitot's reading (the simulated pitot reads indicated airspeed, as
                    AirData carries it; 0 without a pitot), groundspeed, heading deg, alt, climb.
WIND                the wind the autopilot estimates: direction it blows FROM, deg; speed m/s; speed_z.
HEARTBEAT           type quadrotor / fixed wing, autopilot ArduPilot / PX4, system_status active or poweroff.
==================  ======================================================================================

ISA (troposphere, below 11 km): ``p = P0 * (1 - L*h/T0) ** (g0*M/(R*L))`` with P0 = 101325 Pa, T0 = 288.15 K,
L = 0.0065 K/m and exponent 5.25588 (g0 = 9.80665 m/s2, M = 0.0289644 kg/mol, R = 8.31446 J/(mol K)); its
inverse gives the altitude. ``L/T0 = 2.25577e-5 /m`` is the constant of
:func:`geofence.physics.dynamics.isa_density_ratio` (the density exponent is the pressure exponent minus one).
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

from pymavlink import mavutil

from geofence.estimation.measurements import AirData, AttitudeSample, GpsFix
from geofence.geometry.geodesy import LocalFrame
from geofence.interface import PlatformKind, VehicleState
from geofence.physics.control_laws import wrap_pi
from scenarios.link.sticks import Autopilot

mav: Any = mavutil.mavlink

ISA_P0_PA = 101325.0
ISA_T0_K = 288.15
ISA_LAPSE_K_PER_M = 0.0065
ISA_PRESSURE_EXPONENT = 5.25588
ISA_RHO0_KG_M3 = 1.225
_TWO_PI = 2.0 * math.pi
UINT16_UNKNOWN = 65535

GF_MARGIN_NAME = "GF_MARGIN"
"""NAMED_VALUE_FLOAT name of the companion's activation margin (m): the lock-step reply to each ATTITUDE."""
GF_MODE_NAME = "GF_MODE"
"""NAMED_VALUE_INT name of the companion's mode number."""
GF_MARGIN_MAX_M = 1e6
"""The largest margin sent (an infinite margin is sent as this)."""

GPS_FIX_TYPE_3D = 3
GPS_FIX_TYPE_NONE = 0


class TelemetryRates(NamedTuple):
    """Message rates, Hz (ArduPilot SRn_* class rates for a companion link). GPS_RAW_INT: one per delivered fix."""

    attitude_hz: float = 50.0
    global_position_int_hz: float = 50.0
    scaled_pressure_hz: float = 10.0
    vfr_hud_hz: float = 10.0
    wind_hz: float = 2.0
    heartbeat_hz: float = 1.0


def isa_pressure_pa(alt_m: float) -> float:
    """ISA static pressure at ``alt_m`` m AMSL (troposphere formula, see the module docstring), Pa."""
    return ISA_P0_PA * (1.0 - ISA_LAPSE_K_PER_M / ISA_T0_K * alt_m) ** ISA_PRESSURE_EXPONENT


def isa_altitude_m(pressure_pa: float) -> float:
    """The ISA pressure altitude of ``pressure_pa``, m AMSL (the inverse of :func:`isa_pressure_pa`)."""
    return ISA_T0_K / ISA_LAPSE_K_PER_M * (1.0 - (pressure_pa / ISA_P0_PA) ** (1.0 / ISA_PRESSURE_EXPONENT))


def time_boot_ms(t_s: float) -> int:
    """A simulated time as MAVLink ``time_boot_ms``."""
    return int(round(t_s * 1000.0))


def _e7(deg: float) -> int:
    return int(round(deg * 1e7))


def heading_rad(a: float) -> float:
    """An angle as a heading in [0, 2 pi) (``%`` alone gives 2 pi for a tiny negative angle)."""
    h = a % _TWO_PI
    return 0.0 if h >= _TWO_PI else h


def _cdeg(angle_rad: float) -> int:
    return int(round(math.degrees(angle_rad % _TWO_PI) * 100.0)) % 36000


def heartbeat(kind: PlatformKind, autopilot: Autopilot, *, powering_off: bool = False) -> Any:
    """The vehicle's HEARTBEAT (armed, custom mode 0; system_status ACTIVE, or POWEROFF at the flight's end)."""
    return mav.MAVLink_heartbeat_message(
        mav.MAV_TYPE_QUADROTOR if kind is PlatformKind.MULTIROTOR else mav.MAV_TYPE_FIXED_WING,
        mav.MAV_AUTOPILOT_ARDUPILOTMEGA if autopilot is Autopilot.ARDUPILOT else mav.MAV_AUTOPILOT_PX4,
        mav.MAV_MODE_FLAG_SAFETY_ARMED | mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
        0,
        mav.MAV_STATE_POWEROFF if powering_off else mav.MAV_STATE_ACTIVE,
        3,
    )


def attitude(att: AttitudeSample, rates_radps: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> Any:
    """ATTITUDE of an AHRS sample (the tick's frame marker)."""
    return mav.MAVLink_attitude_message(time_boot_ms(att.t_s), att.roll_rad, att.pitch_rad, wrap_pi(att.yaw_rad), *rates_radps)


def attitude_sample(msg: Any) -> AttitudeSample:
    """The AHRS sample an ATTITUDE carries (yaw in [0, 2 pi))."""
    return AttitudeSample(msg.time_boot_ms / 1000.0, float(msg.roll), float(msg.pitch), heading_rad(float(msg.yaw)))


def global_position_int(state: VehicleState, home_alt_m: float) -> Any:
    """GLOBAL_POSITION_INT of the autopilot's state (``relative_alt`` above ``home_alt_m``)."""
    return mav.MAVLink_global_position_int_message(
        time_boot_ms(state.t_s), _e7(state.lat_deg), _e7(state.lon_deg), int(round(state.alt_m * 1000.0)),
        int(round((state.alt_m - home_alt_m) * 1000.0)), int(round(state.v_north_mps * 100.0)),
        int(round(state.v_east_mps * 100.0)), int(round(-state.v_up_mps * 100.0)), _cdeg(state.yaw_rad),
    )  # fmt: skip


def vehicle_state(gpi: Any, att: Any | None, frame: LocalFrame) -> VehicleState:
    """The autopilot's state from a GLOBAL_POSITION_INT (and the ATTITUDE beside it, if any), ENU about ``frame``.

    ``agl_m`` is ``relative_alt`` (home is the frame origin, on the ground); the attitude is 0 without ``att``.
    """
    lat, lon, alt = gpi.lat * 1e-7, gpi.lon * 1e-7, gpi.alt / 1000.0
    e, n, u = frame.to_enu(lat, lon, alt)
    roll, pitch, yaw = (0.0, 0.0, 0.0) if att is None else attitude_sample(att)[1:]
    return VehicleState(
        t_s=gpi.time_boot_ms / 1000.0, lat_deg=lat, lon_deg=lon, alt_m=alt, east_m=e, north_m=n, up_m=u,
        agl_m=gpi.relative_alt / 1000.0, v_east_mps=gpi.vy / 100.0, v_north_mps=gpi.vx / 100.0,
        v_up_mps=-gpi.vz / 100.0, roll_rad=roll, pitch_rad=pitch, yaw_rad=yaw,
    )  # fmt: skip


def _accuracy(m: float, scale: float, top: int) -> int:
    return top if not math.isfinite(m) else min(top - 1, max(0, int(round(m * scale))))


def gps_raw_int(fix: GpsFix) -> Any:
    """GPS_RAW_INT of one delivered fix (time_usec = its time of validity; fix_type 0 and zeros without a fix)."""
    t_us = int(round(fix.t_s * 1e6))
    if not fix.valid:
        return mav.MAVLink_gps_raw_int_message(
            t_us, GPS_FIX_TYPE_NONE, 0, 0, 0, UINT16_UNKNOWN, UINT16_UNKNOWN, UINT16_UNKNOWN, UINT16_UNKNOWN, 0
        )
    speed = math.hypot(fix.v_east_mps, fix.v_north_mps)
    cog = _cdeg(math.atan2(fix.v_east_mps, fix.v_north_mps)) if speed > 0.0 else 0
    alt_mm = int(round(fix.alt_m * 1000.0))
    h, v = fix.horizontal_accuracy_m, fix.vertical_accuracy_m
    return mav.MAVLink_gps_raw_int_message(
        t_us, GPS_FIX_TYPE_3D, _e7(fix.lat_deg), _e7(fix.lon_deg), alt_mm, _accuracy(h, 100.0, UINT16_UNKNOWN),
        _accuracy(v, 100.0, UINT16_UNKNOWN), min(int(round(speed * 100.0)), UINT16_UNKNOWN - 1), cog, 12,
        alt_mm, _accuracy(h, 1000.0, 2**32 - 1), _accuracy(v, 1000.0, 2**32 - 1),
    )  # fmt: skip


def _decoded_accuracy(acc_mm: int, ep_cm: int) -> float:
    if acc_mm > 0:
        return acc_mm / 1000.0
    return math.inf if ep_cm == UINT16_UNKNOWN else ep_cm / 100.0


def gps_fix(msg: Any, v_up_mps: float) -> GpsFix:
    """The fix a GPS_RAW_INT carries; ``v_up_mps`` from elsewhere (GPS_RAW_INT has no vertical velocity).

    Without a 3-D fix (fix_type < 3) the fix is invalid: NaN fields, infinite accuracies.
    """
    t_s = msg.time_usec / 1e6
    if msg.fix_type < GPS_FIX_TYPE_3D:
        nan = math.nan
        return GpsFix(t_s, nan, nan, nan, nan, nan, nan, math.inf, math.inf, False)
    speed = msg.vel / 100.0 if msg.vel != UINT16_UNKNOWN else 0.0
    cog = math.radians(msg.cog / 100.0) if msg.cog != UINT16_UNKNOWN else 0.0
    return GpsFix(
        t_s, msg.lat * 1e-7, msg.lon * 1e-7, msg.alt / 1000.0, speed * math.sin(cog), speed * math.cos(cog), v_up_mps,
        _decoded_accuracy(msg.h_acc, msg.eph), _decoded_accuracy(msg.v_acc, msg.epv), True,
    )  # fmt: skip


def scaled_pressure(air: AirData) -> Any:
    """SCALED_PRESSURE of an air-data sample: the barometer's altitude as ISA pressure, the pitot's dynamic pressure."""
    t_k = ISA_T0_K - ISA_LAPSE_K_PER_M * air.baro_alt_m
    ias = air.airspeed_mps if air.airspeed_mps is not None and math.isfinite(air.airspeed_mps) else 0.0
    q_hpa = 0.5 * ISA_RHO0_KG_M3 * ias * ias / 100.0
    return mav.MAVLink_scaled_pressure_message(
        time_boot_ms(air.t_s), isa_pressure_pa(air.baro_alt_m) / 100.0, q_hpa, int(round((t_k - 273.15) * 100.0))
    )


def vfr_hud(air: AirData, state: VehicleState, throttle_pct: int = 0) -> Any:
    """VFR_HUD: the pitot's airspeed (0 without one), the autopilot's ground speed, heading, altitude and climb."""
    ias = air.airspeed_mps if air.airspeed_mps is not None and math.isfinite(air.airspeed_mps) else 0.0
    heading = int(round(math.degrees(state.yaw_rad % _TWO_PI))) % 360
    return mav.MAVLink_vfr_hud_message(ias, state.ground_speed_mps, heading, throttle_pct, state.alt_m, state.v_up_mps)


def air_data(pressure: Any, hud: Any | None, has_pitot: bool) -> AirData:
    """The air-data sample of a SCALED_PRESSURE (and the VFR_HUD beside it); airspeed None without a pitot."""
    airspeed = float(hud.airspeed) if has_pitot and hud is not None else None
    return AirData(pressure.time_boot_ms / 1000.0, airspeed, isa_altitude_m(pressure.press_abs * 100.0))


def wind(wind_enu_mps: tuple[float, float, float]) -> Any:
    """WIND (ardupilotmega) of a wind vector (east, north, up) blowing TOWARD, m/s."""
    we, wn, wu = wind_enu_mps
    return mav.MAVLink_wind_message(math.degrees(math.atan2(-we, -wn)) % 360.0, math.hypot(we, wn), wu)


def wind_enu(msg: Any) -> tuple[float, float, float]:
    """The wind vector (east, north, up) toward which it blows, m/s, of a WIND message."""
    d = math.radians(msg.direction)
    return -msg.speed * math.sin(d), -msg.speed * math.cos(d), float(msg.speed_z)


def gf_margin(t_boot_ms: int, margin_m: float) -> Any:
    """The companion's lock-step reply: NAMED_VALUE_FLOAT GF_MARGIN = the margin clipped to +-1e6 m for the
    ATTITUDE of ``t_boot_ms`` (NaN, no margin known, is sent as -1e6)."""
    value = -GF_MARGIN_MAX_M if math.isnan(margin_m) else min(max(margin_m, -GF_MARGIN_MAX_M), GF_MARGIN_MAX_M)
    return mav.MAVLink_named_value_float_message(t_boot_ms, GF_MARGIN_NAME.encode(), value)


def named_value_name(msg: Any) -> str:
    """A NAMED_VALUE_FLOAT / _INT's name as text (pymavlink gives str or bytes, NUL-padded)."""
    name = msg.name
    if isinstance(name, bytes):
        name = name.decode("ascii", "replace")
    return name.rstrip("\x00")
