"""Regenerate the ``quarry`` example scene: a long-lens shot with a strongly non-planar background.

Run from anywhere: ``python examples/scenes/quarry/make.py``. Deterministic (fixed seeds, numpy and
Vergence's own writers only); it rewrites ``scene.json`` and every mesh and texture beside it.

The layout (world +y up, metres; the camera 1.8 m up at the origin looking down -z, 12 degrees):

- **subject group, 27-34 m**: a person (striped jersey, trousers, arms, head) with a ball, a boulder
  to the left, a banded post with a patterned sign to the right;
- **ground**: a tiled grass-and-soil texture (4 m repeat) from the camera to 115 m;
- **background, 45-90 m**: a hillside whose foot runs in and out between about 50 and 76 m (two
  ridges across the view, oblique gullies) and recedes as it rises, boulders lying on it, conifers
  and bushes standing 4-15 m in front of it at different depths;
- **sky**: a small HDR gradient with a sun, which lights everything (Lambertian, view-independent).

This is the held-out report scene of the stereoscopic zoom rigs (S0 §5-7): unlike the built-in
stadium's flat bleachers, large parts of this background are seen by the virtual eyes of a
Quadri-Rig but by none of its real cameras (S0 §7, Fig. 12). Everything is textured (PSNR needs
texture, not flat colour); texture noise is periodic (tiles without seams) and band-limited to
wavelengths of 4 texels or more, so the renders do not alias much.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from vergence.io import write_image
from vergence.render._procedural import lathe

HERE = Path(__file__).resolve().parent

CAMERA = {"position": [0.0, 1.8, 0.0], "look_at": [0.0, 1.5, -30.0], "up": [0, 1, 0], "fov_deg": 12.0,
          "width": 480, "height": 270}  # fmt: skip
GROUND_REPEAT = 4.0  # metres per texture tile on the ground (256 px: 1.6 cm per texel)
HILL_REPEAT = 8.0  # metres per texture tile on the hillside (256 px: 3 cm per texel)
HILL_X = (-45.0, 45.0)
HILL_Y = (-1.0, 16.0)  # starts below the ground: no gap at its foot


# ----------------------------------------------------------------------------- textures
def _noise(rng: np.random.Generator, height: int, width: int, *, beta: float = 1.6, min_wavelength: float = 4.0) -> np.ndarray:
    """Periodic fractal noise (tiles seamlessly), amplitude ~ f^-beta, no wavelengths under ``min_wavelength`` px."""
    fy = np.fft.fftfreq(height)[:, None]
    fx = np.fft.rfftfreq(width)[None, :]
    f = np.hypot(fx, fy)
    amp = np.where(f > 0, np.maximum(f, 1.0 / max(height, width)) ** -beta, 0.0)
    amp *= np.exp(-((f * min_wavelength) ** 4))  # a soft low-pass at 1 / min_wavelength
    field = np.fft.irfft2(np.fft.rfft2(rng.standard_normal((height, width))) * amp, s=(height, width))
    return (field - field.mean()) / field.std()


def _mix(a, b, t):
    t = np.clip(t, 0.0, 1.0)[..., None]
    return (1 - t) * np.asarray(a, dtype=float) + t * np.asarray(b, dtype=float)


def _tex(img: np.ndarray) -> np.ndarray:
    return np.clip(img, 0.0, 1.0).astype(np.float32)


def ground_texture(rng: np.random.Generator, n: int = 256) -> np.ndarray:
    grass = _mix([0.16, 0.36, 0.1], [0.32, 0.5, 0.16], 0.5 + 0.3 * _noise(rng, n, n, beta=1.2))
    soil = _mix([0.3, 0.22, 0.13], [0.48, 0.38, 0.26], 0.5 + 0.3 * _noise(rng, n, n, beta=1.0))
    patches = 0.5 + 0.6 * _noise(rng, n, n, beta=2.2)
    return _tex(_mix(grass, soil, patches) * (1 + 0.2 * _noise(rng, n, n, beta=0.5))[..., None])


def hill_texture(rng: np.random.Generator, n: int = 256) -> np.ndarray:
    ys = np.arange(n)[:, None] * np.ones((1, n))
    warp = 6.0 * _noise(rng, n, n, beta=2.0)
    strata = 0.5 + 0.5 * np.sin(2 * np.pi * (ys + warp) / (n / 16))  # 16 rock layers per tile
    rock = _mix([0.42, 0.36, 0.3], [0.7, 0.64, 0.55], strata * (0.7 + 0.2 * _noise(rng, n, n, beta=1.0)))
    green = _mix([0.14, 0.3, 0.09], [0.3, 0.45, 0.14], 0.5 + 0.3 * _noise(rng, n, n, beta=1.0))
    cover = 0.5 + 0.8 * _noise(rng, n, n, beta=2.4)
    return _tex(_mix(rock, green, cover) * (1 + 0.22 * _noise(rng, n, n, beta=0.4))[..., None])


def granite_texture(rng: np.random.Generator, n: int = 128) -> np.ndarray:
    base = _mix([0.5, 0.42, 0.38], [0.72, 0.62, 0.55], 0.5 + 0.3 * _noise(rng, n, n, beta=1.4))
    speck = _noise(rng, n, n, beta=0.2, min_wavelength=2.5)
    base[speck > 1.3] = (0.15, 0.13, 0.14)
    base[speck < -1.5] = (0.9, 0.88, 0.85)
    return _tex(base)


def foliage_texture(rng: np.random.Generator, n: int = 128, *, tint=(0.1, 0.3, 0.1)) -> np.ndarray:
    leaves = 0.5 + 0.35 * _noise(rng, n, n, beta=0.8, min_wavelength=3.0)
    return _tex(_mix(np.asarray(tint) * 0.45, np.asarray(tint) * 1.8 + 0.05, leaves))


def bark_texture(rng: np.random.Generator, w: int = 64, h: int = 128) -> np.ndarray:
    xs = np.arange(w)[None, :] * np.ones((h, 1))
    grooves = 0.5 + 0.5 * np.sin(2 * np.pi * (xs + 3 * _noise(rng, h, w, beta=2.0)) / 8)
    return _tex(_mix([0.16, 0.11, 0.07], [0.45, 0.34, 0.24], grooves * (0.8 + 0.2 * _noise(rng, h, w))))


def jersey_texture(rng: np.random.Generator, n: int = 128) -> np.ndarray:
    ys = np.arange(n)[:, None] * np.ones((1, n))
    band = (ys // (n / 8)).astype(int) % 2  # 8 horizontal stripes
    img = np.where(band[..., None] == 0, [0.9, 0.45, 0.08], [0.1, 0.2, 0.6])
    return _tex(img * (1 + 0.12 * _noise(rng, n, n, beta=0.8))[..., None])


def cloth_texture(rng: np.random.Generator, n: int = 64, *, color=(0.15, 0.2, 0.35)) -> np.ndarray:
    weave = 0.5 + 0.3 * _noise(rng, n, n, beta=0.6, min_wavelength=3.0)
    return _tex(_mix(np.asarray(color) * 0.6, np.asarray(color) * 1.6, weave))


def post_texture(rng: np.random.Generator, w: int = 32, h: int = 128) -> np.ndarray:
    ys = np.arange(h)[:, None] * np.ones((1, w))
    band = (ys // (h / 8)).astype(int) % 2
    img = np.where(band[..., None] == 0, [0.85, 0.1, 0.1], [0.92, 0.92, 0.9])
    return _tex(img * (1 + 0.08 * _noise(rng, h, w, beta=0.8))[..., None])


def sign_texture(rng: np.random.Generator, w: int = 192, h: int = 128) -> np.ndarray:
    """Coloured tiles, each with a dark disc, bar or triangle: sharp, distinct edges."""
    ys, xs = np.mgrid[0:h, 0:w].astype(float)
    tiles, img = 32, np.empty((h, w, 3))
    cols = rng.uniform(0.3, 0.95, (h // tiles, w // tiles, 3))
    img[:] = cols[(ys // tiles).astype(int), (xs // tiles).astype(int)]
    u, v = (xs % tiles) - tiles / 2, (ys % tiles) - tiles / 2
    kind = ((ys // tiles) * 3 + (xs // tiles)).astype(int) % 3
    disc = np.hypot(u, v) < tiles * 0.3
    bar = (np.abs(u) < tiles * 0.35) & (np.abs(v) < tiles * 0.1)
    tri = (v > -tiles * 0.3) & (v < tiles * 0.3) & (np.abs(u) < (v + tiles * 0.3) * 0.6)
    mark = np.where(kind == 0, disc, np.where(kind == 1, bar, tri))
    img[mark] = (0.08, 0.08, 0.12)
    img[((xs % tiles) < 1.5) | ((ys % tiles) < 1.5)] = (0.2, 0.2, 0.2)
    return _tex(img)


def sky_hdr(width: int = 128, height: int = 64) -> np.ndarray:
    """Equirectangular sky (row 0 at the zenith, centre column facing -z): blue zenith, pale horizon, a sun."""
    elevation = (0.5 - (np.arange(height) + 0.5) / height) * np.pi
    phi = ((np.arange(width) + 0.5) / width - 0.5) * 2 * np.pi
    t = np.clip(elevation / (np.pi / 2), 0.0, 1.0)[:, None, None] ** 0.6
    img = ((1 - t) * np.array([1.4, 1.35, 1.25]) + t * np.array([0.3, 0.5, 1.0])) * np.ones((1, width, 1))
    img[elevation < 0] = (0.25, 0.23, 0.2)
    dirs = np.stack([np.cos(elevation)[:, None] * np.sin(phi)[None], np.sin(elevation)[:, None] * np.ones((1, width)),
                     -np.cos(elevation)[:, None] * np.cos(phi)[None]], axis=-1)  # fmt: skip
    el, az = np.radians(35.0), np.radians(-50.0)  # the sun: 35 degrees up, behind-left of the camera's view
    sun = np.array([np.cos(el) * np.sin(az), np.sin(el), np.cos(el) * np.cos(az)])
    img[dirs @ sun > np.cos(np.radians(4.0))] = (30.0, 28.0, 24.0)
    return img.astype(np.float32)


# ----------------------------------------------------------------------------- meshes
_BUMPS = np.random.default_rng(21).uniform([0.3, 0.3, 0.0], [1.2, 1.2, 6.0], (4, 3))  # (a, b, phase) of 4 waves


def hill_front(x: np.ndarray | float, y: np.ndarray | float = 0.0) -> np.ndarray:
    """Distance (metres, along -z) of the hillside at (x, y): two ridges, oblique gullies, receding upwards."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    s = x + 0.45 * y  # ridges lean: gullies run obliquely up the slope
    ridge = 9.0 * np.sin(2 * np.pi * s / 22.0 + 0.5) + 4.0 * np.sin(2 * np.pi * s / 9.0 + 1.3)
    bumps = 0.6 * sum(np.sin(a * x + b * y + c) for a, b, c in _BUMPS)
    return 63.0 + ridge + bumps + 1.2 * y + 0.08 * y**2


