"""Poses of a bone rig blended frame by frame (pure maths, no Blender).

A *pose* is what an animator saves in a pose library: for some bones, their
location, rotation and scale, each relative to the bone's rest pose (Blender
stores pose-bone channels that way).  Lip sync drives each pose with a weight
per frame; the rig shows their blend:

* location and scale as offsets from the rest pose: ``rest + sum(w * (pose -
  rest))`` (scale's rest is 1, so two poses scaling a bone by 1.2 and 0.9 at
  full weight give 1.1);
* a rotation blended in the bone's own rotation mode.  Quaternions and axis
  angles are summed as rotation vectors (the logarithm of the quaternion,
  ``axis * angle``) and turned back, so a pose at weight 1 shows exactly its
  rotation, half a weight half its angle about the same axis, and the
  result is a unit quaternion whatever the weights.  Euler angles are summed
  as angles, as Blender's own pose blending does; a pose keyed in another
  mode than the bone's is converted to it first.

Only the channels some pose keys are produced: a bone no pose touches is
left to the user's own animation, and so is the scale of a bone the poses
only rotate.

On a bone rig the lips meet only if the closing pose is not disturbed by the
others: :func:`with_closure` gives the closing poses the closure track's
weight and takes it from the other poses, so at a full closure the rig shows
exactly the pose the animator made for /p b m/.
"""

from __future__ import annotations

import numpy as np

#: The rest value of each pose-bone channel (Blender's defaults).
REST = {
    "location": (0.0, 0.0, 0.0),
    "scale": (1.0, 1.0, 1.0),
    "rotation_quaternion": (1.0, 0.0, 0.0, 0.0),
    "rotation_euler": (0.0, 0.0, 0.0),
    "rotation_axis_angle": (0.0, 0.0, 1.0, 0.0),
}
ROTATIONS = ("rotation_quaternion", "rotation_euler", "rotation_axis_angle")
EULER_ORDERS = ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")
MODES = ("QUATERNION", "AXIS_ANGLE") + EULER_ORDERS

#: A pose: bone name -> {channel ("location", "rotation_euler" ...): values}.
Pose = dict


def rotation_channel(mode: str) -> str:
    """The pose-bone channel a bone in rotation ``mode`` is keyed on."""
    if mode == "QUATERNION":
        return "rotation_quaternion"
    if mode == "AXIS_ANGLE":
        return "rotation_axis_angle"
    if mode in EULER_ORDERS:
        return "rotation_euler"
    raise ValueError(f"{mode!r} is not a rotation mode: {', '.join(MODES)}")


# --- rotations ---------------------------------------------------------------------

def _qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    w1, x1, y1, z1 = np.moveaxis(a, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(b, -1, 0)
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                     w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=-1)


def quat_log(q) -> np.ndarray:
    """Unit quaternion(s) (w, x, y, z) -> rotation vector(s) ``axis * angle``
    (the shorter way round: ``q`` and ``-q`` give the same vector)."""
    q = np.asarray(q, dtype=float)
    q = q / np.maximum(np.linalg.norm(q, axis=-1, keepdims=True), 1e-12)
    q = np.where(q[..., :1] < 0, -q, q)
    v = q[..., 1:]
    s = np.linalg.norm(v, axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(s, q[..., :1])
    return np.where(s > 1e-12, v / np.maximum(s, 1e-12) * angle, 2.0 * v)


def quat_exp(r) -> np.ndarray:
    """Rotation vector(s) -> unit quaternion(s) (w, x, y, z)."""
    r = np.asarray(r, dtype=float)
    angle = np.linalg.norm(r, axis=-1, keepdims=True)
    half = angle / 2.0
    axis = np.where(angle > 1e-12, r / np.maximum(angle, 1e-12), 0.0)
    q = np.concatenate([np.cos(half), axis * np.sin(half)], axis=-1)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def axis_angle_to_vector(aa) -> np.ndarray:
    """Blender's axis angle (angle, x, y, z) -> rotation vector."""
    aa = np.asarray(aa, dtype=float)
    axis = aa[..., 1:]
    n = np.linalg.norm(axis, axis=-1, keepdims=True)
    return np.where(n > 1e-12, axis / np.maximum(n, 1e-12), 0.0) * aa[..., :1]


def vector_to_axis_angle(r) -> np.ndarray:
    """Rotation vector -> Blender's axis angle (angle, x, y, z); no rotation
    is (0, 0, 1, 0), Blender's rest."""
    r = np.asarray(r, dtype=float)
    angle = np.linalg.norm(r, axis=-1, keepdims=True)
    axis = np.where(angle > 1e-12, r / np.maximum(angle, 1e-12), np.array([0.0, 1.0, 0.0]))
    return np.concatenate([angle, axis], axis=-1)


def euler_to_quat(e, order: str = "XYZ") -> np.ndarray:
    """Euler angles (x, y, z) in Blender's ``order`` (``XYZ``: X applied
    first) -> unit quaternion."""
    e = np.asarray(e, dtype=float)
    q = None
    for ax in order:
        i = "XYZ".index(ax)
        half = e[..., i:i + 1] / 2.0
        part = np.concatenate([np.cos(half)] + [np.sin(half) if j == i else np.zeros_like(half) for j in range(3)],
                              axis=-1)
        q = part if q is None else _qmul(part, q)
    return q


def quat_to_euler(q, order: str = "XYZ") -> np.ndarray:
    """Unit quaternion -> Euler angles (x, y, z) in Blender's ``order``."""
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    m = np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
                  np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
                  np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], -2)
    # R = R[order[2]] R[order[1]] R[order[0]]: a Tait-Bryan decomposition
    # with axes i (first), j, k; the sign follows the axes' parity.
    i, j, k = ("XYZ".index(a) for a in order)
    sign = 1.0 if (j - i) % 3 == 1 else -1.0
    b = np.clip(-sign * m[..., k, i], -1.0, 1.0)
    second = np.arcsin(b)
    first = np.arctan2(sign * m[..., k, j], m[..., k, k])
    third = np.arctan2(sign * m[..., j, i], m[..., i, i])
    out = np.empty(q.shape[:-1] + (3,))
    out[..., i], out[..., j], out[..., k] = first, second, third
    return out


