"""Meshes and textures generated in code for the built-in scenes (no downloads).

Meshes are closed, wound counter-clockwise seen from outside, with texture coordinates; textures
are albedo images in [0, 1] made with numpy and Pillow, seeded so every run is identical.
"""

from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from vergence.render.scene import Mesh

__all__ = ["box", "crowd_texture", "cylinder", "grass_texture", "lathe", "poster_texture", "tile_texture", "wood_texture"]


def box(center: tuple, size: tuple, material: str) -> Mesh:
    """Axis-aligned box, each face with its own vertices and uv over [0, 1]^2 (flat shading)."""
    c = np.asarray(center, dtype=np.float64)
    h = np.asarray(size, dtype=np.float64) / 2.0
    verts, faces, uvs = [], [], []
    for axis in range(3):
        for sign in (1.0, -1.0):
            n = np.zeros(3)
            n[axis] = sign
            a = np.zeros(3)
            a[(axis + 1) % 3] = 1.0
            b = np.cross(n, a)  # (a, b, n) right-handed: counter-clockwise seen from outside
            base = len(verts)
            for du, dv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                verts.append(c + h * (n + du * a + dv * b))
                uvs.append(((du + 1) / 2.0, (dv + 1) / 2.0))
            faces += [[base, base + 1, base + 2], [base, base + 2, base + 3]]
    return Mesh(vertices=np.array(verts), faces=np.array(faces), material=material, uv=np.array(uvs))


def lathe(profile: list[tuple[float, float]], *, base: tuple, material: str, segments: int = 48) -> Mesh:
    """Closed solid of revolution about +y: ``profile`` is (radius, height) from bottom to top.

    The first and last points should have radius 0 (closing the solid on the axis). Smooth vertex
    normals; uv = (angle / 2 pi, height fraction).
    """
    prof = np.asarray(profile, dtype=np.float64)
    m = len(prof)
    ang = np.linspace(0.0, 2 * np.pi, segments + 1)
    r, y = prof[:, 0][:, None], prof[:, 1][:, None]
    verts = np.stack([r * np.sin(ang)[None], y * np.ones_like(ang)[None], r * np.cos(ang)[None]], axis=-1)
    verts = verts.reshape(-1, 3) + np.asarray(base, dtype=np.float64)
    span = prof[-1, 1] - prof[0, 1]
    uv = np.stack(np.broadcast_arrays(ang[None] / (2 * np.pi), (prof[:, 1:2] - prof[0, 1]) / span), axis=-1).reshape(-1, 2)
    idx = np.arange(m * (segments + 1)).reshape(m, segments + 1)
    a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]
    faces = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    v = verts[faces]
    area = np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)
    faces = faces[area > 1e-14]  # drop the degenerate triangles at the poles
    # Smooth normals from the profile's 2D normal (exact for a surface of revolution).
    dr = np.gradient(prof[:, 0])
    dy = np.gradient(prof[:, 1])
    n2 = np.stack([dy, -dr], axis=1)
    n2 /= np.linalg.norm(n2, axis=1, keepdims=True)
    normals = np.stack([n2[:, :1] * np.sin(ang)[None], n2[:, 1:2] * np.ones_like(ang)[None], n2[:, :1] * np.cos(ang)[None]], -1)
    return Mesh(vertices=verts, faces=faces, material=material, normals=normals.reshape(-1, 3), uv=uv)


def cylinder(base: tuple, radius: float, height: float, material: str, *, segments: int = 48) -> Mesh:
    """Closed upright cylinder (flat caps) standing on ``base``, smooth sides."""
    return lathe([(0.0, 0.0), (radius, 0.0), (radius, 0.0), (radius, height), (radius, height), (0.0, height)],
                 base=base, material=material, segments=segments)  # fmt: skip