def hill_mesh(nx: int = 91, ny: int = 25) -> dict:
    X, Y = np.meshgrid(np.linspace(*HILL_X, nx), np.linspace(*HILL_Y, ny))  # (ny, nx)
    verts = np.stack([X, Y, -hill_front(X, Y)], axis=-1)
    # v follows the arc length up each column (the slope is mostly depth, not height).
    step = np.linalg.norm(np.diff(verts, axis=0), axis=-1)
    arc = np.vstack([np.zeros((1, nx)), np.cumsum(step, axis=0)])
    uv = np.stack([X / HILL_REPEAT, arc / HILL_REPEAT], axis=-1)
    idx = np.arange(nx * ny).reshape(ny, nx)
    a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]
    faces = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    return _facing(verts.reshape(-1, 3), faces, uv.reshape(-1, 2), toward=(0.0, 0.0, 1.0))


def ground_mesh() -> dict:
    x0, x1, z0, z1 = -60.0, 60.0, 5.0, -115.0
    verts = np.array([[x0, 0, z0], [x1, 0, z0], [x1, 0, z1], [x0, 0, z1]])
    uv = np.stack([verts[:, 0], -verts[:, 2]], axis=1) / GROUND_REPEAT
    return _facing(verts, np.array([[0, 1, 2], [0, 2, 3]]), uv, toward=(0.0, 1.0, 0.0))


