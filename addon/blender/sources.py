"""Where the audio, the transcript, its language and the target mesh come
from: :func:`line_inputs` answers for one line, whichever operator or
command asks.

Audio is decoded by Blender's own sound library (``aud``), so every format
the sequencer plays works (a ``bpy`` build without it falls back on the
engine's reader: see :func:`.compat.decode_file`), ``//`` paths are resolved
against the .blend and packed sounds are read from their packed data.  A
sound strip's visible part is what gets lip-synced: trims, the strip's
offset and the sound offset are applied, and the keys start on the strip's
first visible frame.
"""

from __future__ import annotations

import os
import re
import stat
import tempfile
from collections.abc import Callable
from dataclasses import dataclass

import bpy

from ..engine.audio import Audio
from ..engine.errors import AudioError, LipSyncError, TranscriptError
from ..engine.language import resolve_language
from ..engine.language.text import read_text_file
from . import compat

#: Custom properties a sound strip may carry for batch runs.
STRIP_TARGET = "lipsync_target"
STRIP_TEXT = "lipsync_text"
STRIP_LANGUAGE = "lipsync_language"


@dataclass
class Clip:
    """One line to lip-sync, in plain values."""

    audio: Audio
    first_frame: int
    label: str
    audio_path: str | None  # for finding a transcript beside it
    strip: str = ""         # the sound strip's name ("" for an audio file)


def scene_fps(scene) -> float:
    return scene.render.fps / scene.render.fps_base


def decode(path: str) -> Audio:
    """Any file the sequencer can play -> mono float samples."""
    if not path:
        raise AudioError("no audio file given")
    if os.path.isdir(path):
        raise AudioError(f"audio path is a folder, not a file: {path}")
    if not os.path.isfile(path):
        raise AudioError(f"audio file not found: {path}")
    try:
        return compat.decode_file(path)
    except AudioError:
        raise
    except Exception as exc:  # noqa: BLE001 - aud raises its own error types
        raise AudioError(f"cannot decode {path}: {exc}") from None


def sound_path(sound) -> str:
    return bpy.path.abspath(sound.filepath, library=sound.library)


def decode_sound(sound) -> Audio:
    """A Sound datablock, packed or on disk."""
    if sound.packed_file is not None:
        ext = os.path.splitext(sound.filepath)[1] or ".wav"
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "packed" + ext)
            with open(path, "wb") as fh:
                fh.write(sound.packed_file.data)
            return decode(path)
    return decode(sound_path(sound))


def strip_by_name(scene, name: str):
    for s in compat.sound_strips(scene):
        if s.name == name:
            return s
    raise LipSyncError(f"no sound strip named {name!r} in scene {scene.name!r}")


def active_sound_strip(scene):
    ed = scene.sequence_editor
    s = ed.active_strip if ed is not None else None
    if s is not None and s.type == "SOUND":
        return s
    strips = compat.sound_strips(scene)
    return strips[0] if len(strips) == 1 else None


def strip_clip(scene, strip) -> Clip:
    """The visible part of a sound strip, and the frame it starts on."""
    if strip.sound is None:
        raise AudioError(f"sound strip {strip.name!r} has no sound")
    snd = decode_sound(strip.sound)
    fps = scene_fps(scene)
    first, end = compat.strip_frames(strip)
    start = compat.strip_content_start(strip)
    offset = compat.strip_sound_offset(strip)
    t0 = (first - start) / fps + offset
    t1 = (end - start) / fps + offset
    a = max(0, int(round(t0 * snd.rate)))
    b = min(len(snd.samples), int(round(t1 * snd.rate)))
    if b - a < int(0.05 * snd.rate):
        raise AudioError(f"sound strip {strip.name!r} shows less than 50 ms of its sound")
    path = None if strip.sound.packed_file is not None else sound_path(strip.sound)
    return Clip(Audio(snd.samples[a:b], snd.rate), int(first), strip.name, path, strip.name)


