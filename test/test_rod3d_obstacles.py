"""3D obstacles: signed distances against hand values, derivatives by finite differences."""

import dataclasses
import math

import numpy as np
import pytest

from vibrissa_ros.core.errors import ParameterError
from vibrissa_ros.core.rod3d.obstacles import Cylinder, Plane, Prism, Sphere, SurfacePoint
from vibrissa_ros.core.scenes.scene import (
    CurveObstacle, PegObstacle, PolygonObstacle, ProfileObstacle,
)

L_SHAPE = [[0.0, 0.0], [1.0, 0.0], [1.0, 0.4], [0.4, 0.4], [0.4, 1.0], [0.0, 1.0]]
OBSTACLES = {
    "sphere": Sphere((0.1, -0.2, 0.3), 0.4),
    "cylinder": Cylinder((0.2, 0.1, -0.3), (1.0, 2.0, -0.5), 0.25),
    "plane": Plane((0.1, 0.2, 0.3), (0.3, -1.0, 2.0)),
    "peg": Prism(PegObstacle(0.1, 0.4, 0.2)),
    "point_peg": Prism(PegObstacle(0.1, 0.4, 0.0)),
    "polygon": Prism(PolygonObstacle(L_SHAPE)),
    "curve": Prism(CurveObstacle([[-1.0, 0.8], [0.0, 0.5], [0.4, 0.9], [1.0, 0.3], [1.5, 0.6]])),
    "parabola": Prism(ProfileObstacle("parabola", {"p0": 0.3, "k": 1.0}, 0.1, 0.2, 0.4)),
    "catenary": Prism(ProfileObstacle("catenary", {"p0": 0.3, "c": 0.5}, 0.0, 0.0, 1.0)),
    "circle": Prism(ProfileObstacle("circle", {"p0": 0.3, "R": 0.5}, 0.1, 0.2, -0.4)),
    "two_circles": Prism(ProfileObstacle("two_circles",
                                         {"p0": 0.3, "R_left": 0.5, "R_right": 0.2},
                                         -0.1, 0.0, 0.3)),
}

# query points [x, y, z] per obstacle, away from where the signed distance is not smooth (the
# medial axis, a centre, an axis, an edge itself); each (point, feature expected)
QUERIES = {
    "sphere": [([0.6, 0.1, 0.5], "surface"), ([0.2, -0.1, 0.4], "surface"),
               ([-0.5, -0.9, 0.0], "surface")],
    "cylinder": [([0.9, 0.1, 0.2], "surface"), ([0.3, 0.0, -0.1], "surface"),
                 ([-2.0, 3.0, 1.0], "surface")],
    "plane": [([0.0, 0.0, 0.0], "surface"), ([1.0, -2.0, 3.0], "surface")],
    "peg": [([0.5, 0.7, 2.0], "surface"), ([0.15, 0.35, -1.0], "surface")],
    "point_peg": [([0.3, 0.1, 0.7], "edge"), ([0.1, 0.45, -3.0], "edge")],
    "polygon": [([0.5, -0.2, 0.3], "surface"),    # below edge 0
                ([0.7, 0.35, 0.0], "surface"),    # inside, near edge 2
                ([0.2, 0.9, 0.1], "surface"),     # inside, near edge 4 (y = 1)
                ([1.2, -0.1, 0.5], "edge"),       # outside the convex corner (1, 0)
                ([-0.1, 1.3, -0.2], "edge"),      # outside the convex corner (0, 1)
                ([0.3, 0.3, 0.0], "edge")],       # inside, nearest the reflex corner (0.4, 0.4)
    "curve": [([0.0, 0.3, 0.0], "surface"), ([0.35, 1.0, 1.0], "surface"),
              ([-1.5, 0.5, 0.2], "surface"), ([2.0, 0.4, -0.4], "surface")],
    "parabola": [([0.0, 0.0, 0.0], "surface"), ([0.6, 0.3, 0.5], "surface"),
                 ([0.1, 0.6, -0.5], "surface")],
    "catenary": [([0.1, -0.2, 0.0], "surface"), ([0.5, 0.5, 1.0], "surface")],
    "circle": [([0.0, 0.0, 0.0], "surface"), ([0.9, 0.9, 0.2], "surface"),
               ([-0.6, 0.9, 0.0], "surface")],
    "two_circles": [([0.0, 0.0, 0.0], "surface"), ([0.4, 0.1, 0.3], "surface"),
                    ([-0.5, 0.1, -0.3], "surface")],
}
CASES = [(name, tuple(q), feature) for name, qs in QUERIES.items() for q, feature in qs]


