"""HDR-FLIP of several test images against one reference (pure numpy, float32 as FLIP).

The same computation as NVIDIA's ``flip-evaluator`` (``FLIP.h`` of FLIP 1.6/1.7, its C++
path; Andersson et al. 2020 and 2021), step for step in float32 and in the same order of
operations, so that its error maps are ``flip_evaluator.evaluate(reference, test, "HDR",
...)``'s. What differs is the cost: the library evaluates one pair per call and redoes
the reference's half (tone mapping, colour transforms, filtering) at every exposure of
every call; here the reference and all the tests go through each exposure as one array.
``metrics.image.hdr_flip`` uses it; ``tests/metrics/test_flip.py`` holds it to the
library's maps.

Where it can differ from the library: the per-pixel powers. The library calls the C
library's ``powf`` (glibc's: within 0.82 ulp, not always correctly rounded); numpy's
float32 power is a vectorised approximation (a quarter of its results differ from glibc's
in the last bit), so the powers here are taken in float64 and rounded: the correctly
rounded float32 but where the float64 power falls within its own error of a float32
rounding midpoint (~1e-8 of cases). A pixel where the two round differently moves by a
float32 power's last bit; on sphere1 that is 0.03–0.2% of the pixels and moves a mean by
≤ 1.4e-10 of FLIP's [0, 1] (docs/history.md "Metrics stage speed"). With the C
library's ``powf`` the maps are bit-identical (the test says so).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

F = np.float32
GQC, GPC, GPT, GW, GQF = F(0.7), F(0.4), F(0.95), F(0.082), F(0.5)   # FLIPConstants
PI = F(3.14159265358979)
PI_SQ = PI * PI
# xGaussianConstants: (a1, b1, a2, b2) per channel Y, Cx, Cz
A1, B1 = (F(1.0), F(1.0), F(34.1)), (F(0.0047), F(0.0053), F(0.04))
A2, B2 = (F(0.0), F(0.0), F(13.5)), (F(1.0e-5), F(1.0e-5), F(0.025))
ILLUMINANT = (F(0.950428545), F(1.0), F(1.088900371))
INV_ILLUMINANT = (F(1.052156925), F(1.0), F(0.918357670))
# ACES with FLIP's 0.6 pre-exposure cancellation (ToneMappingCoefficients[1])
ACES = (F(0.6) * F(0.6) * F(2.51), F(0.6) * F(0.03), F(0.0), F(0.6) * F(0.6) * F(2.43), F(0.6) * F(0.59), F(0.14))
RGB_TO_XYZ = ((F(10135552.0) / F(24577794.0), F(8788810.0) / F(24577794.0), F(4435075.0) / F(24577794.0)),
              (F(2613072.0) / F(12288897.0), F(8788810.0) / F(12288897.0), F(887015.0) / F(12288897.0)),
              (F(1425312.0) / F(73733382.0), F(8788810.0) / F(73733382.0), F(70074185.0) / F(73733382.0)))
XYZ_TO_RGB = ((F(3.241003275), F(-1.537398934), F(-0.498615861)),
              (F(-0.969224334), F(1.875930071), F(0.041554224)),
              (F(0.055639423), F(-0.204011202), F(1.057148933)))



def _c_library():
    """The C library's float functions (the library's ``expf`` and ``powf``) where it
    can be loaded, else None (float64 then rounded: the same but in rare last bits)."""
    try:
        libm = ctypes.CDLL(ctypes.util.find_library("m") or "libm.so.6")
        for name, args in (("expf", 1), ("powf", 2)):
            getattr(libm, name).restype = ctypes.c_float
            getattr(libm, name).argtypes = [ctypes.c_float] * args
        return libm
    except (OSError, AttributeError):
        return None


LIBM = _c_library()


def _expf(x) -> F:
    return F(LIBM.expf(float(x))) if LIBM else F(math.exp(float(x)))


def _powf_scalar(x, y) -> F:
    return F(LIBM.powf(float(x), float(y))) if LIBM else F(float(x) ** float(y))


def _powf(x: np.ndarray, y) -> np.ndarray:
    """float32 x ** y, taken in float64 and rounded (module docstring)."""
    return np.power(x.astype(np.float64), np.asarray(y, np.float64)).astype(F)


def _matrix(m, c0, c1, c2):
    return [m[i][0] * c0 + m[i][1] * c1 + m[i][2] * c2 for i in range(3)]


def _lab(rgb, power=None):
    """Linear RGB (three float32 arrays) → CIELAB, as FLIP's LinearRGBToXYZ, XYZToCIELab
    (``power``: the float32 power, default :func:`_powf`)."""
    power = power or _powf
    delta = F(6.0) / F(29.0)
    delta_cube = delta * (delta * delta)
    factor = F(1.0) / (F(3.0) * (delta * delta))
    term = F(4.0) / F(29.0)
    xyz = [v * inv for v, inv in zip(_matrix(RGB_TO_XYZ, *rgb), INV_ILLUMINANT)]
    third = F(1.0) / F(3.0)
    f = [np.where(v > delta_cube, power(v, third), factor * v + term) for v in xyz]
    return F(116.0) * f[1] - F(16.0), F(500.0) * (f[0] - f[1]), F(200.0) * (f[1] - f[2])


def _hunt_lab(rgb, power=None):
    L, a, b = _lab(rgb, power)
    return L, F(0.01) * L * a, F(0.01) * L * b


def _max_distance() -> F:
    """FLIP's cmax: the Hunt-adjusted HyAB distance of pure green and pure blue, ** gqc."""
    green = _hunt_lab([np.array(v, F) for v in (0.0, 1.0, 0.0)], _powf_scalar)  # constants: the library's own powf
    blue = _hunt_lab([np.array(v, F) for v in (0.0, 0.0, 1.0)], _powf_scalar)
    d = abs(green[0] - blue[0]) + np.sqrt((green[1] - blue[1]) * (green[1] - blue[1])
                                          + (green[2] - blue[2]) * (green[2] - blue[2]))
    return _powf_scalar(d, GQC)


