"""Scenes: obstacle geometry against independent answers, validation, scene files."""

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.integrate import quad
from scipy.interpolate import CubicSpline
from scipy.optimize import minimize_scalar

from vibrissa_ros.core.scenes.boundary import CircleArc, GraphArc, ProfileArc, RayArc, SegmentArc
from vibrissa_ros.core.errors import InvalidPoseError, ParameterError
from vibrissa_ros.core.profiles import Peg, TwoCircles, make_profile
from vibrissa_ros.core.scenes.scene import (
    CurveObstacle, PegObstacle, PolygonObstacle, ProfileObstacle, Scene, clip_polygon,
    clip_polyline,
)
from vibrissa_ros.scan.scene_file import dump_scene, load_scene

L_SHAPE = [[0.0, 0.0], [1.0, 0.0], [1.0, 0.4], [0.4, 0.4], [0.4, 1.0], [0.0, 1.0]]
OBSTACLES = {
    "peg": PegObstacle(0.1, 0.4, 0.2),
    "polygon": PolygonObstacle(L_SHAPE),
    "polygon_cw": PolygonObstacle([[0.0, 0.0], [0.3, 1.0], [1.0, 0.2], [0.5, 0.3]]),
    "curve": CurveObstacle([[-1.0, 0.8], [0.0, 0.5], [0.4, 0.9], [1.0, 0.3], [1.5, 0.6]]),
    "curve_below": CurveObstacle([[-1.0, 0.8], [0.0, 0.5], [1.0, 0.9]], side="below"),
    "parabola": ProfileObstacle("parabola", {"p0": 0.3, "k": 1.0}, 0.1, 0.2, 0.4),
    "catenary": ProfileObstacle("catenary", {"p0": 0.3, "c": 0.5}, 0.0, 0.0, 1.0),
    "circle": ProfileObstacle("circle", {"p0": 0.3, "R": 0.5}, 0.1, 0.2, -0.4),
    "ellipse": ProfileObstacle("ellipse", {"p0": 0.3, "a": 0.5, "b": 0.2}),
    "two_circles": ProfileObstacle("two_circles", {"p0": 0.3, "R_left": 0.5, "R_right": 0.2},
                                   -0.1, 0.0, 0.3),
}
WIDE = (-10.0, -10.0, 10.0, 10.0)


def reference_distance(ob, p, n=1500):
    """Unsigned distance by dense sampling of every arc, refined by a bounded 1-d minimization."""
    best = math.inf
    for index, us, pts in ob.boundary_samples(n, WIDE):
        d = np.hypot(pts[:, 0] - p[0], pts[:, 1] - p[1])
        k = int(np.argmin(d))
        best = min(best, float(d[k]))
        if index is None:
            continue
        arc = ob.arcs[index]
        lo, hi = sorted((us[max(k - 1, 0)], us[min(k + 1, len(us) - 1)]))

        def dist(u, arc=arc):
            q = arc.at(float(u))
            return math.hypot(q.x - p[0], q.y - p[1])

        best = min(best, minimize_scalar(dist, bounds=(lo, hi), method="bounded",
                                         options={"xatol": 1e-13}).fun)
    return best


def crossing_inside(poly, x, y):
    """Even-odd ray casting (an independent point-in-polygon test)."""
    inside = False
    n = len(poly)
    for i in range(n):
        (x0, y0), (x1, y1) = poly[i], poly[(i + 1) % n]
        if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
            inside = not inside
    return inside


def reference_inside(ob, x, y):
    if isinstance(ob, PegObstacle):
        return math.hypot(x - ob.x, y - ob.y) < ob.r
    if isinstance(ob, PolygonObstacle):
        return crossing_inside(ob.points, x, y)
    if isinstance(ob, CurveObstacle):
        pts = np.array(ob.points)
        sp = CubicSpline(pts[:, 0], pts[:, 1], bc_type="natural")
        x0, x1 = pts[0, 0], pts[-1, 0]
        if x < x0:
            g = pts[0, 1] + sp(x0, 1) * (x - x0)
        elif x > x1:
            g = pts[-1, 1] + sp(x1, 1) * (x - x1)
        else:
            g = sp(x)
        return y > g if ob.side == "above" else y < g
    # a profile: above its curve, in its own frame (the strip above a closed shape's lower arc)
    c, s = math.cos(ob.rotation), math.sin(ob.rotation)
    u, v = c * (x - ob.x) + s * (y - ob.y), -s * (x - ob.x) + c * (y - ob.y)
    try:
        return v > ob.base.height_at_x(u)
    except ParameterError:
        return False