def numeric_gradient(ob, x, h=1e-6):
    x = np.asarray(x, dtype=float)
    pts = np.array([x + s * h * e for e in np.eye(3) for s in (1.0, -1.0)])
    d = ob.signed_distance(pts)
    return (d[0::2] - d[1::2]) / (2.0 * h)


def numeric_hessian(ob, x, h=1e-5):
    """Central differences of the normal returned by ``surface`` (columns: d n / d x_j)."""
    x = np.asarray(x, dtype=float)
    cols = [(ob.surface(x + h * e).normal - ob.surface(x - h * e).normal) / (2.0 * h)
            for e in np.eye(3)]
    return np.column_stack(cols)


# -- hand values --------------------------------------------------------------------------------
@pytest.mark.parametrize("ob, point, expected", [
    (Sphere((1.0, 2.0, 3.0), 0.5), [1.0, 2.0, 5.0], 1.5),
    (Sphere((1.0, 2.0, 3.0), 0.5), [1.1, 2.0, 3.0], -0.4),
    (Cylinder((0.0, 0.0, 0.0), (0.0, 0.0, 2.0), 0.5), [3.0, 4.0, 7.0], 4.5),
    (Cylinder((0.0, 0.0, 1.0), (1.0, 1.0, 0.0), 0.5), [1.0, -1.0, 1.0], math.sqrt(2.0) - 0.5),
    (Cylinder((0.0, 0.0, 1.0), (1.0, 1.0, 0.0), 0.5), [7.0, 7.0, 1.2], -0.3),
    (Plane((0.0, 0.0, 1.0), (0.0, 0.0, -3.0)), [5.0, 5.0, 0.0], 1.0),  # obstacle above z = 1
    (Plane((0.0, 0.0, 1.0), (0.0, 0.0, -3.0)), [0.0, 0.0, 2.0], -1.0),
    (Plane((0.0, 0.0, 0.0), (1.0, 1.0, 0.0)), [1.0, 0.0, 9.0], math.sqrt(0.5)),
    (OBSTACLES["peg"], [0.1, 1.0, 9.0], 0.4),
    (OBSTACLES["point_peg"], [0.4, 0.0, -2.0], 0.5),
    (OBSTACLES["polygon"], [1.3, 0.8, 4.0], 0.5),   # nearest: the corner (1, 0.4)
    (OBSTACLES["polygon"], [1.3, -0.4, 0.0], 0.5),  # nearest: the corner (1, 0)
    (OBSTACLES["polygon"], [0.2, 0.5, 0.0], -0.2),  # inside the upright, 0.2 from x = 0 and 0.4
])
def test_signed_distance_hand_values(ob, point, expected):
    d = ob.signed_distance(np.array([point]))
    assert d.shape == (1,)
    assert d[0] == pytest.approx(expected, abs=1e-12)
    assert ob.surface(point).distance == pytest.approx(expected, abs=1e-12)


def test_prism_ignores_z_and_matches_the_planar_distance():
    rng = np.random.default_rng(3)
    for name in ("peg", "polygon", "curve", "parabola", "circle"):
        ob = OBSTACLES[name]
        pts = rng.uniform(-1.5, 1.5, size=(40, 3))
        moved = pts + np.array([0.0, 0.0, 5.0])
        np.testing.assert_array_equal(ob.signed_distance(pts), ob.signed_distance(moved))
        np.testing.assert_array_equal(ob.signed_distance(pts),
                                      ob.planar.signed_distance(pts[:, :2]))


@pytest.mark.parametrize("name", OBSTACLES)
def test_vectorised_distance_matches_one_point_queries(name):
    ob = OBSTACLES[name]
    pts = np.random.default_rng(7).uniform(-1.0, 1.5, size=(25, 3))
    d = ob.signed_distance(pts)
    assert d.shape == (25,)
    for p, dk in zip(pts, d):
        assert ob.surface(p).distance == pytest.approx(dk, abs=1e-9)
        assert ob.clearance_bound(p, 0.0) == pytest.approx(dk, abs=1e-9)
        assert ob.contains(p) == (dk < 0.0)


# -- derivatives --------------------------------------------------------------------------------
@pytest.mark.parametrize("name, x, feature", CASES)
def test_surface_point_normal_and_feature(name, x, feature):
    ob = OBSTACLES[name]
    sp = ob.surface(x)
    assert isinstance(sp, SurfacePoint)
    assert sp.feature == feature
    assert sp.point.shape == sp.normal.shape == (3,) and sp.hessian.shape == (3, 3)
    assert np.linalg.norm(sp.normal) == pytest.approx(1.0, abs=1e-12)
    # x = nearest point + d n, and the nearest point is on the surface
    np.testing.assert_allclose(np.asarray(x), sp.point + sp.distance * sp.normal, atol=1e-9)
    assert ob.signed_distance(sp.point[None, :])[0] == pytest.approx(0.0, abs=1e-9)
    if feature == "edge":
        a, e = sp.edge
        np.testing.assert_array_equal(e, [0.0, 0.0, 1.0])
        assert a[2] == 0.0
        np.testing.assert_allclose(sp.point[:2], a[:2])
        assert sp.normal[2] == 0.0
    else:
        assert sp.edge is None


