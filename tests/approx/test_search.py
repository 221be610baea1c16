"""The searches of `search` (bisection, secant, dda, hiz) and the start rules of
`start_rule` on light maps written by hand (tests/approx/synthetic_maps.py): the
paper's Fig. 2 cases, a thin wall, a grazing segment, dda = hiz on random segments,
map_reads against a count, and the hit point's error against the exact chord."""

from __future__ import annotations

import numpy as np
import pytest

from tests.approx import synthetic_maps as sm

SEARCHES = ("bisection", "secant", "dda", "hiz")
SAMPLED = ("bisection", "secant")
RES = 64


def _surface_t(start, direction, radius):
    """Where the segment first meets the sphere of ``radius`` about the light, after
    its start (the surface a map of constant distance holds), and the other root."""
    q = np.asarray(start, np.float64) - sm.frustum().position
    qd = q @ direction
    disc = qd * qd - (q @ q - radius * radius)
    return -qd - np.sqrt(disc), -qd + np.sqrt(disc)


def _unit(v):
    v = np.asarray(v, np.float64)
    return v / np.linalg.norm(v)


def _light_point(r, x=0.0, z=0.0):
    """A point at distance about r below the light (shifted by x, z in world)."""
    return sm.frustum().position + np.array([x, -r, z])


def _one(maps, start, direction, search, **params):
    return sm.trace_segments(_ctx(), maps, np.array([start]), np.array([direction]), search=search, **params)[0]


_CTX = []


def _ctx():
    return _CTX[0]


@pytest.fixture(autouse=True)
def _context(ctx):
    _CTX[:] = [ctx]
    yield


def _maps(front, back=None):
    back = np.zeros_like(front) if back is None else back
    return np.stack([front, back]).astype(np.float32)


def _texel_x_world():
    """World x of each texel centre's light ray at unit depth below the light (res×res)."""
    return sm.frustum().texel_directions(RES)[..., 0]


@pytest.mark.parametrize("search", SEARCHES)
def test_case_a_one_crossing(search):
    """Fig. 2 A: a surface everywhere at 2 m from the light; the segment crosses it once
    inside a texel. Every search finds that root (float rounding: 1e-4 m)."""
    start, d = _light_point(1.5, x=-0.2), _unit([0.3, -1.0, 0.1])
    rec = _one(_maps(np.full((RES, RES), 2.0)), start, d, search)
    assert rec["hit"] and rec["map"] == 0
    assert rec["t"] == pytest.approx(_surface_t(start, d, 2.0)[1], abs=1e-4)


@pytest.mark.parametrize("search", SEARCHES)
def test_case_b_several_crossings_the_first(search):
    """Fig. 2 B: 2 m left of x = 0, 2.6 m right of it: the segment crosses 2 m, crosses
    back at x = 0 (the map's edge between the two) and crosses 2.6 m later. The first
    crossing wins (the samples straddle only it)."""
    front = np.where(_texel_x_world() < 0.0, 2.0, 2.6)
    start, d = _light_point(1.5, x=-0.3), _unit([0.25, -1.0, 0.0])
    first = _surface_t(start, d, 2.0)[1]
    assert (start + first * d)[0] < -0.05  # the first crossing lies left of x = 0
    rec = _one(_maps(front), start, d, search)
    assert rec["hit"] and rec["t"] == pytest.approx(first, abs=1e-4)


@pytest.mark.parametrize("search", SEARCHES)
def test_case_c_no_crossing(search):
    """Fig. 2 C: the surface (2 m) exists only left of x = −0.5; the segment meets 2 m
    only where the map is empty: no hit, for every search."""
    front = np.where(_texel_x_world() < -0.5, 2.0, 0.0)
    start, d = _light_point(1.5, x=0.1), _unit([0.2, -1.0, 0.0])
    rec = _one(_maps(front), start, d, search)
    assert not rec["hit"]


def _samples_image_y(start, d, res=RES):
    """Image y (texel units; world x under this light) of the sampled searches' interior
    samples: uniform along the clipped segment's projection
    (trace/search_samples.glsl), peak_samples = 8."""
    length = sm.box_exit(start[None], d[None])[0]
    t = np.linspace(0.0, length, 200_001)
    image, inside = sm.image_of(start + t[:, None] * d, res)
    ends = image[inside][[0, -1], 1]
    return ends[0] + (ends[1] - ends[0]) * np.arange(1, 9) / 9.0