@pytest.mark.parametrize("key", sorted(OBSTACLES))
def test_signed_distance_matches_sampling_and_an_independent_inside_test(key):
    ob = OBSTACLES[key]
    rng = np.random.default_rng(7)
    points = rng.uniform(-1.5, 1.5, (60, 2))
    sd = ob.signed_distance(points)
    assert sd.shape == (60,)
    for p, d in zip(points, sd):
        assert abs(abs(d) - reference_distance(ob, p)) < 1e-12
        assert (d < 0.0) == reference_inside(ob, *p)
        assert ob.contains(*p) == (d < 0.0)


@pytest.mark.parametrize("key", sorted(OBSTACLES))
@pytest.mark.parametrize("offset", [1e-9, -1e-9, 1e-5, -1e-5])
def test_signed_distance_is_exact_near_the_boundary(key, offset):
    """Points a tiny step along the outward normal from smooth boundary points."""
    ob = OBSTACLES[key]
    rng = np.random.default_rng(3)
    for _ in range(10):
        index = int(rng.integers(len(ob.arcs)))
        arc = ob.arcs[index]
        if isinstance(arc, RayArc):
            u = float(rng.uniform(0.05, 1.0)) * (-1.0 if arc.incoming else 1.0)
        elif math.isfinite(arc.u_min) and math.isfinite(arc.u_max):
            span = arc.u_max - arc.u_min
            u = float(rng.uniform(arc.u_min + 0.1 * span, arc.u_max - 0.1 * span))
        else:
            u = float(rng.uniform(-1.2, 1.2))
        q = arc.at(u)
        nx, ny = q.normal
        p = np.array([[q.x + offset * nx, q.y + offset * ny]])
        assert abs(ob.signed_distance(p)[0] - offset) < 1e-13 + 1e-9 * abs(offset)
        near = ob.closest(*p[0])
        assert near.arc_index == index
        assert abs(near.u - u) < 1e-7 * max(1.0, q.speed)


def _segment_distance(p, a, b):
    ax, ay = a
    bx, by = b
    dx, dy = bx - ax, by - ay
    t = max(0.0, min(1.0, ((p[0] - ax) * dx + (p[1] - ay) * dy) / (dx * dx + dy * dy)))
    return math.hypot(p[0] - ax - t * dx, p[1] - ay - t * dy)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0.2, 1.0), min_size=3, max_size=9),
       st.lists(st.tuples(st.floats(-1.5, 1.5), st.floats(-1.5, 1.5)), min_size=1, max_size=8))
def test_star_shaped_polygons_against_plain_segment_distances(radii, points):
    """Random star-shaped polygons, convex or not, either orientation of the input."""
    n = len(radii)
    angles = [2.0 * math.pi * (i + 0.3 * ((i * 7) % 3) / 3.0) / n for i in range(n)]
    corners = [(r * math.cos(a), r * math.sin(a)) for r, a in zip(radii, angles)]
    ob = PolygonObstacle(corners[::-1] if n % 2 else corners)
    sd = ob.signed_distance(points)
    for p, d in zip(points, sd):
        ref = min(_segment_distance(p, corners[i], corners[(i + 1) % n]) for i in range(n))
        assert abs(abs(d) - ref) < 1e-14
        if ref > 1e-12:
            assert (d < 0.0) == crossing_inside(corners, *p)


def test_signed_distance_of_many_points_is_vectorised():
    pts = np.random.default_rng(0).uniform(-1.0, 1.0, (500, 2))
    for ob in OBSTACLES.values():
        sd = ob.signed_distance(pts)
        one = np.array([ob.signed_distance(p[None, :])[0] for p in pts[:40]])
        # (a curve has its own path for one point, in plain floats: equal to rounding)
        assert np.max(np.abs(sd[:40] - one)) <= 1e-15