@pytest.mark.parametrize("name, x, feature", CASES)
def test_normal_is_the_gradient(name, x, feature):
    ob = OBSTACLES[name]
    np.testing.assert_allclose(ob.surface(x).normal, numeric_gradient(ob, x), atol=1e-8)


@pytest.mark.parametrize("name, x, feature", CASES)
def test_hessian_is_the_derivative_of_the_normal(name, x, feature):
    ob = OBSTACLES[name]
    sp = ob.surface(x)
    H = sp.hessian
    np.testing.assert_allclose(H, H.T, atol=1e-14)
    np.testing.assert_allclose(H @ sp.normal, 0.0, atol=1e-12)  # d grows linearly along n
    scale = max(1.0, float(np.abs(H).max()))
    np.testing.assert_allclose(H, numeric_hessian(ob, x), atol=1e-6 * scale)


def test_hessians_in_closed_form():
    x = np.array([0.6, 0.1, 0.5])
    ball = OBSTACLES["sphere"]
    n = ball.surface(x).normal
    rho = np.linalg.norm(x - np.array(ball.center))
    np.testing.assert_allclose(ball.surface(x).hessian, (np.eye(3) - np.outer(n, n)) / rho,
                               atol=1e-14)
    cyl = OBSTACLES["cylinder"]
    a = np.array(cyl.axis)
    sp = cyl.surface(x)
    rho = sp.distance + cyl.r
    np.testing.assert_allclose(sp.hessian,
                               (np.eye(3) - np.outer(a, a) - np.outer(sp.normal, sp.normal)) / rho,
                               atol=1e-14)
    np.testing.assert_array_equal(OBSTACLES["plane"].surface(x).hessian, np.zeros((3, 3)))
    # a peg's prism: the disk's parallel circle, k / (1 + k d) = 1 / (r + d) along the tangent
    peg = OBSTACLES["peg"]
    sp = peg.surface([0.5, 0.7, 2.0])
    t = np.array([-sp.normal[1], sp.normal[0], 0.0])
    np.testing.assert_allclose(sp.hessian, np.outer(t, t) / (0.2 + sp.distance), atol=1e-14)


def test_prism_curvature_sign_for_a_concave_arc():
    # the region below a valley is concave there (k < 0): H = k / (1 + k d) t t^T is negative,
    # the region above it convex (k > 0): positive
    points = [[-1.0, 1.0], [0.0, 0.0], [1.0, 1.0]]
    below = Prism(CurveObstacle(points, side="below"))
    above = Prism(CurveObstacle(points, side="above"))
    k = 3.0  # the natural spline's g''(0) (g'(0) = 0)
    for ob, x, sign in ((below, [0.0, 0.1, 0.0], -1.0), (above, [0.0, -0.1, 0.0], 1.0)):
        sp = ob.surface(x)
        assert sp.distance == pytest.approx(0.1)
        assert sp.hessian[0, 0] == pytest.approx(sign * k / (1.0 + sign * k * 0.1))
        np.testing.assert_allclose(sp.hessian, numeric_hessian(ob, x), atol=1e-4)


def test_degenerate_points_still_answer():
    centre = OBSTACLES["sphere"].surface(OBSTACLES["sphere"].center)
    assert centre.distance == -0.4 and np.linalg.norm(centre.normal) == pytest.approx(1.0)
    on_axis = OBSTACLES["cylinder"].surface(OBSTACLES["cylinder"].point)
    assert on_axis.distance == -0.25
    assert abs(on_axis.normal @ np.array(OBSTACLES["cylinder"].axis)) < 1e-15
    on_edge = OBSTACLES["point_peg"].surface([0.1, 0.4, 1.0])
    assert on_edge.distance == 0.0 and on_edge.feature == "edge"
    corner = OBSTACLES["polygon"].surface([1.0, 0.0, 0.0])
    np.testing.assert_allclose(corner.normal, [math.sqrt(0.5), -math.sqrt(0.5), 0.0])
    for sp in (centre, on_axis, on_edge, corner):
        assert np.all(np.isfinite(sp.hessian))


