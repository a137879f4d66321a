"""Daylight: where the sun is, how bright the sky is in each direction, and the tables the light
tracer needs to let sky and sun in through glazing.

- Sun position: the NOAA solar calculator's equations (after J. Meeus, *Astronomical
  Algorithms*, 1991, ch. 25 and 28): declination and equation of time from the sun's mean
  anomaly and longitude, then the hour angle, zenith and azimuth, with the NOAA approximation
  of atmospheric refraction. About 0.01° from NREL's SPA (Reda & Andreas, NREL/TP-560-34302,
  2004) between 1901 and 2099; the tests check the SPA's worked example.
- Skies (ISO 15469:2004 / CIE S 011/E:2003, "Spatial distribution of daylight – CIE standard
  general sky"): the CIE standard overcast sky L(Z) = Lz (1 + 2 cos Z) / 3 (Moon & Spencer
  1942, CIE 1955), whose horizontal illuminance is E_h = 7π Lz / 9; and the CIE standard clear
  sky (type 12 of S 011: gradation a = −1, b = −0.32; indicatrix c = 10, d = −3, e = 0.45),
  L / Lz = f(χ) φ(Z) / (f(Z_s) φ(0)) with φ(Z) = 1 + a exp(b / cos Z) and
  f(χ) = 1 + c (exp(dχ) − exp(dπ/2)) + e cos²χ, χ the angle to the sun.
- Absolute levels: the sky is scaled so that its unobstructed horizontal illuminance is
  ``sky_horizontal_lx`` (default 10 000 lx for the overcast sky, a design value; the daylight
  factor does not depend on it); the sun's direct normal illuminance is ``sun_normal_lx``. For
  the clear sky both must be given (from measured or design data: sonolux does not guess
  turbidity).
- Ground: below the horizon a uniform Lambertian ground of reflectance ``ground_reflectance``
  lit by sky and sun: L_g = ρ_g E_global,h / π (the externally reflected component of the
  daylight factor, CIE 171:2006 §5.12 style with no obstructions).

Directions: z up; by default +y is north and +x east; the scene's ``north_deg`` turns north
counter-clockwise from +y (see :func:`sun_direction`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone

import numpy as np

OVERCAST_HORIZONTAL_LX = 10_000.0
#: CIE S 011 type 12, the CIE standard clear sky (low turbidity): a, b, c, d, e.
CLEAR_SKY_PARAMETERS = (-1.0, -0.32, 10.0, -3.0, 0.45)


@dataclass(frozen=True)
class SunPosition:
    zenith_deg: float  # refraction included
    azimuth_deg: float  # from north, clockwise (east = 90°)
    declination_deg: float
    equation_of_time_min: float

    @property
    def altitude_deg(self) -> float:
        return 90.0 - self.zenith_deg


def _julian_day(t: datetime) -> float:
    t = t.astimezone(timezone.utc)
    epoch = datetime(2000, 1, 1, 12, tzinfo=timezone.utc)
    return 2451545.0 + (t - epoch) / timedelta(days=1)


def sun_position(when: datetime, latitude_deg: float, longitude_deg: float) -> SunPosition:
    """The sun's apparent position at ``when`` (aware datetime) seen from latitude / longitude
    (degrees, north and east positive)."""
    jc = (_julian_day(when) - 2451545.0) / 36525.0
    l0 = (280.46646 + jc * (36000.76983 + jc * 0.0003032)) % 360
    m = 357.52911 + jc * (35999.05029 - 0.0001537 * jc)
    e = 0.016708634 - jc * (0.000042037 + 0.0000001267 * jc)
    mr = math.radians(m)
    c = (math.sin(mr) * (1.914602 - jc * (0.004817 + 0.000014 * jc))
         + math.sin(2 * mr) * (0.019993 - 0.000101 * jc) + math.sin(3 * mr) * 0.000289)
    omega = math.radians(125.04 - 1934.136 * jc)
    apparent = math.radians(l0 + c - 0.00569 - 0.00478 * math.sin(omega))
    eps0 = 23 + (26 + (21.448 - jc * (46.815 + jc * (0.00059 - jc * 0.001813))) / 60) / 60
    eps = math.radians(eps0 + 0.00256 * math.cos(omega))
    decl = math.asin(math.sin(eps) * math.sin(apparent))
    y = math.tan(eps / 2) ** 2
    l0r = math.radians(l0)
    eot = 4 * math.degrees(y * math.sin(2 * l0r) - 2 * e * math.sin(mr)
                           + 4 * e * y * math.sin(mr) * math.cos(2 * l0r)
                           - 0.5 * y * y * math.sin(4 * l0r) - 1.25 * e * e * math.sin(2 * mr))
    utc = when.astimezone(timezone.utc)
    minutes = utc.hour * 60 + utc.minute + utc.second / 60 + utc.microsecond / 6e7
    true_solar = (minutes + eot + 4 * longitude_deg) % 1440
    hour = math.radians(true_solar / 4 - 180)
    lat = math.radians(latitude_deg)
    cos_z = math.sin(lat) * math.sin(decl) + math.cos(lat) * math.cos(decl) * math.cos(hour)
    zenith = math.acos(max(-1.0, min(1.0, cos_z)))
    # Azimuth from north, clockwise.
    az = math.degrees(math.atan2(math.sin(hour),
                                 math.cos(hour) * math.sin(lat) - math.tan(decl) * math.cos(lat)))
    azimuth = (az + 180) % 360
    elevation = 90 - math.degrees(zenith)
    return SunPosition(90 - elevation - _refraction_deg(elevation), azimuth, math.degrees(decl), eot)


def _refraction_deg(elevation_deg: float) -> float:
    """NOAA's approximation of atmospheric refraction (degrees) at a true elevation."""
    h = elevation_deg
    if h > 85:
        return 0.0
    t = math.tan(math.radians(h))
    if h > 5:
        arcsec = 58.1 / t - 0.07 / t ** 3 + 0.000086 / t ** 5
    elif h > -0.575:
        arcsec = 1735 + h * (-518.2 + h * (103.4 + h * (-12.79 + h * 0.711)))
    else:
        arcsec = -20.772 / t
    return arcsec / 3600