@pytest.mark.parametrize("key", sorted(OBSTACLES))
def test_arcs_have_the_obstacle_to_their_left(key):
    ob = OBSTACLES[key]
    for arc in ob.arcs:
        for u in _params(arc):
            q = arc.at(u)
            nx, ny = q.normal
            assert ob.contains(q.x - 1e-6 * nx, q.y - 1e-6 * ny)
            assert not ob.contains(q.x + 1e-6 * nx, q.y + 1e-6 * ny)
            # the tangent is the direction of travel: d point / du = speed * tangent
            h = 1e-6
            a, b = arc.at(u - h), arc.at(u + h)
            tx, ty = q.tangent
            assert abs((b.x - a.x) / (2 * h) - q.speed * tx) < 1e-6 * max(1.0, q.speed)
            assert abs((b.y - a.y) / (2 * h) - q.speed * ty) < 1e-6 * max(1.0, q.speed)


def _params(arc):
    if isinstance(arc, RayArc):
        return [-0.5, -0.1] if arc.incoming else [0.1, 0.5]
    if math.isfinite(arc.u_min) and math.isfinite(arc.u_max):
        span = arc.u_max - arc.u_min
        return list(np.linspace(arc.u_min + 0.05 * span, arc.u_max - 0.05 * span, 6))
    return list(np.linspace(-1.5, 1.5, 6))


def test_closest_finds_edges_corners_and_walls():
    square = PolygonObstacle([[0, 0], [1, 0], [1, 1], [0, 1]])
    near = square.closest(0.5, -0.2)
    assert near.arc_index == 0 and near.u == pytest.approx(0.5) and near.distance == \
        pytest.approx(0.2)
    assert isinstance(near.feature, SegmentArc) and not near.on_vertex
    corner = square.closest(1.3, 1.4)
    assert corner.on_vertex and corner.vertex_index == 2 and (corner.x, corner.y) == (1.0, 1.0)
    assert corner.distance == pytest.approx(0.5)
    inside = square.closest(0.5, 0.9)
    assert inside.arc_index == 2 and inside.distance == pytest.approx(-0.1)
    # the L shape's reflex corner is nearest to points inside near it
    ell = PolygonObstacle(L_SHAPE)
    reflex = ell.closest(0.38, 0.38)
    assert reflex.on_vertex and not ell.vertices[reflex.vertex_index].convex
    assert reflex.distance == pytest.approx(-math.hypot(0.02, 0.02))
    # a circle strip: beside it above its equator the wall is nearest
    strip = ProfileObstacle("circle", {"p0": 0.3, "R": 0.5})
    wall = strip.closest(0.7, 1.2)
    assert isinstance(wall.feature, RayArc) and wall.arc_index == 2
    assert wall.u == pytest.approx(1.2 - 0.8) and wall.distance == pytest.approx(0.2)
    left = strip.closest(-0.9, 1.0)
    assert left.arc_index == 0 and left.u == pytest.approx(-0.2)
    lower = strip.closest(0.0, 0.0)
    assert isinstance(lower.feature, ProfileArc) and lower.u == pytest.approx(0.0)
    assert lower.distance == pytest.approx(0.3)
    peg = PegObstacle(0.0, 1.0, 0.1)
    below = peg.closest(0.0, 0.5)
    assert isinstance(below.feature, CircleArc) and below.u == pytest.approx(0.0)
    assert (below.x, below.y) == pytest.approx((0.0, 0.9))
    point = PegObstacle(0.0, 1.0)
    assert point.closest(0.3, 1.4).on_vertex
    assert point.closest(0.3, 1.4).distance == pytest.approx(0.5)
    curve = OBSTACLES["curve_below"]
    c = curve.closest(0.0, 0.0)
    assert isinstance(c.feature, GraphArc) and c.distance < 0.0
    q = curve.graph.at(c.u)
    assert (q.x, q.y) == pytest.approx((c.x, c.y))
    # the foot of the perpendicular: p - q along the outward normal
    nx, ny = q.normal
    assert (0.0 - q.x) * ny - (0.0 - q.y) * nx == pytest.approx(0.0, abs=1e-12)


