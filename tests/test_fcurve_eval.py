"""Animation curves evaluated in bulk (``engine/fcurve_eval.py``), checked
without Blender against the curve's own definition: a Bezier segment is the
cubic through its key, handles and next key, sampled densely in its
parameter; linear and constant segments are a line and a step.  (The
Blender tests check the same function against ``FCurve.evaluate``.)"""

from __future__ import annotations

import numpy as np
import pytest

from addon.engine import fcurve_eval
from addon.engine.fcurve_eval import BEZIER, CONSTANT, LINEAR


def _bezier_points(p1, p2, p3, p4, n=200001):
    """Dense (x, y) points of the cubic Bezier with these control points."""
    t = np.linspace(0.0, 1.0, n)[:, None]
    pts = ((1 - t) ** 3 * p1 + 3 * (1 - t) ** 2 * t * p2 + 3 * (1 - t) * t ** 2 * p3 + t ** 3 * p4)
    return pts[:, 0], pts[:, 1]


def _shortened(key, handle, width):
    """A handle reaching further in time than its segment, pulled back along
    itself to the segment's length (Blender's rule)."""
    reach = abs(handle[0] - key[0])
    return handle if reach <= width else key + (handle - key) * (width / reach)


def _reference(co, left, right, kinds, frames):
    """The curve by its definition, segment by segment."""
    out = np.empty(len(frames))
    dense = {}
    for i, f in enumerate(frames):
        if f <= co[0, 0] or f >= co[-1, 0]:
            out[i] = co[0, 1] if f <= co[0, 0] else co[-1, 1]
            continue
        k = np.searchsorted(co[:, 0], f, side="right") - 1
        a, b = co[k], co[k + 1]
        if kinds[k] == CONSTANT:
            out[i] = a[1]
        elif kinds[k] == LINEAR:
            out[i] = a[1] + (b[1] - a[1]) * (f - a[0]) / (b[0] - a[0])
        else:
            if k not in dense:
                width = b[0] - a[0]
                dense[k] = _bezier_points(a, _shortened(a, right[k], width), _shortened(b, left[k + 1], width), b)
            out[i] = np.interp(f, *dense[k])
    return out


def test_bezier_segments_follow_the_cubic_through_their_handles():
    rng = np.random.default_rng(7)
    frames_k = np.array([1.0, 6.0, 9.0, 20.0, 21.0, 35.0])
    co = np.column_stack([frames_k, rng.random(len(frames_k))])
    # Handles inside their segments, at random heights.
    gap = np.diff(frames_k)
    right = co.copy()
    right[:-1, 0] += gap * rng.uniform(0.05, 0.6, len(gap))
    left = co.copy()
    left[1:, 0] -= gap * rng.uniform(0.05, 0.6, len(gap))
    right[:, 1] += rng.normal(0, 0.4, len(co))
    left[:, 1] += rng.normal(0, 0.4, len(co))
    kinds = np.full(len(co), BEZIER)
    at = np.linspace(-3.0, 40.0, 431)
    got = fcurve_eval.evaluate(co, left, right, kinds, at)
    assert np.abs(got - _reference(co, left, right, kinds, at)).max() < 1e-6
    assert np.allclose(fcurve_eval.evaluate(co, left, right, kinds, frames_k), co[:, 1])   # through every key


def test_collinear_thirds_handles_draw_a_straight_line():
    co = np.array([[0.0, 0.0], [30.0, 3.0]])
    left = np.array([[-10.0, -1.0], [20.0, 2.0]])
    right = np.array([[10.0, 1.0], [40.0, 4.0]])
    at = np.arange(0.0, 30.5, 0.5)
    assert np.allclose(fcurve_eval.evaluate(co, left, right, [BEZIER, BEZIER], at), at / 10.0, atol=1e-9)


