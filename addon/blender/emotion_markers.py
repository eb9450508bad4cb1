"""Emotion changes from the timeline: markers named ``emotion:<preset>``
inside a line's frames switch the line to that preset from the marker's
frame (see the engine's ``emotion_track``), and the voice's arousal
estimate kept on the sound strip after Generate."""

from __future__ import annotations

from ..engine.errors import LipSyncError
from . import userdata

PREFIX = "emotion:"
#: Custom property on a sound strip: the arousal the last Generate estimated (-1 calm to +1 excited).
STRIP_AROUSAL = "lipsync_arousal"


def changes(scene, first_frame: int, duration: float, fps: float, find=None) -> list[tuple[float, dict]]:
    """(seconds into the line, preset) for each ``emotion:`` marker from
    ``first_frame`` to the line's end, its preset found by ``find`` (default:
    :func:`.userdata.finder`).  A marker naming no preset is an error naming
    the marker and its frame."""
    find = find or userdata.finder()
    end = first_frame + duration * fps
    out = []
    for m in scene.timeline_markers:
        if not m.name.lower().startswith(PREFIX) or not (first_frame <= m.frame < end):
            continue
        name = m.name[len(PREFIX):].strip()
        if not name:
            raise LipSyncError(f"timeline marker {m.name!r} at frame {m.frame} names no preset "
                               f"(write {PREFIX}angry, {PREFIX}sad ...)")
        try:
            preset = find(name)
        except LipSyncError as exc:
            raise LipSyncError(f"timeline marker {m.name!r} at frame {m.frame}: {exc}") from None
        out.append(((m.frame - first_frame) / fps, preset))
    return sorted(out, key=lambda c: c[0])