@pytest.mark.parametrize("search", SEARCHES)
def test_case_d_peak_between_samples(search):
    """Fig. 2 D: a surface 1 m from the light in one texel row between two samples
    (the paper's failure case), 2 m elsewhere; the segment runs at about 1.4 m. The
    texel walks find the row's near edge; the sampled searches miss it."""
    start, d = _light_point(1.4, x=-0.45), _unit([1.0, -0.05, 0.0])
    ys = _samples_image_y(start, d)
    row = int(np.floor(0.5 * (ys[3] + ys[4])))
    assert min(abs(ys - row)).item() > 1.5  # no sample near the row
    front = np.full((RES, RES), 2.0)
    front[row, :] = 1.0
    rec = _one(_maps(front), start, d, search)
    if search in SAMPLED:
        assert not rec["hit"]
        return
    t_oracle, _, y = sm.first_crossing(front, start, d, sm.box_exit(start[None], d[None])[0])
    assert rec["hit"] and y == row
    assert rec["t"] == pytest.approx(t_oracle, abs=2e-4)


@pytest.mark.parametrize("search", SAMPLED)
def test_crossing_at_a_later_coverage_edge_before_a_sign_change(search):
    """Three islands of coverage along the segment, one sample gap between each (the
    segment runs at about 1.4 m): the first (2 m) holds no crossing at its edges; the
    second holds one between its last sample and where its coverage ends (1 m in its
    last rows); the third a sign change between two samples (2 m, then 1 m). The
    second island's crossing is first and is found (the scan's edges are searched in
    order; a search that took the first sign change between samples finds the third)."""
    start, d = _light_point(1.4, x=-0.45), _unit([1.0, -0.05, 0.0])
    ys = _samples_image_y(start, d)
    def past(y):  # the texel rows past image y along the segment
        return np.sign(ys[1] - ys[0]) * (np.arange(RES) + 0.5 - y) >= 0

    mid = 0.5 * (ys[:-1] + ys[1:])  # halfway between samples k and k + 1
    front = np.zeros((RES, RES))
    front[past(mid[0]) & ~past(mid[2])] = 2.0                         # island one: samples 1, 2
    front[past(mid[3]) & ~past(mid[4])] = 2.0                         # island two: sample 4 ...
    front[past(0.5 * (ys[4] + mid[4])) & ~past(mid[4])] = 1.0        # ... 1 m in its last rows
    front[past(mid[5])] = 2.0                                         # island three: 6, 7 ...
    front[past(mid[6])] = 1.0                                         # ... 1 m from halfway
    for k in (0, 3, 5):
        assert front[int(ys[k]), 0] == 0.0  # a sample in every gap
    t_oracle, _, y = sm.first_crossing(front, start, d, sm.box_exit(start[None], d[None])[0])
    assert past(ys[4])[y] and not past(mid[4])[y]  # the oracle's first crossing: island two's
    rec = _one(_maps(front), start, d, search)
    assert rec["hit"] and rec["t"] == pytest.approx(t_oracle, abs=2e-4)


@pytest.mark.parametrize("search", SEARCHES)
def test_crossing_surface_passes_over_a_jump_between_two_surfaces(search):
    """One map, along a segment at about 1.4 m: a near surface (1 m: the segment runs
    behind it), then a far one (2 m: in front of it), then a surface sloping from 1.7 m
    towards the light, 0.02 m per texel, facing it. f changes sign where the near
    surface ends, at no surface: `crossing` = sign (the paper) takes that jump;
    `surface` passes it over and finds where the segment meets the slope."""
    start, d = _light_point(1.4, x=-0.45), _unit([1.0, -0.05, 0.0])
    ys = _samples_image_y(start, d)
    along = np.sign(ys[1] - ys[0]) * (np.arange(RES) + 0.5)  # each texel row's position along the segment
    mid = np.sign(ys[1] - ys[0]) * 0.5 * (ys[:-1] + ys[1:])  # ... of the points halfway between samples
    front = np.ones((RES, RES))                                            # samples 1, 2
    front[along >= mid[1]] = 2.0                                           # samples 3, 4, 5
    slope = along >= mid[4]                                                # samples 6, 7, 8
    front[slope] = (1.7 - 0.02 * (along - mid[4]))[slope, None]
    facing_light = np.zeros((2, RES, RES, 2), np.float32)
    facing_light[..., 1] = 1.0  # octahedral (0, 1, 0): up, towards the light
    length = sm.box_exit(start[None], d[None])[0]
    t_jump, _, y_jump = sm.first_crossing(front, start, d, length)
    t_slope, _, y_slope = sm.first_crossing(np.where(slope[:, None], front, 0.0), start, d, length)
    assert not slope[y_jump] and slope[y_slope] and t_jump < t_slope  # a jump first, then the slope
    maps = _maps(front, front * 0.0)
    paper = sm.trace_segments(_ctx(), maps, np.array([start]), np.array([d]), search=search,
                              geometric_normals=facing_light)[0]
    surface = sm.trace_segments(_ctx(), maps, np.array([start]), np.array([d]), search=search, crossing="surface",
                                geometric_normals=facing_light)[0]
    assert paper["hit"] and paper["t"] == pytest.approx(t_jump, abs=2e-4)
    assert surface["hit"] and surface["t"] == pytest.approx(t_slope, abs=2e-4)


