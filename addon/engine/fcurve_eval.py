"""Animation curves evaluated in bulk: the value a keyframed curve takes on
any frame, for many frames at once, with numpy.

A curve is its keys (frame, value), each key's left and right Bezier
handles, and each key's interpolation, which shapes the segment from that
key to the next: :data:`CONSTANT` (the key's value held), :data:`LINEAR`
(a straight line) or :data:`BEZIER` (the cubic through the key, its right
handle, the next key's left handle and the next key).  Segments are
evaluated the way Blender evaluates an F-curve
(``fcurve_eval_keyframes_interpolate``): a handle reaching further in time
than its segment is long is first shortened to that length, so that time
keeps running forward along the segment, and the Bezier's time is solved
for each frame.  Before the first key and after the last the curve holds
the end key's value (constant extrapolation).

The key reduction of the Blender layer uses it to check the curve Blender
will draw through the keys it kept, and a locked range of frames keeps its
shape when a key is added at its edge (:func:`split`); nothing here needs
Blender.
"""

from __future__ import annotations

import numpy as np

#: A key's interpolation (Blender's own codes, ``BEZT_IPO_CONST``, ``_LIN``, ``_BEZ``).
CONSTANT, LINEAR, BEZIER = 0, 1, 2


def _power(p1, p2, p3, p4):
    """Bezier control values -> the coefficients of the cubic in t."""
    return p4 - p1 + 3.0 * (p2 - p3), 3.0 * (p1 - 2.0 * p2 + p3), 3.0 * (p2 - p1), p1


def evaluate(keys, handle_left, handle_right, interpolation, frames, tol: float = 1e-9) -> np.ndarray:
    """The curve's value on each of ``frames``.

    ``keys``, ``handle_left``, ``handle_right``: (n, 2) arrays of (frame,
    value), the keys in time order, n >= 2; ``interpolation``: n codes
    (:data:`CONSTANT`, :data:`LINEAR`, :data:`BEZIER`).  ``tol``: frames of
    error allowed when solving a Bezier's time."""
    co = np.asarray(keys, dtype=np.float64).reshape(-1, 2)
    left = np.asarray(handle_left, dtype=np.float64).reshape(-1, 2)
    right = np.asarray(handle_right, dtype=np.float64).reshape(-1, 2)
    kinds = np.asarray(interpolation).reshape(-1)
    frames = np.asarray(frames, dtype=np.float64).reshape(-1)
    if len(co) < 2 or not (len(left) == len(right) == len(kinds) == len(co)):
        raise ValueError("a curve needs two keys or more, with a left and a right handle and an interpolation each")
    if not np.isin(kinds, (CONSTANT, LINEAR, BEZIER)).all():
        raise ValueError(f"interpolation codes must be {CONSTANT} (constant), {LINEAR} (linear) or {BEZIER} (Bezier)")
    if not len(frames):
        return np.zeros(0)
    seg = np.clip(np.searchsorted(co[:, 0], frames, side="right") - 1, 0, len(co) - 2)
    v1, v4 = co[seg], co[seg + 1]
    v2, v3 = right[seg].copy(), left[seg + 1].copy()
    # A handle reaching further in time than the segment is long is
    # shortened to that length (Blender's BKE_fcurve_correct_bezpart).
    width = v4[:, 0] - v1[:, 0]
    for key, handle in ((v1, v2), (v4, v3)):
        reach = np.abs(key[:, 0] - handle[:, 0])
        fac = np.where(reach > width, width / np.where(reach > 0, reach, 1.0), 1.0)[:, None]
        handle[:] = key - fac * (key - handle)

    ax, bx, cx, dx = _power(v1[:, 0], v2[:, 0], v3[:, 0], v4[:, 0])
    target = np.clip(frames, v1[:, 0], v4[:, 0])
    span = np.where(width > 0, width, 1.0)
    lo, hi = np.zeros(len(frames)), np.ones(len(frames))
    t = (target - v1[:, 0]) / span
    # x(t) rises on [0, 1]: Newton's method kept inside a shrinking bracket,
    # halving it where a step would leave it.
    for _ in range(60):
        fx = ((ax * t + bx) * t + cx) * t + dx - target
        if np.abs(fx).max() < tol:
            break
        lo, hi = np.where(fx < 0, t, lo), np.where(fx > 0, t, hi)
        slope = (3.0 * ax * t + 2.0 * bx) * t + cx
        step = t - fx / np.where(slope > 0, slope, 1.0)
        newton = (slope > 0) & (step >= lo) & (step <= hi)
        t = np.where(fx == 0, t, np.where(newton, step, (lo + hi) / 2))
    ay, by, cy, dy = _power(v1[:, 1], v2[:, 1], v3[:, 1], v4[:, 1])
    out = ((ay * t + by) * t + cy) * t + dy
    kind = kinds[seg]
    out = np.where(kind == LINEAR, v1[:, 1] + (v4[:, 1] - v1[:, 1]) * (target - v1[:, 0]) / span, out)
    out = np.where(kind == CONSTANT, v1[:, 1], out)
    # Constant extrapolation past the end keys.
    out = np.where(frames <= co[0, 0], co[0, 1], out)
    out = np.where(frames >= co[-1, 0], co[-1, 1], out)
    return out


def split(key, handle_right, handle_left, next_key, frame: float, tol: float = 1e-9) -> np.ndarray:
    """A Bezier segment cut at ``frame`` without changing its shape (de
    Casteljau): the segment from ``key`` (its ``handle_right``) to
    ``next_key`` (its ``handle_left``), each an (frame, value) pair, handles
    first shortened as Blender shortens them.  Exact where the handles do
    not cross in time (Blender's automatic handles reach a third of the
    segment); where they do, the halves draw nearly the same curve.  Returns five points: the
    key's new right handle, the new key's left handle, the new key, its
    right handle, and the next key's new left handle."""
    p1, p4 = np.asarray(key, dtype=np.float64), np.asarray(next_key, dtype=np.float64)
    p2, p3 = np.asarray(handle_right, dtype=np.float64).copy(), np.asarray(handle_left, dtype=np.float64).copy()
    width = p4[0] - p1[0]
    if not p1[0] < frame < p4[0]:
        raise ValueError(f"frame {frame} is not inside the segment {p1[0]}-{p4[0]}")
    for k, h in ((p1, p2), (p4, p3)):
        reach = abs(k[0] - h[0])
        if reach > width:
            h[:] = k - (width / reach) * (k - h)
    ax, bx, cx, dx = _power(p1[0], p2[0], p3[0], p4[0])
    lo, hi, t = 0.0, 1.0, (frame - p1[0]) / width
    for _ in range(100):
        fx = ((ax * t + bx) * t + cx) * t + dx - frame
        if abs(fx) < tol:
            break
        lo, hi = (t, hi) if fx < 0 else (lo, t)
        slope = (3.0 * ax * t + 2.0 * bx) * t + cx
        step = t - fx / slope if slope > 0 else -1.0
        t = step if lo <= step <= hi else (lo + hi) / 2
    p12, p23, p34 = p1 + t * (p2 - p1), p2 + t * (p3 - p2), p3 + t * (p4 - p3)
    p123, p234 = p12 + t * (p23 - p12), p23 + t * (p34 - p23)
    mid = p123 + t * (p234 - p123)
    mid[0] = frame
    return np.array([p12, p123, mid, p234, p34])