def test_closest_of_a_profile_is_its_slope_in_the_world_frame():
    ob = OBSTACLES["parabola"]
    near = ob.closest(1.0, -0.5)
    q = ob.profile.point(near.u)
    assert q == pytest.approx((near.x, near.y), abs=1e-14)
    # the point lies on the outward normal (sin a, -cos a) of the slope found
    d = math.hypot(1.0 - q[0], -0.5 - q[1])
    assert (math.sin(near.u) * d, -math.cos(near.u) * d) == pytest.approx(
        (1.0 - q[0], -0.5 - q[1]), abs=1e-12)


def test_polygon_corners_are_ordered_with_their_edges_and_cones():
    cw = [[0.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 0.0]]
    square = PolygonObstacle(cw)
    assert square.area == pytest.approx(1.0)  # normalised counter-clockwise
    assert square.points[0] == (1.0, 0.0)
    ell = PolygonObstacle(L_SHAPE)
    turns = [round(v.turn / (0.5 * math.pi)) for v in ell.vertices]
    assert turns == [1, 1, 1, -1, 1, 1]
    assert [v.convex for v in ell.vertices] == [True, True, True, False, True, True]
    assert sum(v.turn for v in ell.vertices) == pytest.approx(2 * math.pi)
    for v, (e_in, e_out) in zip(ell.vertices, ell.vertex_arcs):
        a_in, a_out = ell.arcs[e_in], ell.arcs[e_out]
        end, start = a_in.at(a_in.u_max), a_out.at(0.0)
        assert (end.x, end.y) == pytest.approx((v.x, v.y))
        assert (start.x, start.y) == (v.x, v.y)
        assert v.phi_in == a_in.at(0.0).phi
        assert math.remainder(v.phi_out - a_out.at(0.0).phi, 2 * math.pi) == pytest.approx(0.0)
    # the cone of the convex corner (1, 0): outward normals from the bottom edge to the right one
    corner = ell.vertices[1]
    assert corner.in_cone(1.0, -1.0) and corner.in_cone(0.0, -1.0) and corner.in_cone(1.0, 0.0)
    assert not corner.in_cone(-1.0, -0.1) and not corner.in_cone(0.1, 1.0)
    point = PegObstacle(0.2, 0.3)
    assert point.arcs == () and len(point.vertices) == 1
    assert point.vertices[0].turn == pytest.approx(2 * math.pi)
    assert all(point.vertices[0].in_cone(math.cos(t), math.sin(t)) for t in np.linspace(0, 6, 13))
    assert not point.contains(0.2, 0.3) and point.signed_distance([[0.2, 0.3]])[0] == 0.0


# -- the boundary additions used by scenes -----------------------------------------------------
def test_arc_lengths_are_exact_across_spline_knots_and_circle_joins():
    arc = GraphArc(((-1.0, 0.8), (0.0, 0.5), (0.4, 0.9), (1.0, 0.3)))
    exact, _ = quad(lambda u: arc.at(u).speed, -1.7, 1.6, points=[-1.0, 0.0, 0.4, 1.0],
                    epsabs=1e-14, epsrel=1e-13, limit=200)
    assert arc.sigma_between(-1.7, 1.6) == pytest.approx(exact, abs=1e-13)
    assert arc.sigma_between(1.6, -1.7) == pytest.approx(-exact, abs=1e-13)
    below = GraphArc(arc.points, side="below")
    assert below.sigma_between(-1.6, 1.7) == pytest.approx(exact, abs=1e-13)
    two = ProfileArc(TwoCircles(0.3, 2.0, 1.0, scan_checks=False).placed(0.0, 0.0, 0.3))
    assert two.sigma_between(-0.5, 0.9) == pytest.approx(2.0 * 0.8 + 1.0 * 0.6, abs=1e-14)
    ray = RayArc(1.0, 2.0, 0.5, incoming=True)
    assert (ray.u_min, ray.u_max) == (-math.inf, 0.0)
    q = ray.at(-2.0)
    assert (q.x, q.y) == pytest.approx((1.0 - 2.0 * math.cos(0.5), 2.0 - 2.0 * math.sin(0.5)))
    assert ray.sigma_between(-3.0, -1.0) == 2.0 and RayArc(0, 0, 0).u_max == math.inf
    # projection onto a wall: clamped to its end, signed along the outward normal
    wall = RayArc(0.0, 0.0, 0.5 * math.pi)  # going up along x = 0, obstacle at x < 0
    assert wall.project(0.3, 2.0) == pytest.approx((2.0, 0.3))
    assert wall.project(-0.2, 1.0) == pytest.approx((1.0, -0.2))
    assert wall.project(0.3, -0.4)[0] == 0.0


