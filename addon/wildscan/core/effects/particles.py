"""The physics of weather (numpy only): what fog, rain, dust and snow do to a 905 nm pulse,
each from a published model. core/effects/weather.py turns it into hits; docs/weather.md
has the derivations and the bench against these curves.

Two things happen to a beam in weather:

  extinction   particles far smaller than the beam (fog droplets, dust grains) dim the
               pulse on its way out and back: transmission exp(-2 alpha r) (Beer-Lambert).
  events       along the beam, at a rate lambda(r) per metre (a Poisson process), the beam
               meets something that ends it before the surface: a raindrop or a snowflake
               in its way (alpha counted by the drops themselves, so rain and snow add no
               extinction), or a pulse cell of fog or dust whose backscatter the receiver
               detects. An event whose return is strong enough is an echo (a point of class
               `particle`); a drop too far to be seen still takes the beam (a lost return).

The detection budget. The UTM-30LX-EW detects a white Kent sheet (reflectance RHO_REF) to
30 m in the dark [spec, the device file's max_dark_m], R_DET. A target of reflectance rho
at range r through extinction alpha is detected when

    (rho / RHO_REF) * (R_DET / r)^2 * exp(-2 alpha r) >= 1

the lidar range equation for an extended Lambertian target (received power ~ rho T^2 / r^2;
Goodin et al., "Predicting the Influence of Rain on LIDAR in ADAS", Electronics 8(1) 89,
2019, eq. 1-2, whose reduced maximum range this is). Surfaces keep the reference budget
(the paper model returns every class to max range in clear air, so weather only takes the
transmission off it): a surface beyond R_max(alpha), where R e^(alpha R) = R_DET, is lost.
"""

from __future__ import annotations

import math

import numpy as np

from .. import detmath as dm

RHO_REF = 0.9  # white Kent sheet, the spec's reference target (a white paper: ~90 % diffuse)
WAVELENGTH_NM = 905.0  # the UTM-30LX-EW's laser [spec]
KOSCHMIEDER = 3.912  # -ln(0.02): visibility is where a black target's contrast falls to 2 %

# Water at 905 nm: n = 1.328 (Hale & Querry, Appl. Opt. 12(3) 555, 1973). A drop is a
# specular sphere: its backscatter cross-section is R_F * pi a^2 (geometric optics), R_F the
# Fresnel reflectance at normal incidence; a Lambertian disc of the same area has 4 rho pi a^2,
# so the drop looks like a diffuse target of reflectance R_F / 4.
WATER_INDEX = 1.328
FRESNEL_WATER = ((WATER_INDEX - 1) / (WATER_INDEX + 1)) ** 2
RHO_DROP = FRESNEL_WATER / 4
# Snow is the brightest natural diffuse reflector in the near infrared: ~0.9 at 900 nm
# (Warren, "Optical properties of snow", Rev. Geophys. 20(1) 67, 1982, fig. 11); a flake is
# taken as a diffuse target of that reflectance.
RHO_FLAKE = 0.9

# Fog's backscatter coefficient beta = 0.046 / MOR (Rasshofer, Spies & Spies, "Influences of
# weather phenomena on automotive laser radar systems", Adv. Radio Sci. 9, 49, 2011; used by
# Hahner et al., "Fog Simulation on Real LiDAR Point Clouds", ICCV 2021), MOR the
# meteorological optical range (5 % contrast): MOR = -ln(0.05) / alpha.
FOG_BETA_MOR = 0.046
MOR_CONTRAST = 2.995732273553991  # -ln(0.05)
# Mineral dust's lidar ratio (extinction / backscatter): 55 sr (Saharan dust, Tesche et al.,
# "Vertically resolved separation of dust and smoke", J. Geophys. Res. 114, D13202, 2009).
DUST_LIDAR_RATIO = 55.0

# Marshall & Palmer, "The distribution of raindrops with size", J. Meteorol. 5, 165 (1948):
# N(D) = N0 exp(-Lambda D), N0 = 8000 m^-3 mm^-1, Lambda = 4.1 R^-0.21 mm^-1 (R in mm/h).
MP_N0 = 8000.0
MP_LAMBDA = (4.1, -0.21)
# Gunn & Marshall, "The distribution with size of aggregate snowflakes", J. Meteorol. 15,
# 452 (1958): N0 = 3800 R^-0.87 m^-3 mm^-1, Lambda = 2.55 R^-0.48 mm^-1 (R: melted, mm/h).
GM_N0 = (3800.0, -0.87)
GM_LAMBDA = (2.55, -0.48)
# Chepil & Woodruff, "Sedimentary characteristics of dust storms: II. Visibility and dust
# concentration", Am. J. Sci. 255, 104 (1957): C = 56 V^-1.25 (C in mg/m^3, V in km).
CW_COEFF, CW_EXPONENT = 56.0, -1.25


def power(base: float, exponent: float) -> float:
    """base ** exponent through detmath (the same bits on every CPU)."""
    return dm.exp(exponent * dm.log(base))