@pytest.mark.parametrize("search", SEARCHES)
def test_thin_wall_front_map_first(search):
    """A shell wall thinner than a texel footprint: front map at 2 m, back map 1 mm
    beyond. The front crossing wins, on map 0."""
    start, d = _light_point(1.5, x=-0.1), _unit([0.2, -1.0, 0.3])
    rec = _one(_maps(np.full((RES, RES), 2.0), np.full((RES, RES), 2.001)), start, d, search)
    assert rec["hit"] and rec["map"] == 0
    assert rec["t"] == pytest.approx(_surface_t(start, d, 2.0)[1], abs=1e-4)


@pytest.mark.parametrize("search", SEARCHES)
def test_grazing_segment(search):
    """A segment that dips 5 mm below the 2 m surface and comes back (two roots 0.2 m
    apart). The texel walks find the first root; a sampled search finds the first root
    or nothing, never the second."""
    light = sm.frustum().position
    d = _unit([1.0, 0.0, 0.2])
    closest = light + np.array([0.0, -1.995, 0.0])
    start = closest - 0.15 * d
    q = start - light
    first = -(q @ d) - np.sqrt((q @ d) ** 2 - (q @ q - 4.0))
    second = -(q @ d) + np.sqrt((q @ d) ** 2 - (q @ q - 4.0))
    assert 0 < first < second
    rec = _one(_maps(np.full((RES, RES), 2.0)), start, d, search)
    if search in SAMPLED and not rec["hit"]:
        return
    assert rec["hit"] and rec["t"] == pytest.approx(first, abs=2e-3)


def _wavy_maps():
    """Two maps: a wavy surface about 2 m from the light with a hole, and a second one
    0.3 m beyond it, covering only the left half."""
    yy, xx = np.mgrid[0:RES, 0:RES] / RES
    front = 2.0 + 0.3 * np.sin(7 * xx) * np.cos(5 * yy) + 0.1 * np.sin(23 * xx + 11 * yy)
    front[(xx - 0.3) ** 2 + (yy - 0.6) ** 2 < 0.02] = 0.0
    back = np.where(xx < 0.5, front + 0.3, 0.0)
    return np.stack([front, back]).astype(np.float32)


def _random_segments(n, seed):
    rng = np.random.default_rng(seed)
    fr = sm.frustum()
    starts = fr.position + fr.direction * rng.uniform(0.5, 3.0, n)[:, None] + rng.normal(0, 0.4, (n, 3)) * [1, 0, 1]
    d = rng.normal(size=(n, 3))
    return starts, d / np.linalg.norm(d, axis=1, keepdims=True)


def test_dda_and_hiz_find_the_same_crossings(ctx):
    """On 4000 random segments over two maps (holes, a half-covered map) the Hi-Z walk
    ends where the DDA does: same hit and map, t to a float ulp (a texel entered after a
    skipped cell gets its entry from the cell's edge, rounded once more: 36 of ~600 hits
    differ by 1 ulp) — while reading fewer texels."""
    maps = _wavy_maps()
    starts, d = _random_segments(4000, 1)
    dda = sm.trace_segments(ctx, maps, starts, d, search="dda")
    hiz = sm.trace_segments(ctx, maps, starts, d, search="hiz")
    assert dda["hit"].sum() > 500  # many crossings to compare
    np.testing.assert_array_equal(dda["hit"], hiz["hit"])
    np.testing.assert_array_equal(dda["map"], hiz["map"])
    np.testing.assert_allclose(np.nan_to_num(hiz["t"]), np.nan_to_num(dda["t"]), rtol=3e-7, atol=0)
    assert hiz["map_reads"].sum() < 0.8 * dda["map_reads"].sum()