# -- scenes ---------------------------------------------------------------------------------------
MIXED = """
friction: 0.1
obstacles:
  - {type: peg, x: -0.35, y: 0.45, r: 0.03, friction: 0.3}
  - {type: polygon, vertices: [[0.3, 0.6], [0.5, 0.6], [0.5, 0.8], [0.4, 0.7], [0.3, 0.8]]}
  - {type: curve, points: [[-1.0, 1.0], [0.0, 0.9], [1.0, 1.3]], side: above}
  - {type: parabola, p0: 0.3, k: 2.0, placement: {x: 1.0, y: 0.3, rotation_deg: -90}}
  - {type: peg, x: -0.6, y: 0.3, name: pin}
"""


def test_a_scene_names_its_obstacles_and_gives_each_its_friction():
    scene = load_scene(MIXED)
    assert [ob.name for ob in scene] == ["peg0", "polygon0", "curve0", "parabola0", "pin"]
    assert [ob.kind for ob in scene] == ["peg", "polygon", "curve", "parabola", "peg"]
    assert [scene.mu_of(i) for i in range(len(scene))] == [0.3, 0.1, 0.1, 0.1, 0.1]
    assert scene[3].rotation == pytest.approx(-0.5 * math.pi)
    assert "parabola0: parabola(p0=0.3, k=2.0) placed at" in scene.describe()
    assert len(scene.describe().splitlines()) == 1
    index, near = scene.closest(0.55, 0.85)
    assert index == 1 and near.on_vertex
    assert scene.signed_distance([[0.0, 0.0]])[0] == pytest.approx(
        min(float(ob.signed_distance([[0.0, 0.0]])[0]) for ob in scene))


def test_scene_round_trips_through_dicts_and_yaml(tmp_path):
    scene = load_scene(MIXED)
    assert Scene.from_dict(scene.to_dict()) == scene
    path = tmp_path / "scene.yaml"
    text = dump_scene(scene, path)
    assert load_scene(path) == scene and load_scene(text) == scene
    assert load_scene(str(path)) == scene
    for name in ("scene_two_pegs", "scene_contour", "scene_mixed"):
        shipped = load_scene(f"config/{name}.yaml")
        assert load_scene(dump_scene(shipped)) == shipped


def test_metres_are_converted_to_whisker_lengths():
    length = 0.05  # m
    metres = """
obstacles:
  - {type: peg, x: 0.0, y: 0.0225, r: 0.0015}
  - {type: polygon, vertices: [[0.015, 0.03], [0.025, 0.03], [0.025, 0.04]]}
  - {type: parabola, p0: 0.015, k: 40.0,
     placement: {x: 0.05, y: 0.0, rotation: -1.5707963267948966}}
  - {type: circle, p0: 0.005, R: 0.01, placement: {x: -0.05, y: 0.0, rotation: 3.14159}}
"""
    scene = load_scene(metres, length_scale=length)
    assert scene[0].params == pytest.approx({"x": 0.0, "y": 0.45, "r": 0.03})
    assert np.array(scene[1].points) == pytest.approx(np.array([[0.3, 0.6], [0.5, 0.6],
                                                                [0.5, 0.8]]))
    assert scene[2].params == pytest.approx({"p0": 0.3, "k": 2.0})  # 40 /m * 0.05 m
    assert (scene[2].x, scene[2].y, scene[2].rotation) == pytest.approx((1.0, 0.0, -0.5 * math.pi))
    assert scene[3].params == pytest.approx({"p0": 0.1, "R": 0.2})
    back = load_scene(dump_scene(scene, length_scale=length), length_scale=length)
    for a, b in zip(back, scene):
        assert a.kind == b.kind and a.name == b.name
        for key, value in a.params.items():
            assert np.array(value, dtype=float) == pytest.approx(np.array(b.params[key],
                                                                          dtype=float))
    assert "k: 40.0" in dump_scene(scene, length_scale=length)
    # YAML 1.1 reads 1.5e-3 without a dot as a string: converted all the same
    small = load_scene("obstacles: [{type: peg, x: 0, y: 2e-2, r: 1e-3}]", length_scale=length)
    assert small[0].params == pytest.approx({"x": 0.0, "y": 0.4, "r": 0.02})