def boulder_mesh(segments: int = 32, rings: int = 16) -> dict:
    """A unit lumpy rock: a sphere with smooth radial bumps (functions of the 3D direction: no seam)."""
    mesh = lathe([(np.sin(a), -np.cos(a)) for a in np.linspace(0.0, np.pi, rings + 1)], base=(0, 0, 0),
                 material="rock", segments=segments)  # fmt: skip
    d = mesh.vertices / np.linalg.norm(mesh.vertices, axis=1, keepdims=True)
    rng = np.random.default_rng(5)
    axes = rng.normal(size=(6, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    radius = 1.0 + 0.08 * np.sin(3.0 * d @ axes.T + rng.uniform(0, 6, 6)).sum(axis=1)
    verts = d * radius[:, None]
    return {"vertices": verts, "faces": mesh.faces, "uv": mesh.uv * (3.0, 1.5)}


def _revolved(profile, *, u_repeat: float, v_repeat: float, segments: int = 32) -> dict:
    mesh = lathe(profile, base=(0, 0, 0), material="m", segments=segments)
    return {"vertices": mesh.vertices, "faces": mesh.faces, "uv": mesh.uv * (u_repeat, v_repeat),
            "normals": mesh.normals}  # fmt: skip


def _facing(verts, faces, uv, *, toward) -> dict:
    """Wind the faces counter-clockwise seen from the side ``toward`` points to."""
    v = verts[faces]
    n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    if float((n @ np.asarray(toward)).sum()) < 0:
        faces = faces[:, ::-1]
    return {"vertices": verts, "faces": faces, "uv": uv}


def _signed_volume(mesh: dict) -> float:
    v = mesh["vertices"][mesh["faces"]]
    return float(np.einsum("ij,ij->i", v[:, 0], np.cross(v[:, 1], v[:, 2])).sum() / 6.0)


def write_obj(path: Path, mesh: dict, comment: str) -> None:
    lines = [f"# {comment} (generated by make.py)"]
    lines += [f"v {x:.4f} {y:.4f} {z:.4f}" for x, y, z in mesh["vertices"]]
    lines += [f"vt {u:.4f} {v:.4f}" for u, v in mesh["uv"]]
    if "normals" in mesh:
        lines += [f"vn {x:.4f} {y:.4f} {z:.4f}" for x, y, z in mesh["normals"]]
        lines += ["f " + " ".join(f"{i + 1}/{i + 1}/{i + 1}" for i in f) for f in mesh["faces"]]
    else:
        lines += ["f " + " ".join(f"{i + 1}/{i + 1}" for i in f) for f in mesh["faces"]]
    path.write_text("\n".join(lines) + "\n")


# ----------------------------------------------------------------------------- the scene
def _mesh(path: str, material: str, translate, scale=1.0, rotate_deg=(0, 0, 0), smooth: bool = True) -> dict:
    obj = {"type": "mesh", "path": path, "material": material,
           "transform": {"translate": [round(float(t), 4) for t in translate], "rotate_deg": list(rotate_deg),
                         "scale": scale if np.isscalar(scale) else list(scale)}}  # fmt: skip
    if not smooth:
        obj["smooth"] = False
    return obj


def scene_objects() -> list[dict]:
    objs = [_mesh("ground.obj", "ground", (0, 0, 0), smooth=False), _mesh("hill.obj", "hill", (0, 0, 0))]
    # The subject group: a person at 30 m with a ball, a boulder at 27 m, a post and sign at 33 m.
    px, pz = 0.0, -30.0
    objs += [
        _mesh("cylinder.obj", "trousers", (px - 0.12, 0, pz), (0.09, 0.88, 0.09)),
        _mesh("cylinder.obj", "trousers", (px + 0.12, 0, pz + 0.06), (0.09, 0.88, 0.09)),
        _mesh("torso.obj", "jersey", (px, 0.85, pz)),
        _mesh("cylinder.obj", "skin", (px - 0.33, 0.95, pz), (0.055, 0.5, 0.055), (0, 0, -8)),
        _mesh("cylinder.obj", "skin", (px + 0.33, 0.95, pz + 0.05), (0.055, 0.5, 0.055), (0, 0, 10)),
        {"type": "sphere", "center": [px, 1.62, pz], "radius": 0.12, "material": "skin"},
        {"type": "sphere", "center": [px + 0.5, 0.11, pz + 0.45], "radius": 0.11, "material": "ball"},
        _mesh("boulder.obj", "granite", (-1.35, 0.22, -27.0), (0.5, 0.4, 0.45), (0, 35, 0)),
        _mesh("cylinder.obj", "post", (1.55, 0, -33.0), (0.06, 1.9, 0.06)),
        {"type": "rectangle", "center": [1.55, 1.55, -32.93], "normal": [-0.15, 0, 1], "up": [0, 1, 0],
         "size": [0.9, 0.6], "material": "sign"},
    ]  # fmt: skip
    # Boulders lying on the hillside (their centres half a radius into the slope).
    for x, y, r, rot in ((-4.0, 0.4, 1.3, 10), (3.5, 1.5, 1.8, 70), (-8.5, 2.5, 2.2, 140), (7.0, 0.3, 1.1, 200)):
        z = -float(hill_front(x, y)) + 0.5 * r
        objs.append(_mesh("boulder.obj", "granite", (x, y, z), (r, 0.8 * r, r), (0, rot, 0)))
    # Conifers (45-65 m) and bushes (50-64 m), 4-15 m in front of the hillside.
    for x, ahead, height in ((-4.6, 7.0, 7.0), (3.9, 6.0, 6.0), (-0.9, 15.0, 8.0), (6.8, 9.0, 7.5), (-8.0, 5.0, 6.5)):
        z = -float(hill_front(x)) + ahead
        objs.append(_mesh("cylinder.obj", "bark", (x, -0.2, z), (0.18, 2.2, 0.18)))
        objs.append(_mesh("cone.obj", "conifer", (x, 1.6, z), (0.19 * height, height - 1.6, 0.19 * height)))
    for x, ahead, r in ((-2.6, 9.0, 0.9), (1.6, 11.0, 1.1), (5.2, 4.0, 0.8)):
        z = -float(hill_front(x)) + ahead
        objs.append({"type": "sphere", "center": [x, 0.55 * r, round(z, 4)], "radius": r, "material": "bush"})
    return objs


def main() -> None:
    rng = np.random.default_rng(2026)
    textures = {
        "ground": ground_texture(rng), "hill": hill_texture(rng), "granite": granite_texture(rng),
        "conifer": foliage_texture(rng, tint=(0.08, 0.26, 0.1)), "bush": foliage_texture(rng, tint=(0.2, 0.34, 0.08)),
        "bark": bark_texture(rng), "jersey": jersey_texture(rng), "trousers": cloth_texture(rng),
        "skin": cloth_texture(rng, n=32, color=(0.62, 0.44, 0.32)), "post": post_texture(rng),
        "sign": sign_texture(rng),
    }  # fmt: skip
    for name, image in textures.items():
        write_image(HERE / f"{name}.png", image)
    write_image(HERE / "sky.hdr", sky_hdr())

    meshes = {
        "ground.obj": (ground_mesh(), "ground: 120 x 120 m, texture every 4 m"),
        "hill.obj": (hill_mesh(), "hillside 50-90 m away: ridges, gullies, receding slope"),
        "boulder.obj": (boulder_mesh(), "unit lumpy rock"),
        "cylinder.obj": (_revolved([(0, 0), (1, 0), (1, 0), (1, 1), (1, 1), (0, 1)], u_repeat=2, v_repeat=1),
                         "unit capped cylinder, base at 0, top at 1"),
        "cone.obj": (_revolved([(0, 0), (1, 0), (1, 0), (0, 1)], u_repeat=3, v_repeat=2), "unit cone"),
        "torso.obj": (_revolved([(0, 0), (0.19, 0), (0.2, 0.06), (0.23, 0.35), (0.25, 0.55), (0.12, 0.66), (0, 0.68)],
                                u_repeat=1, v_repeat=1), "torso, 0.68 m"),
    }  # fmt: skip
    for name, (mesh, comment) in meshes.items():
        if name not in ("ground.obj", "hill.obj"):  # closed solids: outward winding
            assert _signed_volume(mesh) > 0, name
        write_obj(HERE / name, mesh, comment)

    materials = {name: {"type": "texture", "path": f"{name}.png"} for name in textures}
    materials["ball"] = {"type": "checker", "colors": [[0.95, 0.95, 0.92], [0.08, 0.08, 0.1]], "squares": [8, 4]}
    scene = {
        "name": "quarry",
        "description": "Long-lens held-out scene with a non-planar background: a person, a boulder and a post "
                       "27-34 m away; a ridged hillside 50-90 m away with boulders, conifers and bushes 45-70 m "
                       "away; textured ground; HDR sky. Regenerate with make.py.",
        "camera": CAMERA,
        "stereo": {"baseline": 0.5, "convergence": 30.0},
        "environment": {"hdr": "sky.hdr", "intensity": 1.0},
        "materials": materials,
        "objects": scene_objects(),
    }  # fmt: skip
    _write_scene(HERE / "scene.json", scene)


def _write_scene(path: Path, scene: dict) -> None:
    """JSON with one material and one object per line (readable diffs)."""
    head = {k: v for k, v in scene.items() if k not in ("materials", "objects")}
    lines = ["{"] + [f"  {json.dumps(k)}: {json.dumps(v)}," for k, v in head.items()]
    mats = [f"    {json.dumps(k)}: {json.dumps(v)}" for k, v in scene["materials"].items()]
    lines += ['  "materials": {', ",\n".join(mats), "  },", '  "objects": [']
    lines += [",\n".join(f"    {json.dumps(o)}" for o in scene["objects"]), "  ]", "}"]
    path.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