@pytest.mark.slow  # about 12 s on 2 cores (the marker's 10 s and more)
def test_dda_is_the_oracle_at_the_maps_resolution(ctx):
    """The DDA's first crossing on one map equals the dense-sampling oracle's (texel and t
    within the oracle's sampling step) on 300 random segments."""
    maps = _wavy_maps()
    maps[1] = 0.0
    starts, d = _random_segments(300, 2)
    rec = sm.trace_segments(ctx, maps, starts, d, search="dda")
    lengths = sm.box_exit(starts, d)
    for i in range(len(starts)):
        t, _, _ = sm.first_crossing(maps[0], starts[i], d[i], lengths[i])
        assert rec["hit"][i] == (not np.isnan(t)), i
        if rec["hit"][i]:
            assert rec["t"][i] == pytest.approx(t, abs=2 * lengths[i] / 200_000 + 1e-5), i


def test_secant_with_a_bracket_inside_one_texel_is_bisection(ctx):
    """Where the samples bracket a crossing inside one texel (f is smooth there) the
    secant refinement changes nothing: same hit, map, texel surface and t to float
    precision (both converge on the same root)."""
    start, d = _light_point(1.9, x=0.05), _unit([0.05, -1.0, 0.02])
    maps = _maps(np.full((RES, RES), 2.0))
    bis = sm.trace_segments(ctx, maps, np.array([start]), np.array([d]), search="bisection")[0]
    sec = sm.trace_segments(ctx, maps, np.array([start]), np.array([d]), search="secant", iterations=30)[0]
    assert bis["hit"] and sec["hit"] and bis["map"] == sec["map"]
    assert sec["t"] == pytest.approx(bis["t"], rel=1e-6)
    # and it gets there in fewer iterations: 4 secant steps match 30 halvings
    few = sm.trace_segments(ctx, maps, np.array([start]), np.array([d]), search="secant", iterations=4)[0]
    assert few["t"] == pytest.approx(bis["t"], rel=1e-5)


def test_dda_map_reads_are_the_texels_crossed(ctx):
    """A segment whose projection runs along one texel row from the centre of texel x0
    to that of x1 over a covered map it never crosses: the DDA reads |x1 − x0| + 1
    texels, one each; Hi-Z reads fewer."""
    fr = sm.frustum()
    dirs = fr.texel_directions(RES)
    row, x0, x1 = 40, 10, 50
    start = fr.position + dirs[row, x0] * 1.0
    end = fr.position + dirs[row, x1] * 1.3
    d = _unit(end - start)
    # covered everywhere, far beyond the segment; one texel off its row near enough
    # that the map's distance range meets the segment's (else the map is skipped)
    front = np.full((RES, RES), 5.0)
    front[0, 0] = 1.05
    rec = sm.trace_segments(ctx, _maps(front), np.array([start]), np.array([d]), search="dda")[0]
    length = sm.box_exit(start[None], d[None])[0]
    t = np.linspace(0.0, length, 400_001)
    texel, inside = sm.texel_of(start + t[:, None] * d, RES)
    crossed = len(np.unique(texel[inside], axis=0))
    assert not rec["hit"]
    assert int(rec["map_reads"]) == crossed
    hiz = sm.trace_segments(ctx, _maps(front), np.array([start]), np.array([d]), search="hiz")[0]
    assert 0 < int(hiz["map_reads"]) < crossed


@pytest.mark.parametrize("search", SEARCHES)
def test_start_rule_id_passes_over_the_start_triangle(search):
    """Start rule `id`: a photon leaving the surface of triangle 7 (id + 1 = 8) where the
    map shows it slightly beyond the start point. With the start id the crossing onto
    triangle 7 is passed over and the next surface (triangle 9, the back map) is found;
    with another start id the crossing onto triangle 7 is a hit."""
    front, back = np.full((RES, RES), 2.0), np.full((RES, RES), 2.4)
    primitive = np.stack([np.full((RES, RES), 8.0), np.full((RES, RES), 10.0)])
    start, d = _light_point(1.999, x=0.05), _unit([0.1, -1.0, 0.05])
    run = dict(primitive=primitive, search=search, start_rule="id")
    own = sm.trace_segments(_ctx(), _maps(front, back), np.array([start]), np.array([d]), start_ids=[8.0], **run)[0]
    other = sm.trace_segments(_ctx(), _maps(front, back), np.array([start]), np.array([d]), start_ids=[3.0], **run)[0]
    assert other["hit"] and other["map"] == 0
    assert own["hit"] and own["map"] == 1
    assert own["t"] == pytest.approx(_surface_t(start, d, 2.4)[1], abs=1e-4)