def file_clip(path: str, first_frame: int) -> Clip:
    path = bpy.path.abspath(path)
    return Clip(decode(path), first_frame, os.path.basename(path), path)


def sidecar_transcript(audio_path: str | None) -> str | None:
    """``line.txt`` beside ``line.wav``, in any encoding the engine reads
    (:func:`..engine.language.text.read_text_file`; a guessed encoding is reported on
    the console).  An unreadable file is a :class:`TranscriptError`."""
    if not audio_path:
        return None
    txt = os.path.splitext(audio_path)[0] + ".txt"
    if os.path.isfile(txt):
        body, notes = read_text_file(txt)
        for note in notes:
            print(f"Emotive Lip Sync: warning: {note}")
        return body
    return None


def has_sidecar_transcript(audio_path: str | None) -> bool:
    """Whether a ``.txt`` with text lies beside the audio (for the panel's
    checklist; an unreadable one counts, and Generate says what is wrong)."""
    if not audio_path:
        return False
    txt = os.path.splitext(audio_path)[0] + ".txt"
    try:
        info = os.stat(txt)
    except OSError:
        return False
    if not stat.S_ISREG(info.st_mode):
        return False
    key = (info.st_mtime_ns, info.st_size)
    known = _SIDECARS.get(txt)
    if known is not None and known[0] == key:    # the panel asks at every redraw: read a file once per change
        return known[1]
    try:
        found = bool(read_text_file(txt)[0].strip())
    except LipSyncError:
        found = True
    _SIDECARS[txt] = (key, found)
    return found


#: path -> ((modification time, size), whether it holds text), for :func:`has_sidecar_transcript`.
_SIDECARS: dict[str, tuple[tuple[int, int], bool]] = {}


#: Where the words come from when no transcript is given.
RECOGNISED = "recognised from the audio (no transcript)"


def transcript(text: str = "", text_block=None, audio_path: str | None = None,
               required: bool = False) -> tuple[str | None, str]:
    """The transcript and where it came from: a text block, typed text, or
    a .txt beside the audio, in that order.  With none of them the text is
    None (the words are recognised from the audio: :data:`RECOGNISED`),
    unless ``required``.  A text block or .txt that is there but empty is
    an error either way: the user meant it to hold the words."""
    if text_block is not None:
        body = text_block.as_string()
        if not body.strip():
            raise TranscriptError(f"the transcript is empty: text block {text_block.name!r} holds no text")
        return body, f"text block {text_block.name!r}"
    if text.strip():
        return text, "typed text"
    side = sidecar_transcript(audio_path)
    if side is not None:
        if not side.strip():
            raise TranscriptError(f"the transcript is empty: {os.path.splitext(audio_path)[0]}.txt holds no text")
        return side, os.path.basename(os.path.splitext(audio_path)[0] + ".txt")
    if not required:
        return None, RECOGNISED
    where = f" or save it as {os.path.basename(os.path.splitext(audio_path)[0])}.txt beside the audio" \
        if audio_path else ""
    raise TranscriptError(f"the transcript is empty: type it, pick a text block{where}")


def strip_transcript(strip, audio_path: str | None, required: bool = False) -> tuple[str | None, str]:
    """For batch runs: the strip's ``lipsync_text`` (a text block's name),
    else the .txt beside its audio, else (unless ``required``) None: the
    words are recognised."""
    name = strip.get(STRIP_TEXT)
    if name:
        block = bpy.data.texts.get(name)
        if block is None:
            raise TranscriptError(f"strip {strip.name!r}: its lipsync_text names {name!r}, "
                                  "which is not a text block")
        return transcript(text_block=block)
    try:
        return transcript(audio_path=audio_path, required=required)
    except TranscriptError as exc:
        raise TranscriptError(f"strip {strip.name!r}: {exc}") from None


def strip_language(strip) -> str | None:
    """For batch runs: the language code of the strip's ``lipsync_language``
    (None: the run's own); an unknown code names the strip."""
    code = strip.get(STRIP_LANGUAGE)
    if code is None or not str(code).strip():
        return None
    try:
        return resolve_language(str(code)).code
    except LipSyncError as exc:
        raise LipSyncError(f"strip {strip.name!r}: its lipsync_language: {exc}") from None


