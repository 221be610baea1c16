"""Light maps of analytic spheres against closed-form ray–sphere distances."""

from __future__ import annotations

import numpy as np
import pytest

from tests.shared import make_scene, ray_sphere, shell_spec, sphere_spec
from volcaustics.approx.geometry import SceneGeometry
from volcaustics.approx.layers import LightMapRenderer, decode_normals, levels_needed, read_map
from volcaustics.approx.light import LightFrustum
from volcaustics.scenes.bounds import medium_bounds

RES = 128
CENTER = np.array([0.0, 1.2, 0.0])
SUBDIV = 48


def _setup(ctx, specular, strategy_scene_kwargs=None):
    scene = make_scene(specular, cutoff=25.0, **(strategy_scene_kwargs or {}))
    geo = SceneGeometry.upload(ctx, scene)
    lm = LightMapRenderer(ctx, geo)
    frustum = LightFrustum.for_scene(scene, *medium_bounds(scene))
    return scene, geo, lm, frustum


def _max_sag(mesh, center, radius) -> float:
    """Largest depth of a face plane below the sphere (the polyhedron is inscribed)."""
    tri = mesh.vertices[mesh.faces] - center
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return float(np.max(radius - np.abs(np.einsum("ij,ij->i", n, tri[:, 0]))))


def _tolerance(frustum, dirs, radius, t, sag):
    """Allowed |map − closed form|: rasterisation evaluates the face plane exactly at the
    texel centre, so the only geometric error is the polyhedron's face sag below the
    sphere (measured on the mesh), which a ray at incidence cosine c sees stretched to
    sag / c; plus float32 rounding of distances (~1e-7 relative, 2e-6 allowed)."""
    hit = frustum.position + dirs * t[..., None]
    normal = (hit - CENTER) / radius
    cos_inc = np.abs(np.einsum("...k,...k->...", normal, dirs))
    return sag / np.maximum(cos_inc, 1e-3) + 2e-6 * t, cos_inc


def _check(map_rgba, frustum, expected, radius, sag, mask_cos=0.2):
    dirs = frustum.texel_directions(RES)
    covered = np.isfinite(expected)
    tol, cos_inc = _tolerance(frustum, dirs, radius, np.where(covered, expected, 0.0), sag)
    got = map_rgba[..., 0]
    # Coverage agrees except within one texel of the silhouette (grazing rays).
    stable = covered & (cos_inc > mask_cos)
    assert np.all(got[stable] > 0)
    assert np.all(got[~covered] == 0) or (got[~covered] > 0).sum() < 4 * RES  # silhouette texels only
    err = np.abs(got[stable] - expected[stable])
    assert np.all(err <= tol[stable]), f"max error {err.max():.2e} > tolerance"
    return stable


@pytest.mark.parametrize("strategy", ["threshold", "peel"])
def test_sphere_front_and_back_distances(ctx, strategy):
    radius = 0.5
    scene, geo, lm, frustum = _setup(ctx, [(sphere_spec(radius, CENTER, SUBDIV), 1.5, (0, 0, 0))])
    maps = [read_map(m.surface) for m in lm.render_layers(frustum, RES, 2, strategy)]
    t_in, t_out = ray_sphere(frustum.position, frustum.texel_directions(RES), CENTER, radius)
    sag = _max_sag(scene.specular[0].mesh.load(), CENTER, radius)
    assert sag < 2e-4  # a fine mesh: the check below is about the maps, not the faceting
    stable = _check(maps[0], frustum, t_in, radius, sag)
    _check(maps[1], frustum, t_out, radius, sag)
    # Normals: outward sphere normal at the front hit (octahedral encoding, float32).
    hit = frustum.position + frustum.texel_directions(RES) * t_in[..., None]
    normals = decode_normals(maps[0][..., 2:4])
    dots = np.einsum("...k,...k->...", normals, (hit - CENTER) / radius)
    assert np.all(dots[stable] > 0.999)
    assert np.all(maps[0][..., 1][stable] == 0)  # material id of specular object 0
    if strategy == "peel":  # one convex object: nothing behind the first front/back pair
        assert lm.layer_used[2] is False and lm.layer_used[3] is False
    else:  # threshold level 1 keeps surfaces beyond the mid-plane only
        # front faces seen from a point light end above the equator: level-1 front is empty
        assert lm.layer_used[2] is False and not (maps[2][..., 0] > 0).any()
        beyond = maps[3][..., 0] > 0
        assert beyond.any() and lm.layer_used[3]
        threshold = lm.thresholds(frustum, 2)[1]
        pts = frustum.position + frustum.texel_directions(RES) * maps[3][..., :1]
        assert np.all((pts[beyond] - frustum.position) @ frustum.direction > threshold - 1e-5)
        # where the back surface lies beyond the threshold, level 1 holds exactly it
        both = beyond & (maps[1][..., 0] > 0)
        assert np.allclose(maps[3][..., 0][both], maps[1][..., 0][both])