@pytest.mark.parametrize("text, message", [
    ("friction: -0.1\nobstacles: [{type: peg, x: 0, y: 1}]",
     "scene: friction = -0.1 is not allowed; the Coulomb coefficient must be finite and >= 0"),
    ("friction: .nan\nobstacles: [{type: peg, x: 0, y: 1}]", "scene: friction = nan"),
    ("obstacles: [{type: peg, x: 0, y: 1, friction: -1}]", "obstacle 0: peg0: friction = -1.0"),
    ("obstacles: [{type: peg, x: 0, y: 0.5, r: 0.1}, {type: peg, x: 0, y: 0.65, r: 0.1}]",
     "obstacles 0 (peg0) and 1 (peg1) overlap or touch"),
    ("obstacles: [{type: polygon, vertices: [[0, 0], [1, 0], [1, 1], [0, 1]]},"
     " {type: peg, x: 0.5, y: 0.5, r: 0.1}]", "obstacles 0 (polygon0) and 1 (peg0) overlap"),
    ("obstacles: [{type: polygon, vertices: [[0, 0], [1, 0], [1, 1], [0, 1]]},"
     " {type: polygon, vertices: [[1, 0], [2, 0], [2, 1], [1, 1]]}]", "overlap or touch"),
    ("obstacles: [{type: curve, points: [[-1, 0.5], [0, 0.4], [1, 0.5]]},"
     " {type: peg, x: 0.0, y: 0.6, r: 0.05}]", "obstacles 0 (curve0) and 1 (peg0) overlap"),
    ("obstacles: [{type: parabola, p0: 0.3}, {type: peg, x: 0.0, y: 0.45, r: 0.03}]",
     "obstacles 0 (parabola0) and 1 (peg0) overlap"),
    ("obstacles: [{type: parabola, p0: 0.3}, {type: curve, points: [[-1, 2], [0, 1], [1, 2]]}]",
     "obstacles 0 (parabola0) and 1 (curve0) overlap"),
    ("obstacles: [{type: peg, x: 0, y: 1, r: 0.1}, {type: peg, x: 0, y: 1}]",
     "obstacles 0 (peg0) and 1 (peg1) overlap"),
    ("obstacles: [{type: polygon, vertices: [[0, 0], [1, 0], [2, 0]]}]",
     "obstacle 0: polygon0: zero area"),
    ("obstacles: [{type: polygon, vertices: [[0, 0], [1, 0], [1, 0], [0, 1]]}]",
     "obstacle 0: polygon0: vertices 1 and 2 coincide"),
    ("obstacles: [{type: polygon, vertices: [[0, 0], [1, 1], [1, 0], [0, 1]]}]",
     "obstacle 0: polygon0: self-intersecting (edges 0 and 2 cross)"),
    ("obstacles: [{type: polygon, vertices: [[0, 0], [2, 0], [1, 0], [1, 1]]}]",
     "polygon0: self-intersecting"),
    ("obstacles: [{type: polygon, vertices: [[0, 0], [1, 0]]}]", "needs at least 3 vertices"),
    ("obstacles: [{type: polygon, vertices: [[0, 0], [1, 0], [0, 2e6]]}]",
     "|vertices[2] y| must be <= 1e+06 L"),
    ("obstacles: [{type: polygon, vertices: 3}]", "vertices must be a list of [x, y] points"),
    ("obstacles: [{type: curve, points: [[0, 0], [1, 1]]}]",
     "obstacle 0: curve0: needs at least 3 points [x, y], got 2"),
    ("obstacles: [{type: curve, points: [[0, 0], [2, 1], [1, 1]]}]",
     "curve0: points must have strictly increasing x (point 2: x = 1.0 after 2.0)"),
    ("obstacles: [{type: curve, points: [[0, 0], [1, 1], [1, 2]]}]", "strictly increasing x"),
    ("obstacles: [{type: curve, points: [[0, 0], [1, 1], [2, 0]], side: left}]",
     "side = 'left' is not allowed; side must be 'above' or 'below'"),
    ("obstacles: [{type: peg, x: 0, y: 1, r: -0.1}]", "r = -0.1 is not allowed"),
    ("obstacles: [{type: peg, x: 0, y: 1, r: 1e-9}]",
     "r = 1e-09 is not allowed; it must be within [1e-06, 1e+06]"),
    ("obstacles: [{type: peg, x: .inf, y: 1}]", "peg0: x = inf must be finite"),
    ("obstacles: [{type: peg, x: zero, y: 1}]", "peg0: x = 'zero' must be a number"),
    ("obstacles: [{type: peg, y: 1}]", "peg0: key 'x' is required"),
    ("obstacles: [{type: circle, p0: 0.3, R: 2.0e+6}]",
     "obstacle 0: circle0: circle: R = 2000000.0 is not allowed"),
    ("obstacles: [{type: parabola, k: 1}]", "parabola: parameter p0 is required"),
    ("obstacles: [{type: parabola, p0: 0.3, placement: {x: 1, turn: 2}}]",
     "unknown placement key(s) 'turn'; allowed: x, y, rotation, rotation_deg"),
    ("obstacles: [{type: parabola, p0: 0.3, placement: {rotation: 1, rotation_deg: 2}}]",
     "both rotation and rotation_deg"),
    ("obstacles: [{type: box, x: 0}]",
     "unknown obstacle type 'box'; allowed: peg, polygon, curve, parabola, catenary, circle, "
     "two_circles, ellipse"),
    ("obstacles: [{x: 0}]", "key 'type' is missing"),
    ("obstacles: [{type: peg, x: 0, y: 1, radius: 1}]",
     "obstacle 0: peg: unknown key(s) 'radius'; allowed: type, name, friction, x, y, r"),
    ("obstacles: [{type: peg, x: 0, y: 1, name: a}, {type: peg, x: 0, y: 3, name: a}]",
     "obstacle 1: name 'a' is used twice"),
    ("obstacles: []", "key 'obstacles' must be a non-empty list"),
    ("obstacles: [{type: peg, x: 0, y: 1}]\nwalls: 1",
     "unknown scene key(s) 'walls'; allowed: friction, obstacles"),
    ("obstacles: [ {type: peg", "not valid YAML (line 1"),
    ("- 1\n- 2", "a scene file is a mapping"),
])
def test_bad_scenes_are_refused_with_a_one_line_reason(text, message):
    with pytest.raises(ParameterError) as info:
        load_scene(text)
    assert message in str(info.value)
    assert str(info.value).startswith("scene text: ")
    assert "\n" not in str(info.value)