def kim_q(visibility_km: float) -> float:
    """Kim, McArthur & Korevaar, "Comparison of laser beam propagation at 785 nm and 1550 nm
    in fog and haze", Proc. SPIE 4214, 26 (2001): the size-distribution exponent q of
    alpha = (3.912 / V) (lambda / 550 nm)^-q. Fog (V < 0.5 km) scatters all wavelengths alike."""
    v = visibility_km
    if v > 50:
        return 1.6
    if v > 6:
        return 1.3
    if v > 1:
        return 0.16 * v + 0.34
    if v > 0.5:
        return v - 0.5
    return 0.0


def fog_extinction(visibility_m: float) -> float:
    """alpha (1/m) of fog or haze of visibility V at 905 nm: Koschmieder with Kim's correction."""
    q = kim_q(visibility_m / 1000.0)
    return KOSCHMIEDER / visibility_m * power(WAVELENGTH_NM / 550.0, -q)


def fog_backscatter(alpha: float) -> float:
    """beta (1/(m sr)) of fog of extinction alpha (Rasshofer et al. 2011)."""
    return FOG_BETA_MOR * alpha / MOR_CONTRAST


def dust_visibility(concentration_g_m3: float) -> float:
    """Visibility (m) in dust of this mass concentration (Chepil & Woodruff 1957)."""
    return 1000.0 * power(concentration_g_m3 * 1000.0 / CW_COEFF, 1.0 / CW_EXPONENT)


def dust_extinction(concentration_g_m3: float) -> float:
    """alpha (1/m): Koschmieder on Chepil & Woodruff's visibility; grains of tens of microns
    scatter 905 nm like visible light (geometric regime: no wavelength correction)."""
    return KOSCHMIEDER / dust_visibility(concentration_g_m3)


def dust_backscatter(alpha: float) -> float:
    return alpha / DUST_LIDAR_RATIO


def exponential_psd(kind: str, rate_mm_h: float) -> tuple[float, float]:
    """(N0 in m^-3 mm^-1, Lambda in mm^-1) of rain (Marshall-Palmer) or snow (Gunn-Marshall)."""
    if kind == "rain":
        return MP_N0, MP_LAMBDA[0] * power(rate_mm_h, MP_LAMBDA[1])
    return GM_N0[0] * power(rate_mm_h, GM_N0[1]), GM_LAMBDA[0] * power(rate_mm_h, GM_LAMBDA[1])


def hit_rate(kind: str, rate_mm_h: float) -> float:
    """Drops (or flakes) a thin ray meets per metre: their geometric cross-section per volume,
    integral of (pi D^2 / 4) N0 exp(-Lambda D) dD = pi N0 / (2 Lambda^3) (mm^2 m^-3 = 1e-6 / m).
    Twice this is the published extinction (extinction efficiency 2, large drops)."""
    n0, lam = exponential_psd(kind, rate_mm_h)
    return math.pi * n0 / (2.0 * lam**3) * 1e-6


def max_range(alpha: float, detection_range: float) -> float:
    """R_max: where R e^(alpha R) = R_DET (the reference target's budget used up); R_DET in clear air."""
    if alpha <= 0:
        return detection_range
    lo, hi = 0.0, detection_range
    for _ in range(64):  # bisection: exact comparisons only, the same R on every CPU
        mid = 0.5 * (lo + hi)
        if mid * dm.exp(alpha * mid) > detection_range:
            hi = mid
        else:
            lo = mid
    return lo


def detectable_reflectance(r: np.ndarray, alpha: float, detection_range: float) -> np.ndarray:
    """The least reflectance detected at range r through extinction alpha (the budget above)."""
    r = np.asarray(r, dtype=np.float64)
    return RHO_REF * (r / detection_range) ** 2 * dm.exp(2.0 * alpha * r)


def overlap(r: np.ndarray, min_range: float) -> np.ndarray:
    """The share of the beam the receiver sees at range r: 0 at the minimum range, rising
    linearly to 1 at OVERLAP_FULL_M. Every scanner has such a near field (its emitter and
    receiver are side by side); the spec gives none, so this is an assumption, and it only
    shapes how near the sensor fog and dust echo (docs/weather.md)."""
    r = np.asarray(r, dtype=np.float64)
    return np.clip((r - min_range) / (OVERLAP_FULL_M - min_range), 0.0, 1.0)


OVERLAP_FULL_M = 1.0


def volume_rate(
    r: np.ndarray, beta: float, alpha: float, detection_range: float, cell: float, min_range: float
) -> np.ndarray:
    """Backscatter events per metre at range r in fog or dust. One pulse cell (depth `cell`,
    c tau / 2) backscatters like a diffuse target of reflectance pi beta cell (a Lambertian
    target sends rho / pi per steradian), of which the receiver sees the overlap's share; its
    return from many random droplets is fully developed speckle, exponentially distributed
    (Goodman, "Speckle Phenomena in Optics", 2007, ch. 3), so it crosses the threshold with
    probability exp(-rho_min / (overlap pi beta cell)): that probability per cell depth is
    the rate."""
    seen = overlap(r, min_range) * (math.pi * beta * cell)
    rho_min = detectable_reflectance(r, alpha, detection_range)
    ratio = np.where(seen > 0, rho_min / np.where(seen > 0, seen, 1.0), np.inf)
    return np.where(np.isfinite(ratio), dm.exp(-np.minimum(ratio, 700.0)), 0.0) / cell