def test_flat_handles_ease_in_and_out_symmetrically():
    co = np.array([[0.0, 0.0], [10.0, 1.0]])
    left = np.array([[-3.0, 0.0], [7.0, 1.0]])
    right = np.array([[3.0, 0.0], [13.0, 1.0]])
    at = np.linspace(0.0, 10.0, 101)
    y = fcurve_eval.evaluate(co, left, right, [BEZIER, BEZIER], at)
    assert np.all(np.diff(y) >= -1e-12) and y[0] == 0.0 and y[-1] == 1.0
    assert y[50] == pytest.approx(0.5, abs=1e-9)
    assert np.allclose(y + y[::-1], 1.0, atol=1e-9)       # point-symmetric about the middle
    assert y[10] < 0.1 and y[90] > 0.9                      # slow out of and into the flat keys


def test_handles_reaching_past_their_segment_are_shortened():
    co = np.array([[0.0, 0.0], [10.0, 1.0], [12.0, 0.0]])
    # The middle key's handles reach 30 frames either way, over both neighbours.
    left = np.array([[-1.0, 0.0], [-20.0, 0.2], [11.0, 0.0]])
    right = np.array([[1.0, 0.0], [40.0, 1.8], [13.0, 0.0]])
    kinds = [BEZIER] * 3
    at = np.linspace(0.0, 12.0, 241)
    got = fcurve_eval.evaluate(co, left, right, kinds, at)
    assert np.all(np.isfinite(got))
    assert np.abs(got - _reference(co, left, right, kinds, at)).max() < 1e-6


def test_linear_and_constant_segments_and_the_ends_held():
    co = np.array([[0.0, 1.0], [10.0, 3.0], [20.0, -1.0], [25.0, 2.0]])
    handles = co.copy()
    kinds = [LINEAR, CONSTANT, BEZIER, LINEAR]
    at = np.array([-5.0, 0.0, 2.5, 10.0, 15.0, 19.999, 20.0, 25.0, 99.0])
    got = fcurve_eval.evaluate(co, handles, handles, kinds, at)
    assert np.allclose(got[:5], [1.0, 1.0, 1.5, 3.0, 3.0])
    assert got[5] == 3.0 and got[6] == -1.0                 # a step on the constant key's next key
    assert got[7] == 2.0 and got[8] == 2.0                  # the last key's value held after it
    assert np.allclose(got, _reference(co, handles, handles, kinds, at), atol=1e-6)


def test_what_is_not_a_curve_is_refused():
    co = np.array([[0.0, 1.0]])
    with pytest.raises(ValueError, match="two keys or more"):
        fcurve_eval.evaluate(co, co, co, [BEZIER], [0.0])
    co = np.array([[0.0, 1.0], [1.0, 2.0]])
    with pytest.raises(ValueError, match="interpolation codes"):
        fcurve_eval.evaluate(co, co, co, [BEZIER, 7], [0.5])
    assert fcurve_eval.evaluate(co, co, co, [LINEAR, LINEAR], []).shape == (0,)


@pytest.mark.parametrize("reach", [0.2, 1 / 3, 0.5])
def test_a_bezier_segment_cut_at_a_frame_draws_the_same_curve(reach):
    """The two halves of a cut segment draw what the whole did (handles
    reaching up to half the segment: Blender's automatic handles reach a
    third)."""
    key, nxt = np.array([2.0, 0.1]), np.array([12.0, 0.9])
    right, left = key + np.array([reach * 10, 0.5]), nxt - np.array([reach * 10, -0.2])
    frames = np.linspace(2.0, 12.0, 201)
    whole = fcurve_eval.evaluate([key, nxt], [key, left], [right, nxt], [BEZIER, BEZIER], frames)
    h1, hl, mid, hr, h2 = fcurve_eval.split(key, right, left, nxt, 6.0)
    assert mid[0] == 6.0
    assert mid[1] == pytest.approx(fcurve_eval.evaluate([key, nxt], [key, left], [right, nxt], [BEZIER] * 2,
                                                        [6.0])[0], abs=1e-9)
    halves = fcurve_eval.evaluate([key, mid, nxt], [key, hl, h2], [h1, hr, nxt], [BEZIER] * 3, frames)
    np.testing.assert_allclose(halves, whole, atol=1e-7)
    with pytest.raises(ValueError):
        fcurve_eval.split(key, right, left, nxt, 12.0)