def _gaussian(x2, a, b) -> F:
    return a * F(math.sqrt(float(PI / b))) * _expf(-PI_SQ * x2 / b)


def spatial_filters(ppd: float) -> tuple[np.ndarray, np.ndarray]:
    """FLIP's separated CSF filters (setSpatialFilters): YCx (Y, Cx weights) and Cz (two
    Gaussians), float32, 2r + 1 taps each."""
    ppd = F(ppd)  # type: ignore[assignment]  # float32 from here, as FLIP computes
    scale = max(B1 + B2)
    radius = int(math.ceil(F(3.0) * F(math.sqrt(float(scale / (F(2.0) * PI_SQ)))) * ppd))
    dx = F(1.0) / ppd
    ycx, cz = np.zeros((2 * radius + 1, 2), F), np.zeros((2 * radius + 1, 2), F)
    sums = [F(0.0)] * 4
    for x in range(2 * radius + 1):
        ix = F(x - radius) * dx
        ix2 = ix * ix
        values = (_gaussian(ix2, A1[0], B1[0]), _gaussian(ix2, A1[1], B1[1]),
                  F(math.sqrt(float(A1[2] * F(math.sqrt(float(PI / B1[2])))))) * _expf(-PI_SQ * ix2 / B1[2]),
                  F(math.sqrt(float(A2[2] * F(math.sqrt(float(PI / B2[2])))))) * _expf(-PI_SQ * ix2 / B2[2]))
        ycx[x], cz[x] = values[:2], values[2:]
        sums = [s + v for s, v in zip(sums, values)]
    ycx[:, 0] *= F(1.0) / sums[0]
    ycx[:, 1] *= F(1.0) / sums[1]
    cz *= F(1.0) / F(math.sqrt(float(sums[2] * sums[2] + sums[3] * sums[3])))
    return ycx, cz


