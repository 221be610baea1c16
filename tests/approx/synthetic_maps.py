"""The tracer's search on light maps written by hand (numpy arrays, not rasterised
geometry), with a numpy oracle: the first crossing of a segment with the surface a
piecewise-constant map holds (one distance per texel), found by dense sampling."""

from __future__ import annotations

import numpy as np

from tests.shared import make_scene, sphere_spec
from volcaustics.approx.layers import LightMap
from volcaustics.approx.light import LightFrustum
from volcaustics.approx.params import ApproxParams
from volcaustics.approx.records import records_from_raw
from volcaustics.approx.trace import PhotonTracer
from volcaustics.scenes.formats import PHOTON_DTYPE, RAW_RECORD_DTYPE, STATUS_COLLIDED, STATUS_SURFACE

# the scene box: light at (0, 3, 0) looking down (cutoff 20°); segments end where they leave it
BOX = (np.array([-2.0, -0.5, -2.0]), np.array([2.0, 4.0, 2.0]))


SPHERE = (np.array([0.0, 1.0, 0.0]), 0.3)  # centre, radius of the scene's glass sphere


def scene():
    """A vacuum scene (segments run to the box) with one glass sphere (finely
    tessellated: its light maps are the exact-chord test's)."""
    return make_scene([(sphere_spec(SPHERE[1], SPHERE[0], 96), 1.5, (0, 0, 0))], sigma_s=0.0)


def frustum():
    return LightFrustum.for_scene(scene(), *BOX)


def light_maps(ctx, distances: np.ndarray, primitive: np.ndarray | None = None,
               geometric_normals: np.ndarray | None = None) -> list:
    """LightMap textures from M×res×res distances (0 = uncovered; rows bottom-up),
    optional primitive ids + 1 of the same shape and octahedral geometric normals
    (M×res×res×2, common/octahedral.glsl)."""
    maps = []
    for m, dist in enumerate(np.asarray(distances, np.float32)):
        res = dist.shape[0]
        surface = np.zeros((res, res, 4), np.float32)
        surface[..., 0] = dist
        geometric = np.zeros((res, res, 4), np.float32)
        if primitive is not None:
            geometric[..., 2] = primitive[m]
        if geometric_normals is not None:
            geometric[..., :2] = geometric_normals[m]
        maps.append(LightMap(ctx.texture((res, res), 4, surface.tobytes(), dtype="f4"),
                             ctx.texture((res, res), 4, geometric.tobytes(), dtype="f4")))
    return maps


def trace_segments(ctx, distances, starts, directions, *, primitive=None, start_ids=None, rendered=None,
                   geometric_normals=None, inside=-1, **params) -> np.ndarray:
    """One interaction step of the real tracer for medium photons at ``starts`` (N×3)
    along unit ``directions`` over the maps ``distances`` (2·layers maps of res×res),
    or over ``rendered`` LightMaps of :func:`scene` (``distances`` then gives their
    count and resolution); returns the N records (RECORD_DTYPE). ``start_ids``: per
    photon the start triangle (id + 1) under the start rule ``id``."""
    distances = np.asarray(distances, np.float32)
    res = distances.shape[1]
    p = ApproxParams(layers=len(distances) // 2, light_res=res, **params)
    sc, fr = scene(), frustum()
    tracer = PhotonTracer(ctx, p)
    maps = rendered or light_maps(ctx, distances, primitive, geometric_normals)
    buffers = tracer.pack_maps(maps, res)
    n = len(starts)
    photons = np.zeros(n, PHOTON_DTYPE)
    photons["pos"][:, :3] = starts
    photons["pos"][:, 3] = float(inside)
    photons["dir"][:, :3] = directions
    photons["dir"][:, 3] = STATUS_COLLIDED if inside < 0 else STATUS_SURFACE
    photons["power"] = [1.0, 1.0, 1.0, 0.0]
    if start_ids is not None:
        photons["power"][:, 3] = start_ids
    pbuf, rbuf = ctx.buffer(photons.tobytes()), ctx.buffer(reserve=n * RAW_RECORD_DTYPE.itemsize)
    tracer.trace_step(sc, fr, BOX, buffers, res, pbuf, rbuf, n, 1, 0)
    records = records_from_raw(np.frombuffer(rbuf.read(), RAW_RECORD_DTYPE), 1, active_only=False)
    for r in ((*maps,) if rendered is None else ()) + (buffers, pbuf, rbuf, tracer):
        r.release()
    return records


def box_exit(starts, directions):
    """Distance to where each ray leaves BOX (the tracer's segment length in vacuum)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        far = np.maximum((BOX[0] - starts) / directions, (BOX[1] - starts) / directions)
    return np.nanmin(far, axis=1)


def image_of(points, res: int):
    """Image coordinates (texel units, x and y) of world points (N×3), and whether the
    tracer searches there: in front of the light and within its clipping margin (half
    a texel in normalised device coordinates, trace.comp.glsl clip_to_frustum)."""
    clip = np.c_[points, np.ones(len(points))] @ frustum().view_proj.T
    ndc = clip[:, :2] / clip[:, 3:4]
    inside = (clip[:, 3] > 0) & np.all(np.abs(ndc) <= 1.0 - 0.5 / res, axis=1)
    return (ndc * 0.5 + 0.5) * res, inside


def texel_of(points, res: int):
    """(map texel x, y) under world points (N×3) and whether the tracer searches there."""
    image, inside = image_of(points, res)
    return np.clip(np.floor(image).astype(np.int64), 0, res - 1), inside


def first_crossing(distances_one_map, start, direction, length, samples=200_000):
    """The oracle on one map: (t, texel x, y) of the first sign change of
    f = |p − light| − D(texel under p) between consecutive covered samples along the
    segment (the texel beyond it), or (nan, -1, -1). Dense sampling in t (float64)."""
    res = distances_one_map.shape[0]
    light = frustum().position
    t = np.linspace(0.0, length, samples)
    points = start + t[:, None] * direction
    texel, inside = texel_of(points, res)
    D = np.where(inside, distances_one_map[texel[:, 1], texel[:, 0]], 0.0)
    covered = D > 0
    f = np.linalg.norm(points - light, axis=1) - D
    change = covered[:-1] & covered[1:] & ((f[:-1] > 0) != (f[1:] > 0))
    if not change.any():
        return np.nan, -1, -1
    i = int(np.argmax(change)) + 1
    return float(t[i]), int(texel[i, 0]), int(texel[i, 1])
