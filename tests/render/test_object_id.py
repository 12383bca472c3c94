"""The ray tree names the object each node's ray hit (``object_id``): checked against the scene's geometry."""

from __future__ import annotations

import numpy as np
import pytest

from vergence.render import RenderResult, Sphere, Tracer, builtin_scene

# float32 positions of a sphere ~1 m across: a hit lies on its surface to a few micrometres
ON_SURFACE_M = 1e-4


@pytest.fixture(scope="module")
def glasses():
    scene = builtin_scene("glasses", width=40, height=30)
    return scene, Tracer(scene).render(samples=1, max_depth=2)


def test_object_id_marks_exactly_the_nodes_with_a_hit(glasses):
    _, result = glasses
    oid = result.object_id
    assert oid.shape == result.position.shape[:3] and oid.dtype == np.int32
    np.testing.assert_array_equal(oid >= 0, np.isfinite(result.position).all(axis=-1))
    assert not oid.flags.writeable


def test_each_sphere_hit_lies_on_that_sphere(glasses):
    scene, result = glasses
    checked = 0
    for index, obj in enumerate(scene.objects):
        if not isinstance(obj, Sphere):
            continue
        hit = result.object_id == index
        if not hit.any():
            continue
        radius = np.linalg.norm(result.position[hit].astype(np.float64) - obj.center, axis=-1)
        np.testing.assert_allclose(radius, obj.radius, atol=ON_SURFACE_M)
        checked += int(hit.sum())
    assert checked > 100


def test_trace_rays_gives_the_same_ids_as_render(glasses):
    scene, result = glasses
    from vergence.render.rays import camera_rays

    rays = camera_rays(scene.camera.build())
    tree = Tracer(scene).trace_rays(rays.origins, rays.directions, max_depth=2, samples=1,
                                    shape=(result.camera.height, result.camera.width))  # fmt: skip
    np.testing.assert_array_equal(tree.object_id, result.object_id)


def test_a_bad_object_id_is_refused(glasses):
    _, r = glasses
    fields = dict(radiance=np.array(r.radiance), position=np.array(r.position), normal=np.array(r.normal),
                  depth=np.array(r.depth), beauty=np.array(r.beauty), camera=r.camera, settings=r.settings)  # fmt: skip
    assert RenderResult(**fields).object_id is None  # not known: allowed
    with pytest.raises(ValueError, match="object_id must have shape"):
        RenderResult(**fields, object_id=np.zeros((2, 3, 4), np.int32))
    with pytest.raises(TypeError, match="object_id must be an integer numpy array"):
        RenderResult(**fields, object_id=np.zeros(r.position.shape[:3], np.float32))
