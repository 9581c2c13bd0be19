"""A scene drawn: on matplotlib axes and as the node's MarkerArray (no node, no DDS)."""

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from rclpy.serialization import deserialize_message, serialize_message
from visualization_msgs.msg import Marker, MarkerArray

from vibrissa_ros.scan.plots import draw_scene, plt
from vibrissa_ros.ros.messages import scene_markers
from vibrissa_ros.scan.scene_file import load_scene

SCENE = """
obstacles:
  - {type: peg, x: -0.35, y: 0.45, r: 0.03}
  - {type: peg, x: -0.6, y: 0.3}
  - {type: polygon, vertices: [[0.3, 0.6], [0.5, 0.6], [0.5, 0.8], [0.4, 0.7], [0.3, 0.8]]}
  - {type: curve, points: [[-1.0, 1.0], [0.0, 0.9], [1.0, 1.3]], side: above}
  - {type: circle, p0: 0.1, R: 0.3, placement: {x: 1.2, y: 0.0, rotation: -1.5}}
"""


@pytest.fixture(scope="module")
def scene():
    return load_scene(SCENE)


def test_markers_hold_every_obstacle_in_metres(scene):
    length = 0.05
    array = scene_markers(scene, length, "world", Time(sec=3, nanosec=5))
    array = deserialize_message(serialize_message(array), MarkerArray)
    clear, *shapes, corners = array.markers
    assert clear.action == Marker.DELETEALL and clear.ns == "scene"
    assert [m.id for m in array.markers] == list(range(len(scene) + 2))
    assert all(m.header.frame_id == "world" and m.header.stamp.sec == 3 for m in array.markers)
    assert all(m.type == Marker.LINE_STRIP and m.action == Marker.ADD for m in shapes)
    assert [m.text for m in shapes] == [ob.name for ob in scene]
    window = scene.window(margin=2.0)
    for ob, marker in zip(scene, shapes):
        pts = np.array([(p.x, p.y) for p in marker.points]) / length
        assert len(pts) >= 2
        if ob.name == "peg1":  # a point peg: a small visible circle about it
            assert np.hypot(pts[:, 0] + 0.6, pts[:, 1] - 0.3) == pytest.approx(0.005)
            continue
        assert pts[:, 0].min() >= window[0] - 1e-9 and pts[:, 0].max() <= window[2] + 1e-9
        assert pts[:, 1].min() >= window[1] - 1e-9 and pts[:, 1].max() <= window[3] + 1e-9
        assert np.median(np.abs(ob.signed_distance(pts))) < 1e-9  # on the boundary
        if ob.bounded:
            assert np.array_equal(pts[0], pts[-1])
    got = {(round(p.x / length, 12), round(p.y / length, 12)) for p in corners.points}
    expected = {(0.3, 0.6), (0.5, 0.6), (0.5, 0.8), (0.4, 0.7), (0.3, 0.8), (-0.6, 0.3)}
    assert got == expected and corners.type == Marker.POINTS


def test_draw_scene_fills_outlines_and_marks_corners(scene):
    fig, ax = plt.subplots()
    window = (-1.5, -0.5, 2.0, 2.0)
    draw_scene(ax, scene, window=window, scale_length=2.0)
    for ob in scene:
        gid = f"obstacle:{ob.name}"
        lines = [ln for ln in ax.get_lines() if ln.get_gid() == gid]
        assert lines, gid
        if ob.name == "peg1":
            assert lines[0].get_marker() == "+"
            assert tuple(lines[0].get_xydata()[0]) == (-1.2, 0.6)
            continue
        patches = [p for p in ax.patches if p.get_gid() == gid]
        assert patches, gid
        boundary = lines[0].get_xydata() / 2.0
        assert np.median(np.abs(ob.signed_distance(boundary))) < 1e-9
    polygon_lines = [ln for ln in ax.get_lines() if ln.get_gid() == "obstacle:polygon0"]
    filled = [ln for ln in polygon_lines if ln.get_marker() == "o" and ln.get_markerfacecolor()
              != "none"]
    hollow = [ln for ln in polygon_lines if ln.get_marker() == "o" and ln.get_markerfacecolor()
              == "none"]
    assert len(filled[0].get_xydata()) == 4 and tuple(hollow[0].get_xydata()[0]) == (0.8, 1.4)
    # infinite obstacles are cut at the window: the axes do not run off to infinity
    ax.relim()
    ax.autoscale_view()
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    assert x0 >= 2.0 * -1.5 - 0.5 and x1 <= 2.0 * 2.0 + 0.5
    assert y0 >= 2.0 * -0.5 - 0.5 and y1 <= 2.0 * 2.0 + 0.5
    plt.close(fig)