def tile_texture(width: int = 768, height: int = 480, *, cols: int = 8, rows: int = 5) -> np.ndarray:
    """Coloured tiles, each with a large glyph (reflection and refraction flip it visibly)."""
    img = Image.new("RGB", (width, height))
    draw = ImageDraw.Draw(img)
    glyphs = "ABCDEFGHJKLMNPQRSTUVWXYZ2345679?&#@%"
    tw, th = width / cols, height / rows
    font = ImageFont.load_default(size=int(th * 0.6))
    for j in range(rows):
        for i in range(cols):
            hue = (i / cols + j * 0.37) % 1.0
            rgb = np.array(Image.new("HSV", (1, 1), (int(hue * 255), 150, 230)).convert("RGB").getpixel((0, 0)))
            box_ = [i * tw, j * th, (i + 1) * tw - 1, (j + 1) * th - 1]
            draw.rectangle(box_, fill=tuple(int(v) for v in rgb), outline=(30, 30, 30), width=3)
            g = glyphs[(i + j * cols) % len(glyphs)]
            draw.text(((i + 0.5) * tw, (j + 0.5) * th), g, fill=(25, 25, 35), font=font, anchor="mm")
    return np.asarray(img, dtype=np.float32) / 255.0


def poster_texture(width: int = 512, height: int = 384, *, seed: int = 3) -> np.ndarray:
    """Wallpaper: diagonal stripes with scattered discs, muted colours."""
    rng = np.random.default_rng(seed)
    ys, xs = np.mgrid[0:height, 0:width].astype(np.float64)
    stripes = 0.5 + 0.5 * np.sign(np.sin((xs + ys) * 2 * np.pi / 48.0))
    img = np.stack([0.55 + 0.2 * stripes, 0.6 + 0.1 * stripes, 0.5 + 0.05 * stripes], axis=-1)
    for _ in range(40):
        cx, cy, r = rng.uniform(0, width), rng.uniform(0, height), rng.uniform(8, 30)
        mask = (xs - cx) ** 2 + (ys - cy) ** 2 < r * r
        img[mask] = rng.uniform(0.1, 0.9, 3)
    return img.astype(np.float32)


def wood_texture(width: int = 512, height: int = 256, *, seed: int = 5) -> np.ndarray:
    """Planks with wavy grain along u."""
    rng = np.random.default_rng(seed)
    ys, xs = np.mgrid[0:height, 0:width].astype(np.float64)
    plank = (ys // 32).astype(int)
    shade = rng.uniform(0.8, 1.1, plank.max() + 1)[plank]
    grain = 0.5 + 0.5 * np.sin(ys * 0.9 + 3.0 * np.sin(xs * 0.02 + plank))
    base = np.array([0.55, 0.36, 0.2])
    img = base * (0.8 + 0.2 * grain)[..., None] * shade[..., None]
    img[(ys % 32) < 1.5] *= 0.5
    return np.clip(img, 0.0, 1.0).astype(np.float32)


def grass_texture(width: int = 512, height: int = 512, *, stripes: int = 8, line_v: float = 0.45, seed: int = 7) -> np.ndarray:
    """Mown grass: alternating light and dark bands along v, fine noise, a white line across at ``line_v``."""
    rng = np.random.default_rng(seed)
    ys = np.mgrid[0:height, 0:width][0]
    band = (ys * stripes // height) % 2
    img = np.where(band[..., None] == 0, [0.18, 0.42, 0.14], [0.22, 0.5, 0.17])
    img = img * rng.uniform(0.85, 1.1, (height, width, 1))
    img[np.abs(ys - (1.0 - line_v) * height) < 1.5] = (0.9, 0.9, 0.88)
    return np.clip(img, 0.0, 1.0).astype(np.float32)


def crowd_texture(width: int = 1200, height: int = 40, *, seed: int = 11) -> np.ndarray:
    """One row of spectators (for one 0.5 m riser of 60 m: 5 cm per pixel): heads over shirts."""
    rng = np.random.default_rng(seed)
    img = np.empty((height, width, 3))
    img[:] = (0.12, 0.13, 0.18)
    skins = np.array([(0.85, 0.65, 0.5), (0.55, 0.38, 0.25), (0.35, 0.22, 0.15), (0.95, 0.8, 0.65)])
    for cx in range(4, width - 4, 8):
        if rng.random() < 0.12:
            continue  # an empty seat
        x = cx + int(rng.integers(-1, 2))
        top = int(rng.integers(2, 7))
        img[top : top + 8, x - 2 : x + 2] = skins[rng.integers(len(skins))]
        img[top + 8 :, x - 3 : x + 4] = rng.uniform(0.1, 0.95, 3)
    return img.astype(np.float32)