def test_the_issues_listing_overlaps_and_is_refused(tmp_path):
    """Issue 13's key listing puts the peg and the square inside the parabola's region."""
    listing = tmp_path / "listing.yaml"
    listing.write_text("""friction: 0.0
obstacles:
  - {type: peg, x: 0.0, y: 0.45, r: 0.03, friction: 0.3}
  - {type: polygon, vertices: [[0.3, 0.6], [0.5, 0.6], [0.5, 0.8], [0.3, 0.8]]}
  - {type: curve, points: [[-1.0, 0.8], [0.0, 0.5], [1.0, 0.9]], side: above}
  - {type: parabola, p0: 0.3, k: 1.0, placement: {x: 0.0, y: 0.0, rotation: 0.0}}
""")
    with pytest.raises(ParameterError, match=r"listing.yaml: obstacles 0 \(peg0\) and 3"):
        load_scene(listing)
    with pytest.raises(ParameterError, match="scene file .*missing.yaml' cannot be read"):
        load_scene(tmp_path / "missing.yaml")


def test_overlap_checks_are_exact_not_sampled():
    square = {"type": "polygon", "vertices": [[0, 0], [1, 0], [1, 1], [0, 1]]}
    for gap, ok in ((1e-6, True), (-1e-7, False)):
        peg = {"type": "peg", "x": 0.5, "y": -0.2 - gap, "r": 0.2}
        corner = {"type": "peg", "x": 1.0 + (0.1 + gap) / math.sqrt(2),
                  "y": 1.0 + (0.1 + gap) / math.sqrt(2), "r": 0.1}
        for other in (peg, corner):
            data = {"obstacles": [square, other]}
            if ok:
                Scene.from_dict(data)
            else:
                with pytest.raises(ParameterError, match="overlap or touch"):
                    Scene.from_dict(data)
    # a point peg on the edge touches it
    with pytest.raises(ParameterError, match="overlap or touch"):
        Scene.from_dict({"obstacles": [square, {"type": "peg", "x": 0.5, "y": 1.0}]})


