"""Shading of the ray tree: Schlick Fresnel, mirror and refraction directions, image-based lighting.

- Fresnel: Schlick's approximation (Schlick 1994, as S3 §3.1 uses it), ``R = R0 + (1 - R0)(1 - cos)^5`` with
  ``R0 = ((n1 - n2)/(n1 + n2))^2``; going into a less dense medium the cosine of the transmitted
  angle is used, and ``sin^2 theta_t > 1`` is total internal reflection (``R = 1``).
- Diffuse radiance: image-based lighting times ambient occlusion (S3 §3.1):
  ``L = albedo / pi * E(n) * AO(p, n)``, with ``E(n) = int L_env(w) max(0, n.w) dw`` the
  irradiance from the environment and ``AO`` the cosine-weighted fraction of the hemisphere around
  ``n`` from which a ray escapes the scene. For a constant environment ``c``, ``E = pi c`` exactly
  and an unoccluded diffuse surface has radiance ``albedo c``. For a map, ``E`` is tabulated once on
  a 32 x 16 grid of normals by summing a 64 x 32 area-averaged copy of the map (exact solid angles
  per row), then looked up bilinearly.
- AO directions: a Fibonacci lattice of ``samples`` points in [0, 1)^2 mapped to the
  cosine-weighted hemisphere; with an ``rng`` every shading point shifts the lattice by its own
  uniform offset (Cranley-Patterson rotation: unbiased, stratified), without one the lattice is
  used as is (deterministic, noise-free, slightly banded).
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from vergence._validate import as_float_array
from vergence.render.scene import Environment

__all__ = ["Lighting", "ao_directions", "ao_lattice", "reflect", "refract", "schlick"]

# Irradiance: the map is area-averaged to 64 x 32 texels (exact solid angles per row) and E is
# tabulated for 32 x 16 normals; the cosine lobe is smooth, so the bilinear lookup loses well under
# 1 % (half-sky test). One table costs a (512 x 2048) product.
_SRC_W, _SRC_H = 64, 32
_IRR_W, _IRR_H = 32, 16
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


def schlick(cos_i: np.ndarray | float, n1: np.ndarray | float, n2: np.ndarray | float) -> np.ndarray:
    """Schlick's reflectance for a ray in medium ``n1`` meeting medium ``n2`` (Schlick 1994).

    Parameters
    ----------
    cos_i : array
        Cosine of the incidence angle, in [0, 1].
    n1, n2 : array or float
        Refractive indices of the incident and transmitting media.

    Returns
    -------
    R : float64 array
        Reflected fraction; 1 under total internal reflection. The transmitted fraction is ``1 - R``.

    Examples
    --------
    >>> round(float(schlick(1.0, 1.0, 1.5)), 12)  # normal incidence on glass: R0 = 0.04
    0.04
    """
    cos_i = as_float_array("cos_i", cos_i)
    n1, n2 = as_float_array("n1", n1), as_float_array("n2", n2)
    if cos_i.size and (cos_i.min() < 0.0 or cos_i.max() > 1.0):
        raise ValueError(f"cos_i must be in [0, 1]; got {cos_i.min():g}..{cos_i.max():g}")
    for name, n in (("n1", n1), ("n2", n2)):
        if n.size and n.min() <= 0.0:
            raise ValueError(f"{name} must be > 0; got min {n.min():g}")
    try:
        np.broadcast_shapes(cos_i.shape, n1.shape, n2.shape)
    except ValueError:
        raise ValueError(f"cos_i, n1 and n2 must broadcast together; got {cos_i.shape}, {n1.shape}, {n2.shape}") from None
    r0 = ((n1 - n2) / (n1 + n2)) ** 2  # Schlick 1994
    sin2_t = (n1 / n2) ** 2 * (1.0 - cos_i**2)
    tir = (n1 > n2) & (sin2_t > 1.0)
    cos = np.where(n1 > n2, np.sqrt(np.clip(1.0 - sin2_t, 0.0, 1.0)), cos_i)
    return np.where(tir, 1.0, r0 + (1.0 - r0) * (1.0 - cos) ** 5)


def reflect(d: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Mirror directions ``d - 2 (d.n) n`` of rays ``(M, 3)`` about unit normals ``(M, 3)``."""
    return d - 2.0 * np.einsum("ij,ij->i", d, n)[:, None] * n