@pytest.mark.parametrize("search", SEARCHES)
def test_hit_point_error_within_texel_footprints_of_the_exact_chord(ctx, search):
    """Rasterised maps of a glass sphere (96 subdivisions): 2000 segments aimed at its
    lit side. Each hit's distance to the light is off the true sphere's along the same
    light ray by at most one texel diagonal's worth of the surface's slope (a crossing
    at a texel's edge takes the neighbour's distance): √2 · footprint · tan θ, plus the
    tessellation's sagitta and float rounding (2e-4 m)."""
    from tests.shared import ray_sphere
    from volcaustics.approx.geometry import SceneGeometry
    from volcaustics.approx.layers import LightMapRenderer

    res = 256
    fr = sm.frustum()
    geometry = SceneGeometry.upload(ctx, sm.scene())
    renderer = LightMapRenderer(ctx, geometry)
    maps = renderer.render_layers(fr, res, 1, "threshold")
    rng = np.random.default_rng(3)
    center, radius = sm.SPHERE
    normal = rng.normal(size=(2000, 3))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    normal[:, 1] = np.abs(normal[:, 1])  # the side facing the light above
    targets = center + radius * normal
    starts = targets + rng.normal(0, 0.3, (2000, 3)) + [0, 0.5, 0]
    d = targets - starts
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    rec = sm.trace_segments(ctx, np.zeros((2, res, res)), starts, d, rendered=maps, search=search)
    for m in maps:
        m.release()
    renderer.release(), geometry.release()
    hit = rec["hit"] & (rec["map"] == 0)
    assert hit.sum() > 1000
    p = starts[hit] + d[hit] * rec["t"][hit][:, None].astype(np.float64)
    to_p = p - fr.position
    r_hit = np.linalg.norm(to_p, axis=1)
    ray = to_p / r_hit[:, None]
    r_true, _ = ray_sphere(fr.position, ray, center, radius)
    n = fr.position + ray * r_true[:, None] - center
    n /= radius
    cos_theta = np.abs(np.einsum("ij,ij->i", n, ray))
    steep = cos_theta > 0.25  # tan θ < 3.9: grazing texels are the maps' own problem
    footprint = 2.0 * fr.tan_half / res * r_true
    tan_theta = np.sqrt(1 - cos_theta**2) / cos_theta
    bound = np.sqrt(2.0) * footprint * tan_theta + 2e-4
    error = np.abs(r_hit - r_true)
    assert steep.sum() > 800
    assert np.all(error[steep] <= bound[steep]), (error - bound)[steep].max()


UP, DOWN = (0.0, 1.0), (0.0, -1.0)  # octahedral codes of the world normals ±y (towards / away from the light)


@pytest.mark.parametrize("search", SEARCHES)
@pytest.mark.parametrize("inside", [-1, 0])
def test_start_rule_facing_passes_over_faces_the_photon_cannot_meet(search, inside):
    """Start rule `facing`: a photon 1 mm before a surface at 2 m, moving away from the
    light. Map 0 holds it with its outward normal pointing away from the light (a face
    the photon leaves from inside, or meets from outside only against its normal: from
    outside, d·n > 0 cannot be met), map 1 a surface at 2.4 m facing the light (from
    outside it is met against its normal). Outside: map 0 is passed over and map 1 hit;
    inside glass the roles swap (an exit is along the outward normal: map 0 is the exit).
    The offset rule (no offset here) takes the first crossing whatever its facing."""
    normals = np.zeros((2, RES, RES, 2), np.float32)
    normals[0] = DOWN
    normals[1] = UP
    start, d = _light_point(1.999, x=0.05), _unit([0.1, -1.0, 0.05])
    run = dict(geometric_normals=normals, search=search, inside=inside)
    maps = _maps(np.full((RES, RES), 2.0), np.full((RES, RES), 2.4))
    facing = sm.trace_segments(_ctx(), maps, np.array([start]), np.array([d]), start_rule="facing", **run)[0]
    offset = sm.trace_segments(_ctx(), maps, np.array([start]), np.array([d]), **run)[0]
    assert offset["hit"] and offset["map"] == 0
    assert facing["hit"] and facing["map"] == (1 if inside < 0 else 0)
    radius = 2.4 if inside < 0 else 2.0
    assert facing["t"] == pytest.approx(_surface_t(start, d, radius)[1], abs=1e-4)