def test_the_foot_must_be_outside_every_obstacle():
    scene = load_scene(MIXED)
    scene.check_foot(0.0, 0.0)
    with pytest.raises(InvalidPoseError,
                       match=r"the foot \(0.4, 0.65\) is inside obstacle 1 \(polygon0\)"):
        scene.check_foot(0.4, 0.65)
    with pytest.raises(InvalidPoseError, match=r"on the boundary of obstacle 4 \(pin\)"):
        scene.check_foot(-0.6, 0.3)
    with pytest.raises(InvalidPoseError, match="inside obstacle 2 \\(curve0\\)"):
        scene.check_foot(0.0, 2.0)


def test_a_one_obstacle_scene_gives_back_the_plain_profile():
    peg = Scene([PegObstacle(0.1, 0.5, 0.05)]).single_profile()
    assert peg == Peg(0.1, 0.5, 0.05, scan_checks=False) and isinstance(peg, Peg)
    scene = load_scene("obstacles: [{type: parabola, p0: 0.3, k: 2.0,"
                       " placement: {x: 0.1, y: 0.05, rotation: 0.2}}]")
    profile = scene.single_profile()
    expected = make_profile("parabola", {"p0": 0.3, "k": 2.0}).placed(0.1, 0.05, 0.2)
    assert profile == expected
    plain = load_scene("obstacles: [{type: catenary, p0: 0.4, c: 0.5}]").single_profile()
    assert plain == make_profile("catenary", {"p0": 0.4, "c": 0.5})
    assert load_scene(MIXED).single_profile() is None
    assert Scene([PolygonObstacle(L_SHAPE)]).single_profile() is None
    # the same geometry either way: the scene's distance equals the profile's gap where the
    # nearest point is straight above
    assert scene[0].signed_distance([[0.1, 0.0]])[0] == pytest.approx(0.35, abs=0.01)


def test_outlines_are_closed_and_cut_to_the_window():
    window = (-1.0, -1.0, 1.5, 1.5)
    for key, ob in OBSTACLES.items():
        rings = ob.outline(100, window)
        assert rings, key
        for ring in rings:
            assert np.array_equal(ring[0], ring[-1])
            if not ob.bounded:
                assert ring[:, 0].min() >= -1.0 - 1e-12 and ring[:, 0].max() <= 1.5 + 1e-12
                assert ring[:, 1].min() >= -1.0 - 1e-12 and ring[:, 1].max() <= 1.5 + 1e-12
        for line in ob.boundary_lines(100, window):
            # the samples lie on the boundary (the ends of a cut piece lie on a chord)
            inner = line if ob.bounded else line[1:-1]
            assert np.all(np.abs(ob.signed_distance(inner)) < 1e-9)
    with pytest.raises(ParameterError, match="needs a window"):
        OBSTACLES["curve"].outline(100)


def test_clipping_helpers():
    pieces = clip_polyline(np.array([[-2.0, 0.5], [0.5, 0.5], [0.5, 3.0]]), (0.0, 0.0, 1.0, 1.0))
    assert len(pieces) == 1
    assert pieces[0] == pytest.approx(np.array([[0.0, 0.5], [0.5, 0.5], [0.5, 1.0]]))
    ring = clip_polygon(np.array([[-1.0, -1.0], [2.0, -1.0], [2.0, 0.5], [-1.0, 0.5]]),
                        (0.0, 0.0, 1.0, 1.0))
    area = 0.5 * abs(np.sum(ring[:-1, 0] * ring[1:, 1] - ring[1:, 0] * ring[:-1, 1]))
    assert area == pytest.approx(0.5)