def sun_direction(sun: SunPosition, north_deg: float = 0.0) -> np.ndarray:
    """Unit vector towards the sun in scene axes (z up). ``north_deg``: the azimuth of north in
    the scene, counter-clockwise from +y (0: +y is north, x is east)."""
    alt = math.radians(sun.altitude_deg)
    # Compass azimuth A (clockwise from north) to a scene angle: north is +y turned by north_deg.
    a = math.radians(sun.azimuth_deg - north_deg)
    return np.array([math.cos(alt) * math.sin(a), math.cos(alt) * math.cos(a), math.sin(alt)])


def overcast_relative(cos_z: np.ndarray) -> np.ndarray:
    """L / Lz of the CIE standard overcast sky at zenith-angle cosines ``cos_z``."""
    return (1 + 2 * np.asarray(cos_z, float)) / 3


def clear_relative(cos_z: np.ndarray, cos_chi: np.ndarray, sun_zenith_rad: float) -> np.ndarray:
    """L / Lz of the CIE standard clear sky (S 011 type 12) at zenith-angle cosines ``cos_z`` and
    cosines of the angle to the sun ``cos_chi``."""
    a, b, c, d, e = CLEAR_SKY_PARAMETERS
    cos_z = np.clip(np.asarray(cos_z, float), 1e-6, 1.0)
    chi = np.arccos(np.clip(cos_chi, -1, 1))

    def f(x: np.ndarray | float) -> np.ndarray:
        return 1 + c * (np.exp(d * np.asarray(x)) - math.exp(d * math.pi / 2)) + e * np.cos(x) ** 2

    def phi(cz: np.ndarray | float) -> np.ndarray:
        return 1 + a * np.exp(b / np.asarray(cz))

    return f(chi) * phi(cos_z) / (f(sun_zenith_rad) * phi(1.0))


@dataclass(frozen=True)
class Sky:
    """A sky as the tracer takes it: ``theta_rad`` float64[T] and ``phi_rad`` float64[K] grids of
    *travel* directions (θ from +z: light from the sky travels with θ > 90°), radiance
    ``values`` float64[K, T] in cd/m² (photometric), the sun's travel direction (unit, or None
    below the horizon) and normal illuminance (lx), and the horizontal illuminances."""

    kind: str
    theta_rad: np.ndarray
    phi_rad: np.ndarray
    values: np.ndarray
    sun_travel: np.ndarray | None
    sun_normal_lx: float
    sky_horizontal_lx: float
    ground_luminance_cd_m2: float


def _horizontal(relative: np.ndarray, theta: np.ndarray, phi: np.ndarray) -> float:
    """∫ L cos Z dω of a relative table over the sky hemisphere (travel θ > 90°), by the
    trapezoid rule in θ and φ."""
    cos_z = -np.cos(theta)
    integrand = np.where(theta > math.pi / 2, relative * cos_z * np.sin(theta), 0.0)
    if phi.size == 1:
        return float(2 * math.pi * np.trapezoid(integrand[0], theta))
    return float(np.trapezoid(np.trapezoid(integrand, theta, axis=1), phi))


def make_sky(kind: str, *, sky_horizontal_lx: float | None = None, sun: np.ndarray | None = None,
             sun_normal_lx: float = 0.0, ground_reflectance: float = 0.2,
             steps_deg: float = 1.0) -> Sky:
    """The tracer's table of ``kind`` "overcast" or "clear" (``sun``: unit vector towards it,
    needed for "clear"). The overcast sky has no sun."""
    theta = np.radians(np.arange(0.0, 180.0 + 1e-9, steps_deg))
    if kind == "overcast":
        phi = np.zeros(1)
        relative = np.where(theta > math.pi / 2, overcast_relative(-np.cos(theta)), 0.0)[None, :]
        e_h = OVERCAST_HORIZONTAL_LX if sky_horizontal_lx is None else sky_horizontal_lx
        sun_travel, sun_normal_lx = None, 0.0
    else:
        assert sun is not None and sky_horizontal_lx is not None
        phi = np.radians(np.arange(0.0, 360.0 + 1e-9, 2 * steps_deg))
        tt, pp = np.meshgrid(theta, phi)
        # The sky point a ray comes from is opposite to its travel direction.
        src = -np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], axis=-1)
        sun_zenith = math.acos(max(-1.0, min(1.0, float(sun[2]))))
        relative = np.where(tt > math.pi / 2,
                            clear_relative(src[..., 2], src @ sun, min(sun_zenith, math.pi / 2)),
                            0.0)
        e_h = sky_horizontal_lx
        sun_travel = -np.asarray(sun, float) if sun[2] > 0 else None
        if sun_travel is None:
            sun_normal_lx = 0.0
    # The overcast sky's horizontal illuminance is 7π Lz / 9 in closed form.
    lz = e_h / (7 * math.pi / 9 if kind == "overcast" else _horizontal(relative, theta, phi))
    global_h = e_h + (sun_normal_lx * float(-sun_travel[2]) if sun_travel is not None else 0.0)
    ground = ground_reflectance * global_h / math.pi
    values = np.where(theta[None, :] > math.pi / 2, lz * relative, ground)
    # θ exactly 90° belongs to both; the table interpolates across it.
    return Sky(kind, theta, phi, np.ascontiguousarray(values), sun_travel, float(sun_normal_lx),
               float(e_h), float(ground))
