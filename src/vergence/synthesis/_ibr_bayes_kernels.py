"""Numba kernels of the Bayesian view-synthesis weights (Pujades, Devernay & Goldluecke, CVPR 2014).

:func:`vergence.synthesis.ibr_bayes.bayesian_weights` validates its inputs and calls these; the
kernels trust them: C-contiguous float64 arrays on the target grid, ``visible`` False wherever the
proxy point is NaN. Each kernel has a slow, obviously-correct Python twin in
``tests/synthesis/test_ibr_bayes.py`` that it is checked against.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

__all__ = ["bayes_weight_rows", "count_invalid_rows", "luminance_gradient_rows"]

# Rec. 709 luma weights: the authors' code takes the gradient of Y = 0.2126 R + 0.7152 G + 0.0722 B.
LUMA = (0.2126, 0.7152, 0.0722)


@nb.njit(cache=True, parallel=True)
def count_invalid_rows(points, pixels, visible, counts):  # pragma: no cover - compiled
    """Per target row y, ``counts[y] = (inf in points, inf in pixels, visible where the proxy point
    is not finite, visible where the source pixel is not finite)``, in one pass."""
    n_src, h, w = visible.shape
    for y in nb.prange(h):
        c0 = c1 = c2 = c3 = 0
        for x in range(w):
            known = True
            for k in range(3):
                v = points[y, x, k]
                if math.isinf(v):
                    c0 += 1
                if not math.isfinite(v):
                    known = False
            for i in range(n_src):
                finite = True
                for k in range(2):
                    v = pixels[i, y, x, k]
                    if math.isinf(v):
                        c1 += 1
                    if not math.isfinite(v):
                        finite = False
                if visible[i, y, x]:
                    if not known:
                        c2 += 1
                    if not finite:
                        c3 += 1
        counts[y, 0] = c0
        counts[y, 1] = c1
        counts[y, 2] = c2
        counts[y, 3] = c3


@nb.njit(cache=True, parallel=True, error_model="numpy")
def luminance_gradient_rows(img, lum, gx, gy):  # pragma: no cover - compiled
    """Sobel/8 gradient of the luminance of ``img`` (H, W, C) into ``gx``, ``gy`` (H, W), per pixel.

    ``lum`` (H, W) is scratch space (overwritten with the luminance). C = 3: Y = 0.2126 R +
    0.7152 G + 0.0722 B; C = 1: Y is the channel. The 3x3 Sobel filter divided by 8 gives the slope
    in luminance per pixel (a ramp ``Y = a x`` gives ``gx = a``). At the image border the outside
    row or column is replaced by the nearest inside one, and the difference is divided by its true
    span, so a ramp keeps its slope there too; a 1-pixel-wide axis has slope 0.
    """
    h, w = gx.shape
    nc = img.shape[2]
    for y in nb.prange(h):
        for x in range(w):
            if nc == 3:
                lum[y, x] = LUMA[0] * img[y, x, 0] + LUMA[1] * img[y, x, 1] + LUMA[2] * img[y, x, 2]
            else:
                lum[y, x] = img[y, x, 0]
    for y in nb.prange(h):
        y0 = max(y - 1, 0)
        y2 = min(y + 1, h - 1)
        for x in range(w):
            x0 = max(x - 1, 0)
            x2 = min(x + 1, w - 1)
            sx = (lum[y0, x2] + 2.0 * lum[y, x2] + lum[y2, x2]) - (lum[y0, x0] + 2.0 * lum[y, x0] + lum[y2, x0])
            sy = (lum[y2, x0] + 2.0 * lum[y2, x] + lum[y2, x2]) - (lum[y0, x0] + 2.0 * lum[y0, x] + lum[y0, x2])
            gx[y, x] = sx / (4.0 * (x2 - x0)) if x2 > x0 else 0.0
            gy[y, x] = sy / (4.0 * (y2 - y0)) if y2 > y0 else 0.0


@nb.njit(cache=True, inline="always")
def _ranges(points, pix, y, cx, cy, cz, out):  # pragma: no cover - compiled
    """``out[x]`` = distance of row y's proxy points from the source centre; NaN where the proxy
    point or the source pixel is unknown (so that no continuity test passes there)."""
    for x in range(out.shape[0]):
        r = math.sqrt((points[y, x, 0] - cx) ** 2 + (points[y, x, 1] - cy) ** 2 + (points[y, x, 2] - cz) ** 2)
        out[x] = r if (math.isfinite(pix[y, x, 0]) and math.isfinite(pix[y, x, 1])) else math.nan


@nb.njit(cache=True, inline="always")
def _derivative(pix, ya, xa, oka, yc, xc, okc, y, x):  # pragma: no cover - compiled
    """d beta along one axis at (y, x) from its neighbours a (ahead) and c (behind): central when
    both are on the surface (``oka``, ``okc``), one-sided when one is; ``ok = False`` otherwise."""
    if oka and okc:
        return True, 0.5 * (pix[ya, xa, 0] - pix[yc, xc, 0]), 0.5 * (pix[ya, xa, 1] - pix[yc, xc, 1])
    if oka:
        return True, pix[ya, xa, 0] - pix[y, x, 0], pix[ya, xa, 1] - pix[y, x, 1]
    if okc:
        return True, pix[y, x, 0] - pix[yc, xc, 0], pix[y, x, 1] - pix[yc, xc, 1]
    return False, 0.0, 0.0


@nb.njit(cache=True, parallel=True, error_model="numpy")
def bayes_weight_rows(
    points, pixels, visible, centers, mapped, jac, has_jac, K, R, t, gx, gy, has_grad,
    sigma_sensor, sigma_depth, deformation_cap, min_deformation, gradient_threshold, geometric_cap,
    continuity, out,
):  # pragma: no cover - compiled
    """Unnormalised weights ``out[i, y, x] = m_i |det D beta_i| / (sigma_s^2 + sigma_geom^2)``.

    ``points`` (h, w, 3) undistorted proxy points; ``pixels`` (S, h, w, 2) beta_i; ``visible``
    (S, h, w); ``centers`` (S, 3) source centres; ``mapped`` (h, w, 3) the proxy points in the
    target's world (``phi(p)``, or ``points`` without distortion) and ``jac`` (h, w, 3, 3) ``D phi``
    at ``points`` (read only when ``has_jac``); ``K, R, t`` the target camera; ``gx, gy`` (h, w) the
    gradient of the estimate (read only when ``has_grad``).

    Deformation: ``|det D beta_i(y)|`` from differences of beta_i over the target grid, each axis
    central where both neighbours are one surface with y (their proxy points' distances r from
    source i's centre within ``continuity * r`` of y's, source pixels known), one-sided where one
    is; 1 where an axis has neither. Clamped to ``[min_deformation, deformation_cap]``.
    Geometry: ``v = d tau_i / d(log z_i) = J_pi(phi(p)) D phi(p) (p - c_i)``, the target-image
    velocity of the proxy point moving along source i's ray by a relative depth step;
    ``g = grad u`` scaled down to norm ``gradient_threshold`` when longer;
    ``sigma_geom = min(sigma_depth |g . v|, geometric_cap)`` (``geometric_cap`` where v is not finite).
    """
    n_src, h, w = visible.shape
    var_s = sigma_sensor * sigma_sensor
    for y in nb.prange(h):
        # Per pixel of the row: the capped gradient g and M = J_pi(q) D phi(p), the (2, 3) map from
        # a world displacement at p to a target-pixel displacement.
        g = np.zeros((w, 2))
        m = np.full((w, 6), math.nan)
        if has_grad:
            for x in range(w):
                g0, g1 = gx[y, x], gy[y, x]
                gn = math.sqrt(g0 * g0 + g1 * g1)
                if gn > gradient_threshold:  # authors' _ugrad_threshold: keep the direction
                    g0 *= gradient_threshold / gn
                    g1 *= gradient_threshold / gn
                g[x, 0], g[x, 1] = g0, g1
                q0, q1, q2 = mapped[y, x, 0], mapped[y, x, 1], mapped[y, x, 2]
                c0 = R[0, 0] * q0 + R[0, 1] * q1 + R[0, 2] * q2 + t[0]
                c1 = R[1, 0] * q0 + R[1, 1] * q1 + R[1, 2] * q2 + t[1]
                c2 = R[2, 0] * q0 + R[2, 1] * q1 + R[2, 2] * q2 + t[2]
                if not c2 > 0.0:  # also NaN: no velocity
                    continue
                u = (K[0, 0] * c0 + K[0, 1] * c1 + K[0, 2] * c2) / c2
                v = (K[1, 1] * c1 + K[1, 2] * c2) / c2
                # d pixel / d x_cam = (K[:2] - pixel K[2]) / z with K[2] = (0, 0, 1), then times R
                a00, a01, a02 = K[0, 0] / c2, K[0, 1] / c2, (K[0, 2] - u) / c2
                a11, a12 = K[1, 1] / c2, (K[1, 2] - v) / c2
                for k in range(3):
                    m[x, k] = a00 * R[0, k] + a01 * R[1, k] + a02 * R[2, k]
                    m[x, 3 + k] = a11 * R[1, k] + a12 * R[2, k]
                if has_jac:  # M = (J_pi R) D phi
                    for r in range(2):
                        b0, b1, b2 = m[x, 3 * r], m[x, 3 * r + 1], m[x, 3 * r + 2]
                        for k in range(3):
                            m[x, 3 * r + k] = b0 * jac[y, x, 0, k] + b1 * jac[y, x, 1, k] + b2 * jac[y, x, 2, k]
        above = np.full(w, math.nan)
        here = np.empty(w)
        below = np.full(w, math.nan)
        for i in range(n_src):
            cx, cy, cz = centers[i, 0], centers[i, 1], centers[i, 2]
            pix = pixels[i]
            _ranges(points, pix, y, cx, cy, cz, here)
            if y > 0:
                _ranges(points, pix, y - 1, cx, cy, cz, above)
            if y < h - 1:
                _ranges(points, pix, y + 1, cx, cy, cz, below)
            for x in range(w):
                if not visible[i, y, x]:
                    out[i, y, x] = 0.0
                    continue
                # Resolution term |det D tau_i(beta_i(y))|^-1 = |det D beta_i(y)|.
                r0 = here[x]
                tol = continuity * r0
                right = x < w - 1 and abs(here[x + 1] - r0) <= tol
                left = x > 0 and abs(here[x - 1] - r0) <= tol
                down = abs(below[x] - r0) <= tol  # NaN (outside or unknown) compares False
                up = abs(above[x] - r0) <= tol
                okx, bxu, bxv = _derivative(pix, y, x + 1, right, y, x - 1, left, y, x)
                oky, byu, byv = _derivative(pix, y + 1, x, down, y - 1, x, up, y, x)
                det = abs(bxu * byv - byu * bxv) if (okx and oky) else 1.0
                w_def = min(max(det, min_deformation), deformation_cap)
                # Geometric term sigma_z^2 (grad u . d_z tau_i)^2.
                var_g = 0.0
                g0, g1 = g[x, 0], g[x, 1]
                if g0 != 0.0 or g1 != 0.0:
                    d0, d1, d2 = points[y, x, 0] - cx, points[y, x, 1] - cy, points[y, x, 2] - cz
                    v0 = m[x, 0] * d0 + m[x, 1] * d1 + m[x, 2] * d2
                    v1 = m[x, 3] * d0 + m[x, 4] * d1 + m[x, 5] * d2
                    s_geom = sigma_depth * abs(g0 * v0 + g1 * v1)
                    if not s_geom <= geometric_cap:  # also NaN: the velocity is unknown
                        s_geom = geometric_cap
                    var_g = s_geom * s_geom
                out[i, y, x] = w_def / (var_s + var_g)


def empty_jacobian() -> np.ndarray:
    """The placeholder ``jac`` for :func:`bayes_weight_rows` without distortion."""
    return np.zeros((1, 1, 3, 3))