def feature_filter(ppd: float) -> np.ndarray:
    """FLIP's separated edge/point filter (setFeatureFilter): columns Gaussian, first and
    second derivative, float32."""
    sd = F(0.5) * GW * F(ppd)
    radius = int(math.ceil(F(3.0) * sd))
    out = np.zeros((2 * radius + 1, 3), F)
    g_sum, dg_neg, dg_pos, ddg_neg, ddg_pos = (F(0.0),) * 5
    for x in range(2 * radius + 1):
        xx = F(x - radius)
        g = _expf(-(xx * xx) / (F(2.0) * sd * sd))
        g_sum += g
        dg = -xx * g
        if dg > 0:
            dg_pos += dg
        else:
            dg_neg -= dg
        ddg = (xx * xx / (sd * sd) - F(1.0)) * g
        if ddg > 0:
            ddg_pos += ddg
        else:
            ddg_neg -= ddg
        out[x] = (g, dg, ddg)
    for x in range(2 * radius + 1):
        g, dg, ddg = out[x]
        out[x] = (g / g_sum, dg / (dg_pos if dg > 0 else dg_neg), ddg / (ddg_pos if ddg > 0 else ddg_neg))
    return out


def _correlate(image: np.ndarray, weights, axis: int) -> np.ndarray:
    """Σ over taps of weights[tap] · ``image`` shifted by tap − radius along ``axis``,
    clamped at the border and accumulated from the first tap, as FLIP's loops."""
    radius = len(weights) // 2
    pad = [(0, 0)] * image.ndim
    pad[axis] = (radius, radius)
    padded = np.pad(image, pad, mode="edge")
    n, index = image.shape[axis], [slice(None)] * image.ndim
    acc, term = np.zeros(image.shape, F), np.empty(image.shape, F)
    for tap, w in enumerate(weights):
        index[axis] = slice(tap, tap + n)
        acc += np.multiply(padded[tuple(index)], w, out=term)
    return acc


def _ycxcz(rgb: np.ndarray, exposure: F) -> list:
    """One exposure of linear RGB images (…×H×W×3 float32): exposed, ACES tone-mapped,
    clamped to [0, 1] and taken to YCxCz (three arrays …×H×W)."""
    c = rgb * _powf_scalar(2.0, exposure)
    cc = c * c
    c = np.clip((cc * ACES[0] + c * ACES[1] + ACES[2]) / (cc * ACES[3] + c * ACES[4] + ACES[5]), F(0.0), F(1.0))
    x, y, z = (v * inv for v, inv in zip(_matrix(RGB_TO_XYZ, c[..., 0], c[..., 1], c[..., 2]), INV_ILLUMINANT))
    return [F(116.0) * y - F(16.0), F(500.0) * (x - y), F(200.0) * (y - z)]


def _filtered_lab(ycxcz: list, ycx: np.ndarray, cz: np.ndarray) -> tuple:
    """The CSF-filtered image (computeColorDifference's passes) as Hunt-adjusted CIELAB."""
    axis_x, axis_y = ycxcz[0].ndim - 1, ycxcz[0].ndim - 2
    y = _correlate(_correlate(ycxcz[0], ycx[:, 0], axis_x), ycx[:, 0], axis_y)
    cx = _correlate(_correlate(ycxcz[1], ycx[:, 1], axis_x), ycx[:, 1], axis_y)
    cz_sum = (_correlate(_correlate(ycxcz[2], cz[:, 0], axis_x), cz[:, 0], axis_y)
              + _correlate(_correlate(ycxcz[2], cz[:, 1], axis_x), cz[:, 1], axis_y))
    big_y = (y + F(16.0)) / F(116.0)
    xyz = ((big_y + cx / F(500.0)) * ILLUMINANT[0], big_y * ILLUMINANT[1], (big_y - cz_sum / F(200.0)) * ILLUMINANT[2])
    rgb = [np.clip(v, F(0.0), F(1.0)) for v in _matrix(XYZ_TO_RGB, *xyz)]
    return _hunt_lab(rgb)