# -- clearance bound ----------------------------------------------------------------------------
@pytest.mark.parametrize("name", OBSTACLES)
def test_clearance_bound_is_a_lower_bound(name):
    ob = OBSTACLES[name]
    rng = np.random.default_rng(11)
    for _ in range(5):
        centre = rng.uniform(-1.0, 1.5, size=3)
        radius = float(rng.uniform(0.0, 0.5))
        bound = ob.clearance_bound(centre, radius)
        assert bound == pytest.approx(ob.signed_distance(centre[None, :])[0] - radius, abs=1e-12)
        u = rng.normal(size=(200, 3))
        u *= (radius * rng.uniform(0.0, 1.0, size=(200, 1)) ** (1 / 3)
              / np.linalg.norm(u, axis=1, keepdims=True))
        assert np.all(ob.signed_distance(centre + u) >= bound - 1e-12)


# -- values, scene-file form --------------------------------------------------------------------
def test_values_are_immutable_and_normalised():
    cyl = Cylinder([0, 0, 0], [0, 0, 2], 1)
    assert cyl.axis == (0.0, 0.0, 1.0) and isinstance(cyl.r, float)
    assert Plane([0, 0, 0], [3, 0, 4]).normal == pytest.approx((0.6, 0.0, 0.8))
    with pytest.raises(dataclasses.FrozenInstanceError):
        cyl.r = 2.0
    assert Sphere([1, 2, 3], 0.5) == Sphere((1.0, 2.0, 3.0), 0.5)
    assert hash(Sphere([1, 2, 3], 0.5)) == hash(Sphere((1.0, 2.0, 3.0), 0.5))


@pytest.mark.parametrize("name", OBSTACLES)
def test_kind_to_dict_and_describe(name):
    ob = OBSTACLES[name]
    entry = ob.to_dict()
    assert list(entry)[0] == "type" and entry["type"] == ob.kind
    expected = {"point_peg": "peg", "circle": "circle"}.get(name, name)
    assert ob.kind == expected
    line = ob.describe()
    assert "\n" not in line and line.startswith(ob.name)


def test_prism_takes_its_name_and_drops_a_zero_friction():
    prism = Prism(PegObstacle(0.0, 0.5, 0.1, name="pole", friction=0.0), name="post")
    assert prism.name == prism.planar.name == "post"
    assert prism.planar.friction is None and "friction" not in prism.to_dict()
    assert Prism(PegObstacle(0.0, 0.5, 0.1, name="pole")).name == "pole"


@pytest.mark.parametrize("build, key", [
    (lambda: Sphere((0.0, 0.0), 1.0), "center"),
    (lambda: Sphere((0.0, 0.0, math.nan), 1.0), "center[2]"),
    (lambda: Sphere("abc", 1.0), "center"),
    (lambda: Sphere((0.0, 0.0, 0.0), 0.0), "r"),
    (lambda: Sphere((0.0, 0.0, 0.0), -1.0), "r"),
    (lambda: Sphere((0.0, 0.0, 0.0), math.inf), "r"),
    (lambda: Sphere((0.0, 0.0, 0.0), "big"), "r"),
    (lambda: Cylinder((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 1.0), "axis"),
    (lambda: Cylinder((0.0, 0.0, 0.0), (0.0, 1.0), 1.0), "axis"),
    (lambda: Cylinder((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 0.0), "r"),
    (lambda: Cylinder((0.0, math.inf, 0.0), (0.0, 0.0, 1.0), 1.0), "point[1]"),
    (lambda: Plane((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)), "normal"),
    (lambda: Plane((0.0, 0.0, "x"), (0.0, 0.0, 1.0)), "point[2]"),
    (lambda: Plane((0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 1.0)), "point"),
    (lambda: Prism(PegObstacle(0.0, 0.5, 0.1, friction=0.3)), "friction"),
    (lambda: Prism("peg"), "planar"),
])
def test_bad_values_are_refused_naming_the_key(build, key):
    with pytest.raises(ParameterError) as info:
        build()
    message = str(info.value)
    assert "\n" not in message
    assert f"{key} = " in message
    assert message.split(":")[0] in ("sphere", "cylinder", "plane", "peg", "prism")


def test_the_message_names_the_obstacle():
    with pytest.raises(ParameterError, match=r"^ball: r = -2 is not allowed; the radius r must "
                                             r"be > 0"):
        Sphere((0.0, 0.0, 0.0), -2, name="ball")
    with pytest.raises(ParameterError, match=r"^shaft: axis = \[0, 0, 0\] has length 0"):
        Cylinder((0.0, 0.0, 0.0), [0, 0, 0], 1.0, name="shaft")