def test_peel_separates_nested_surfaces(ctx):
    """Hollow shell: along a ray, outer front (F), inner near (B), inner far (F), outer back (B)."""
    outer, inner = 0.5, 0.3
    scene, geo, lm, frustum = _setup(ctx, [(shell_spec(outer, inner, CENTER, SUBDIV), 1.5, (0, 0, 0))])
    maps = [read_map(m.surface) for m in lm.render_layers(frustum, RES, 2, "peel")]
    dirs = frustum.texel_directions(RES)
    o_in, o_out = ray_sphere(frustum.position, dirs, CENTER, outer)
    i_in, i_out = ray_sphere(frustum.position, dirs, CENTER, inner)
    through_cavity = np.isfinite(i_in)
    inner_front = np.where(through_cavity, i_out, np.nan)  # level 1 front: the cavity's far wall
    inner_back = np.where(through_cavity, i_in, o_out)     # level 0 back: cavity's near wall, else outer back
    mesh = scene.specular[0].mesh.load()
    _check(maps[0], frustum, o_in, outer, _max_sag(mesh, CENTER, outer))
    ok = through_cavity
    assert np.all(np.abs(maps[1][..., 0] - inner_back)[ok & (np.abs(dirs @ frustum.direction) > 0.99)] < 0.01)
    core = ok & np.isfinite(inner_front)
    err = np.abs(maps[2][..., 0] - inner_front)
    central = core & (np.abs(dirs @ frustum.direction) > 0.995)
    assert central.sum() > 50 and np.all(err[central] < 0.01)
    err_back = np.abs(maps[3][..., 0] - o_out)
    assert np.all(err_back[central] < 0.01)


@pytest.mark.parametrize("res", [RES, 100])
def test_packed_distances_and_exact_map_ranges(ctx, res):
    """The tracer's packed distance buffer equals the maps' distance channel, and the
    per-map ranges (GPU reduction with uint atomics) equal numpy's min/max over covered texels;
    also at a size that is no multiple of the texels one work group copies (its tail)."""
    from volcaustics.approx.params import ApproxParams
    from volcaustics.approx.trace import PhotonTracer

    scene, geo, lm, frustum = _setup(ctx, [(shell_spec(0.5, 0.3, CENTER, 16), 1.5, (0, 0, 0))])
    textures = lm.render_layers(frustum, res, 2, "peel")
    maps = [read_map(m.surface) for m in textures]
    tracer = PhotonTracer(ctx, ApproxParams(layers=2))
    (texels, distances, geometric, *_), bounds = tracer.map_buffer(textures, res)
    packed = np.frombuffer(distances.read(), np.float32).reshape(len(maps), res, res)
    whole = np.frombuffer(texels.read(), np.float32).reshape(len(maps), res, res, 4)
    for m, (a, b) in enumerate(zip(maps, bounds)):
        assert np.array_equal(packed[m], a[..., 0]) and np.array_equal(whole[m], a)
        covered = a[..., 0][a[..., 0] > 0]
        assert b == (float(covered.min()), float(covered.max()))
    for r in (texels, distances, geometric, *textures):
        r.release()
    tracer.release()