def _features(ycxcz: list, ff: np.ndarray) -> tuple:
    """Edge and point strengths (computeFeatureDifferenceAndFinalError's passes)."""
    axis_x, axis_y = ycxcz[0].ndim - 1, ycxcz[0].ndim - 2
    gray = ycxcz[0] * (F(1.0) / F(116.0)) + F(16.0) / F(116.0)
    dx, ddx, g = (_correlate(gray, ff[:, i], axis_x) for i in (1, 2, 0))
    dx, ddx = _correlate(dx, ff[:, 0], axis_y), _correlate(ddx, ff[:, 0], axis_y)
    dy, ddy = _correlate(g, ff[:, 1], axis_y), _correlate(g, ff[:, 2], axis_y)
    return np.sqrt(dx * dx + dy * dy), np.sqrt(ddx * ddx + ddy * ddy)


def exposures(start: float, stop: float, count: int | None = None) -> list:
    """HDR-FLIP's exposures (float32) from ``start`` to ``stop``: ``count`` of them, or
    FLIP's own count max(2, ⌈stop − start⌉)."""
    start, stop = F(start), F(stop)  # type: ignore[assignment]  # float32, as FLIP's
    if count is None:
        count = int(max(F(2.0), F(math.ceil(stop - start))))
    step = (stop - start) / F(count - 1)
    return [start + F(i) * step for i in range(count)]


def hdr_flip_maps(reference: ArrayLike, tests: ArrayLike, *, start_exposure: float, stop_exposure: float,
                  ppd: float = 67.0, num_exposures: int | None = None) -> np.ndarray:
    """HDR-FLIP error maps of each test against the reference (``flip_evaluator.evaluate``
    with "HDR", the ACES tone mapper and the given exposures).

    Parameters
    ----------
    reference : H×W×3 float32-convertible, linear RGB radiance ≥ 0.
    tests : T×H×W×3, the same.
    start_exposure, stop_exposure : log2 exposure range (start ≤ stop).
    ppd : pixels per degree of visual angle.
    num_exposures : None: FLIP's count, max(2, ⌈stop − start⌉).

    Returns
    -------
    T×H×W float32 in [0, 1]: each pixel's largest LDR-FLIP error over the exposures.
    """
    r = np.ascontiguousarray(reference, F)
    t = np.ascontiguousarray(tests, F)
    if r.ndim != 3 or r.shape[2] != 3 or t.ndim != 4 or t.shape[1:] != r.shape:
        raise ValueError(f"expected an H×W×3 reference and T×H×W×3 tests, got {r.shape} and {t.shape}")
    if not start_exposure <= stop_exposure:
        raise ValueError(f"exposures {start_exposure!r} to {stop_exposure!r}: expected start ≤ stop")
    ycx, cz = spatial_filters(ppd)
    ff = feature_filter(ppd)
    cmax = _max_distance()
    pccmax = GPC * cmax
    below, norm = GPT / pccmax, F(1.0) / F(math.sqrt(2.0))
    out = np.zeros(t.shape[:3], F)
    both = np.concatenate([r[None], t])  # the reference first: one array through every step
    for exposure in exposures(start_exposure, stop_exposure, num_exposures):
        ycxcz = _ycxcz(both, exposure)
        L, a, b = _filtered_lab(ycxcz, ycx, cz)
        da, db = a[:1] - a[1:], b[:1] - b[1:]
        colour = _powf(np.abs(L[:1] - L[1:]) + np.sqrt(da * da + db * db), GQC)
        colour = np.where(colour < pccmax, colour * below,
                          GPT + ((colour - pccmax) / (cmax - pccmax)) * (F(1.0) - GPT))
        edges, points = _features(ycxcz, ff)
        edge, point = np.abs(edges[:1] - edges[1:]), np.abs(points[:1] - points[1:])
        feature = _powf(norm * np.where(edge > point, edge, point), GQF)
        error = _powf(colour, F(1.0) - feature)
        out = np.where(error > out, error, out)  # the library's setMaxExposure: a pixel's worst exposure
    return out