def refract(d: np.ndarray, n: np.ndarray, eta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Refracted unit directions by Snell's law, and the total-internal-reflection mask.

    ``n`` faces the incoming ray (``d.n < 0``); ``eta = n1 / n2``. With ``c = -d.n`` and
    ``k = 1 - eta^2 (1 - c^2)``: ``t = eta d + (eta c - sqrt(k)) n``; ``k < 0`` is TIR (t = NaN).
    """
    c = -np.einsum("ij,ij->i", d, n)
    k = 1.0 - eta**2 * (1.0 - c**2)
    tir = k < 0.0
    t = eta[:, None] * d + (eta * c - np.sqrt(np.where(tir, np.nan, k)))[:, None] * n
    return t, tir


def ao_lattice(samples: int) -> np.ndarray:
    """The Fibonacci lattice ``((k + 1/2)/S, frac(k phi))``, ``(S, 2)`` points in [0, 1)^2."""
    k = np.arange(samples)
    return np.stack([(k + 0.5) / samples, (k * _GOLDEN) % 1.0], axis=-1)


def ao_directions(normals: np.ndarray, samples: int, rng: np.random.Generator | None) -> np.ndarray:
    """Cosine-weighted hemisphere directions ``(M, S, 3)`` around unit ``normals (M, 3)``.

    The numpy reference of the renderer's Numba kernel (``_kernels.ao_rays``).

    A Fibonacci lattice ``((k + 1/2)/S, frac(k phi))``, shifted per point by ``rng`` when given,
    mapped by ``r = sqrt(u), phi = 2 pi v`` to ``(r cos phi, r sin phi, sqrt(1 - u))`` in an
    orthonormal frame of the normal (Duff et al. 2017).
    """
    lat = ao_lattice(samples)[None]  # (1, S, 2)
    if rng is not None:
        lat = (lat + rng.random((len(normals), 1, 2))) % 1.0
    u, v = lat[..., 0], lat[..., 1]
    r = np.sqrt(u)
    local = np.stack([r * np.cos(2 * np.pi * v), r * np.sin(2 * np.pi * v), np.sqrt(1.0 - u)], axis=-1)
    nx, ny, nz = normals[:, 0], normals[:, 1], normals[:, 2]
    sign = np.where(nz >= 0.0, 1.0, -1.0)
    a = -1.0 / (sign + nz)
    b = nx * ny * a
    t1 = np.stack([1.0 + sign * nx * nx * a, sign * b, -sign * nx], axis=-1)
    t2 = np.stack([b, sign + ny * ny * a, -ny], axis=-1)
    return local[..., :1] * t1[:, None] + local[..., 1:2] * t2[:, None] + local[..., 2:3] * normals[:, None]


class Lighting:
    """Environment radiance along directions and irradiance on normals, from an :class:`Environment`."""

    def __init__(self, env: Environment) -> None:
        self.env = env
        self._rot = math.radians(env.rotation_deg)
        if env.image is None:
            self._map = None
            self._irr = None
            return
        self._map = np.asarray(env.image, dtype=np.float32) * np.float32(env.intensity)
        small = cv2.resize(self._map, (_SRC_W, _SRC_H), interpolation=cv2.INTER_AREA).astype(np.float64)
        theta_edges = np.linspace(0.0, np.pi, _SRC_H + 1)
        solid = (2 * np.pi / _SRC_W) * (np.cos(theta_edges[:-1]) - np.cos(theta_edges[1:]))  # per row
        texels = self._grid_dirs(_SRC_W, _SRC_H).reshape(-1, 3)
        normals = self._grid_dirs(_IRR_W, _IRR_H).reshape(-1, 3)
        weights = (small * solid[:, None, None]).reshape(-1, 3)
        # (normals, texels); three broadcast products: a BLAS product with an inner size of 3 took 80 ms on
        # shared cores (its threads wait), more than a render's shading
        cos = np.maximum(normals[:, :1] * texels[:, 0] + normals[:, 1:2] * texels[:, 1] + normals[:, 2:3] * texels[:, 2], 0.0)
        self._irr = np.einsum("nt,tc->nc", cos, weights).reshape(_IRR_H, _IRR_W, 3).astype(np.float32)  # no BLAS threads

    @property
    def radiance_map(self) -> np.ndarray | None:
        """The environment map times its intensity, ``(h, w, 3)`` float32; None for a constant colour."""
        return self._map

    @property
    def irradiance_table(self) -> np.ndarray | None:
        """``E(n)`` tabulated on a 32 x 16 equirectangular grid of normals, float32; None for a constant colour."""
        return self._irr

    @property
    def rotation(self) -> float:
        """The map's rotation about the vertical axis, radians (``Environment.rotation_deg``)."""
        return self._rot

    @staticmethod
    def _grid_dirs(w: int, h: int) -> np.ndarray:
        """Unrotated directions of texel centres of an equirectangular ``(h, w)`` map."""
        u = (np.arange(w) + 0.5) / w
        v = (np.arange(h) + 0.5) / h
        phi = (u - 0.5) * 2 * np.pi
        theta = v * np.pi
        st = np.sin(theta)[:, None]
        return np.stack([st * np.sin(phi)[None], np.cos(theta)[:, None] * np.ones((1, w)), -st * np.cos(phi)[None]], axis=-1)

    def _lookup(self, table: np.ndarray, dirs: np.ndarray) -> np.ndarray:
        """Bilinear lookup of an equirectangular table at unit directions (``_kernels.equirect_lookup``)."""
        from vergence.render import _kernels

        return _kernels.equirect_lookup(table, np.ascontiguousarray(dirs, dtype=np.float64), self._rot)

    def radiance(self, dirs: np.ndarray) -> np.ndarray:
        """Environment radiance ``(M, 3)`` arriving along unit directions ``(M, 3)`` (looked up at ``dirs``)."""
        if self._map is None:
            return np.broadcast_to(self.env.color * self.env.intensity, (len(dirs), 3)).copy()
        return self._lookup(self._map, dirs)

    def irradiance(self, normals: np.ndarray) -> np.ndarray:
        """Irradiance ``E(n)`` ``(M, 3)`` from the whole environment on unit normals ``(M, 3)``."""
        if self._irr is None:
            return np.broadcast_to(np.pi * self.env.color * self.env.intensity, (len(normals), 3)).copy()
        return self._lookup(self._irr, normals)
