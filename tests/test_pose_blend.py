"""Poses of a bone rig blended frame by frame (addon/engine/pose_blend.py)."""

import numpy as np
import pytest

from addon.engine import pose_blend as pb


def _angle_between(q1, q2):
    return 2 * np.arccos(min(1.0, abs(float(np.dot(q1, q2)))))


def test_location_and_scale_are_offsets_from_rest():
    poses = [{"jaw": {"location": [0, 0, -1], "scale": [1.2, 1.2, 1.2]}},
             {"jaw": {"location": [1, 0, 0], "scale": [0.9, 1, 1]}}]
    out = pb.blend(poses, np.array([[0, 0], [1, 0], [0.5, 0], [1, 1]]), {})
    loc, scale = out[("jaw", "location")], out[("jaw", "scale")]
    np.testing.assert_allclose(loc, [[0, 0, 0], [0, 0, -1], [0, 0, -0.5], [1, 0, -1]])
    np.testing.assert_allclose(scale, [[1, 1, 1], [1.2, 1.2, 1.2], [1.1, 1.1, 1.1], [1.1, 1.2, 1.2]])


def test_quaternion_blend_is_unit_and_follows_the_angle():
    q = pb.euler_to_quat([0.8, 0, 0])            # 0.8 rad about X
    out = pb.blend([{"jaw": {"rotation_quaternion": q}}], np.array([[0.0], [0.5], [1.0], [2.0]]),
                   {"jaw": "QUATERNION"})[("jaw", "rotation_quaternion")]
    np.testing.assert_allclose(np.linalg.norm(out, axis=1), 1.0)
    for w, row in zip([0, 0.5, 1, 2], out):
        assert _angle_between(row, pb.euler_to_quat([0.8 * w, 0, 0])) < 1e-9


def test_quaternion_sign_does_not_matter():
    q = pb.euler_to_quat([0.3, 0.2, 0])
    a = pb.blend([{"b": {"rotation_quaternion": q}}], np.array([[0.5]]), {})[("b", "rotation_quaternion")]
    b = pb.blend([{"b": {"rotation_quaternion": -q}}], np.array([[0.5]]), {})[("b", "rotation_quaternion")]
    np.testing.assert_allclose(a, b)


def test_axis_angle_blend():
    out = pb.blend([{"b": {"rotation_axis_angle": [1.0, 0, 0, 2]}}], np.array([[0.0], [0.25], [1.0]]),
                   {"b": "AXIS_ANGLE"})[("b", "rotation_axis_angle")]
    np.testing.assert_allclose(out, [[0, 0, 1, 0], [0.25, 0, 0, 1], [1.0, 0, 0, 1]], atol=1e-12)


def test_euler_blend_sums_angles_in_the_bones_order():
    poses = [{"b": {"rotation_euler": [0.2, 0, 0]}}, {"b": {"rotation_euler": [0, 0, 0.4]}}]
    out = pb.blend(poses, np.array([[1, 0.5]]), {"b": "ZXY"})[("b", "rotation_euler")]
    np.testing.assert_allclose(out, [[0.2, 0, 0.2]])


@pytest.mark.parametrize("order", pb.EULER_ORDERS)
def test_euler_quaternion_round_trip(order):
    rng = np.random.default_rng(3)
    for e in rng.uniform(-1.4, 1.4, (20, 3)):
        np.testing.assert_allclose(pb.quat_to_euler(pb.euler_to_quat(e, order), order), e, atol=1e-9)


def test_pose_in_another_mode_is_converted():
    q = pb.euler_to_quat([0.3, -0.2, 0.1], "XYZ")
    out = pb.blend([{"b": {"rotation_quaternion": q}}], np.array([[1.0]]), {"b": "XYZ"})
    np.testing.assert_allclose(out[("b", "rotation_euler")], [[0.3, -0.2, 0.1]], atol=1e-9)
    out = pb.blend([{"b": {"rotation_euler": [0.3, -0.2, 0.1]}}], np.array([[1.0]]), {"b": "QUATERNION"})
    assert _angle_between(out[("b", "rotation_quaternion")][0], q) < 1e-9


def test_untouched_bones_and_channels_are_left_out():
    out = pb.blend([{"jaw": {"rotation_euler": [0.1, 0, 0]}}, {"lip": {"location": [0, 0.1, 0]}}],
                   np.ones((2, 2)), {"jaw": "XYZ"})
    assert set(out) == {("jaw", "rotation_euler"), ("lip", "location")}


def test_closure_shows_the_closing_pose_alone():
    w = np.array([[0.7, 0.0, 0.4], [0.7, 0.2, 0.4], [0.7, 0.9, 0.4]])
    out = pb.with_closure(w, np.array([0.0, 0.5, 1.0]), [1])
    np.testing.assert_allclose(out, [[0.7, 0.0, 0.4], [0.35, 0.5, 0.2], [0.0, 1.0, 0.0]])


def test_bad_weights_shape():
    with pytest.raises(ValueError):
        pb.blend([{}], np.ones((3, 2)), {})