def _as_vector(channel: str, value, order: str) -> np.ndarray:
    """A pose's rotation, keyed on ``channel``, as a rotation vector."""
    if channel == "rotation_quaternion":
        return quat_log(value)
    if channel == "rotation_axis_angle":
        return axis_angle_to_vector(value)
    return quat_log(euler_to_quat(value, order))


def _as_euler(channel: str, value, order: str) -> np.ndarray:
    if channel == "rotation_euler":
        return np.asarray(value, dtype=float)
    q = np.asarray(value, dtype=float) if channel == "rotation_quaternion" else quat_exp(axis_angle_to_vector(value))
    return quat_to_euler(q, order)


# --- blending --------------------------------------------------------------------

def touched(poses: list[Pose], modes: dict[str, str]) -> list[tuple[str, str]]:
    """The (bone, channel) pairs the blend of ``poses`` keys, bones in the
    order first met; a rotation on the channel of the bone's mode."""
    out = []
    for pose in poses:
        for bone, channels in pose.items():
            for ch in channels:
                pair = (bone, rotation_channel(modes.get(bone, "QUATERNION")) if ch in ROTATIONS else ch)
                if pair not in out:
                    out.append(pair)
    return out


def blend(poses: list[Pose], weights: np.ndarray, modes: dict[str, str]) -> dict[tuple[str, str], np.ndarray]:
    """The rig's channels on every frame: ``weights`` (frames, poses) drive
    ``poses``; ``modes`` gives each bone's rotation mode (``QUATERNION``,
    ``AXIS_ANGLE``, ``XYZ`` ...; a bone not listed is a quaternion bone).
    Returns (bone, channel) -> (frames, components) for the channels some
    pose keys (module docstring)."""
    weights = np.asarray(weights, dtype=float)
    if weights.ndim != 2 or weights.shape[1] != len(poses):
        raise ValueError(f"weights must be (frames, {len(poses)}), got {weights.shape}")
    frames = weights.shape[0]
    out = {}
    for bone, ch in touched(poses, modes):
        mode = modes.get(bone, "QUATERNION")
        if ch in ("location", "scale"):
            rest = np.asarray(REST[ch])
            acc = np.tile(rest, (frames, 1))
            for p, pose in enumerate(poses):
                value = pose.get(bone, {}).get(ch)
                if value is not None:
                    acc += weights[:, p:p + 1] * (np.asarray(value, dtype=float) - rest)
            out[(bone, ch)] = acc
            continue
        rotated = [(p, rc, pose[bone][rc]) for p, pose in enumerate(poses) for rc in ROTATIONS
                   if rc in pose.get(bone, {})]
        if ch == "rotation_euler":
            acc = np.zeros((frames, 3))
            for p, rc, value in rotated:
                acc += weights[:, p:p + 1] * _as_euler(rc, value, mode)
            out[(bone, ch)] = acc
            continue
        vec = np.zeros((frames, 3))
        for p, rc, value in rotated:
            vec += weights[:, p:p + 1] * _as_vector(rc, value, "XYZ")
        out[(bone, ch)] = quat_exp(vec) if ch == "rotation_quaternion" else vector_to_axis_angle(vec)
    return out


def with_closure(weights: np.ndarray, closure: np.ndarray, closing: list[int]) -> np.ndarray:
    """Pose weights (frames, poses) with the lips shut where ``closure`` (per
    frame, 0-1) says so: the ``closing`` poses (those /p b m/ shows) reach at
    least the closure's weight and the others give up as much, so at a full
    closure only the closing pose shows."""
    w = np.array(weights, dtype=float, copy=True)
    if not closing or not len(w):
        return w
    c = np.clip(np.asarray(closure, dtype=float), 0.0, 1.0)[:, None]
    others = [j for j in range(w.shape[1]) if j not in set(closing)]
    w[:, others] *= 1.0 - c
    w[:, closing] = np.maximum(w[:, closing], c)
    return w