def strip_target(strip, fallback=None):
    """The mesh (or armature) a strip lip-syncs in batch runs.

    1. the object named by the strip's ``lipsync_target`` custom property;
    2. else the mesh whose name the strip's name starts with, followed by the
       end or a separator (``Bob`` for strips ``Bob``, ``Bob.001``,
       ``Bob_line03``, ``Bob - take 2``); the longest such name wins;
    3. else ``fallback``.
    """
    name = strip.get(STRIP_TARGET)
    if name:
        obj = bpy.data.objects.get(name)
        if obj is None or obj.type not in ("MESH", "ARMATURE"):
            raise LipSyncError(f"strip {strip.name!r}: its lipsync_target names {name!r}, which is not a mesh or "
                               "an armature")
        return obj
    best = None
    for obj in bpy.data.objects:
        if obj.type not in ("MESH", "ARMATURE") or not obj.name:
            continue
        if re.match(re.escape(obj.name) + r"($|[\s._\-])", strip.name):
            if best is None or len(obj.name) > len(best.name):
                best = obj
    return best or fallback


@dataclass
class LineInputs:
    """One line to lip-sync, read from Blender: the object keyed, its sound,
    its words and their language."""

    target: object                 # the mesh (or armature) keyed
    clip: Clip
    text: str | None               # None: the words are recognised from the audio
    language: str | None = None    # the line's own language, over the run's (None: the run's)


def line_inputs(scene, *, strip=None, audio: str | None = None, frame: int = 0, target=None, fallback=None,
                no_target: str = "", text: str | None = None, transcript_file: str | None = None,
                typed: str = "", text_block=None, language: str | None = None, strip_properties: bool = True,
                on_clip: Callable[[Clip], None] | None = None) -> LineInputs:
    """Resolve one line: its sound, the object it keys, its words and their
    language, each from the first place that has it.

    * The sound: the file ``audio`` (keyed from ``frame``); else the sound
      strip ``strip`` (a strip, or its name), else the scene's active one.
    * The object: ``target``; else, for a strip, the one the strip names
      (:func:`strip_target`); else ``fallback``.  With none, an error ending
      in the ``no_target`` advice.
    * The words: ``text``; else the file ``transcript_file``; else a strip's
      ``lipsync_text``; else the text block ``text_block``, the ``typed``
      text and the .txt beside the audio (:func:`transcript`); else none (they
      are recognised).
    * The language: ``language``; else a strip's ``lipsync_language``; else
      none (the run's).

    A strip's own properties (``lipsync_target``, ``lipsync_text``,
    ``lipsync_language``) are for runs over many strips: the panel's
    Generate, where the panel says it all, passes ``strip_properties=False``.
    ``on_clip`` is told the clip as soon as it is read (the batch command
    places the next audio file after it, keyed or not).
    """
    if audio is None:
        if isinstance(strip, str) or strip is None:
            strip = strip_by_name(scene, strip) if strip else active_sound_strip(scene)
        if strip is None:
            raise LipSyncError("no sound strip: add one to the sequencer, pick it in the Lip Sync panel, or "
                               "choose an audio file")
    else:
        strip = None
    own = strip_properties and strip is not None
    if target is None:
        target = strip_target(strip, fallback) if own else fallback
        if target is None:
            where = f"strip {strip.name!r}" if strip is not None else audio
            raise LipSyncError(f"{where}: no mesh ({no_target})")
    clip = strip_clip(scene, strip) if strip is not None else file_clip(audio, frame)
    if on_clip is not None:
        on_clip(clip)
    if text is None and transcript_file:
        text = read_text_file(transcript_file)[0]
    elif text is None:
        text = (strip_transcript(strip, clip.audio_path) if own else
                transcript(typed, text_block, clip.audio_path))[0]
    if language is None and own:
        language = strip_language(strip)
    return LineInputs(target, clip, text, language)