@pytest.mark.parametrize("strategy", ["threshold", "peel"])
def test_geometric_normals_are_the_outward_triangle_normals(ctx, strategy):
    """Every covered texel's geometric normal is the outward face normal of the very
    triangle under it: the texel's surface point lies on that face's plane (to float
    rounding), the normal matches the face's within octahedral float precision, and it
    points outward from the glass (away from the centre on the outer sphere of a shell,
    towards it on the inner one). It also reaches the tracer's storage buffer unchanged."""
    from volcaustics.approx.params import ApproxParams
    from volcaustics.approx.trace import PhotonTracer

    spec = shell_spec(0.5, 0.3, CENTER, 6)  # coarse: faces clearly differ from the shading normals
    scene, geo, lm, frustum = _setup(ctx, [(spec, 1.5, (0, 0, 0))])
    mesh = scene.specular[0].mesh.load()
    faces = mesh.face_normals()
    offsets = np.einsum("ij,ij->i", faces, mesh.vertices[mesh.faces[:, 0]])
    light_maps = lm.render_layers(frustum, RES, 2, strategy)
    tracer = PhotonTracer(ctx, ApproxParams(layers=2))
    (texels, distances, geometric, *_), _ = tracer.map_buffer(light_maps, RES)
    packed = np.frombuffer(geometric.read(), np.float32).reshape(len(light_maps), RES, RES, 2)
    dirs = frustum.texel_directions(RES)
    differs_from_shading = 0
    for m, light_map in enumerate(light_maps):
        surface = read_map(light_map.surface)
        geo_tex = np.frombuffer(light_map.geometric.read(), np.float32).reshape(RES, RES, 4)[..., :2]
        assert np.array_equal(packed[m], geo_tex)
        covered = surface[..., 0] > 0
        points = frustum.position + dirs[covered] * surface[covered][:, :1].astype(np.float64)
        n_geo = decode_normals(geo_tex[covered])
        # the face under the texel: normal within octahedral float precision, point on its plane
        same_normal = n_geo @ faces.T > np.cos(1e-4)
        plane = np.abs(points @ faces.T - offsets)
        assert np.all(np.where(same_normal, plane, np.inf).min(axis=1) < 1e-5)
        radial = np.linalg.norm(points - CENTER, axis=1)
        outward = np.einsum("ij,ij->i", n_geo, points - CENTER)
        assert np.all(outward[radial > 0.4] > 0) and np.all(outward[radial < 0.4] < 0)
        shading = decode_normals(surface[covered][:, 2:])
        differs_from_shading += int((np.einsum("ij,ij->i", shading, n_geo) < np.cos(1e-3)).sum())
    assert differs_from_shading > 0
    for r in (texels, distances, geometric, *light_maps):
        r.release()
    tracer.release(), lm.release(), geo.release()


def test_levels_needed_counts_the_levels_above_the_share():
    """layers = auto's rule on texel counts per peeled level: levels down to the first that
    holds less than the share of the first level's texels; at least one."""
    assert levels_needed([1000, 0, 0]) == 1
    assert levels_needed([1000, 10, 9], share=0.01) == 2  # 10 is 1% of 1000: kept; 9 is below
    assert levels_needed([1000, 500, 200, 49, 0]) == 3  # the default share, 5%: 49 is below 50
    assert levels_needed([0, 0]) == 1  # nothing in the light: the least
    assert levels_needed([1000] * 8) == 8


@pytest.mark.parametrize(("scene_arg", "least", "most"), [
    ("sphere1", 1, 1),  # the negative control: one convex sphere is one front and one back face
    ("coil", 4, 8),  # held out, five turns: up to ten surfaces along the axis
])
def test_auto_layers_follow_the_scenes_depth(ctx, scene_arg, least, most):
    """layers = auto from the occlusion counts of peeled light maps: the minimum on a single
    convex sphere, a level per two surfaces on the coil down to the 5% share (measured: 4 of
    8; its fifth level holds 3.8% of the texels)."""
    from volcaustics.reports.measuring.cost_match import auto_layers
    from volcaustics.scenes.catalogue import HELDOUT_NAMES, heldout_path

    assert least <= auto_layers(heldout_path(scene_arg) if scene_arg in HELDOUT_NAMES else scene_arg, 128) <= most


def test_the_presets_take_layers_from_the_scene_unless_given(ctx):
    """AUTO_LAYERS: the presets best and beams resolve layers per scene (sphere1: 1) before
    their cost match; --layers (layers_given) keeps the preset's; the paper's does not."""
    from volcaustics.approx.params import preset
    from volcaustics.reports.measuring.cost_match import with_auto_values

    beams = preset("beams", light_res=64)
    assert with_auto_values("sphere1", beams, "beams", given=True).layers == 1
    assert with_auto_values("sphere1", beams, "beams", given=True, layers_given=True).layers == beams.layers == 2
    assert with_auto_values("sphere1", preset("quick"), "quick", given=True).layers == 4
