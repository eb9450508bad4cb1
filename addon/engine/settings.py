"""How one line of dialogue is animated: :class:`LineSettings`, typed and
checked once, when it is built.

Every program builds one per line and hands it down whole: the command line
(``analyze``; ``batch``, whose options are the settings of the lines that
say nothing for themselves, each line's own column overriding them), the
batch runner per line, and Blender's operators and command (the panel's
settings, which Blender wraps with its own: key reduction, the whole
character).  :func:`.pipeline.analyze` and :func:`.render.render` read it.

A new per-line option (such as ``gestures`` and ``gesture_seed``) is a
field here, checked in
:meth:`LineSettings.__post_init__`, written in :meth:`LineSettings.to_dict`
for a Dask worker, and read where it takes effect; the programs then pass
it on without being changed.
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass, field
from functools import cached_property

from . import presets, visemes
from .alignment import AlignSettings
from .coarticulation import check_model
from .emotion_track import DEFAULT_FADE
from .errors import LipSyncError, SettingError
from .framerate import parse_fps
from .language import resolve_language
from .presets import Preset


@dataclass(frozen=True)
class LineSettings:
    """Every choice about one line, checked: build it with :meth:`of` from
    plain values (a preset's name, ``"29.97"``), change it with
    :meth:`replace`."""

    emotion: Preset                      # the emotion the line starts with
    viseme_set: str | None = None        # a built-in set's name or a file (None: default, or a learned preset's)
    coarticulation: str = "dominance"    # the coarticulation model (coarticulation.MODELS)
    fps: float = 30                      # frames per second, parsed (29.97 is 30000/1001)
    dictionary: str | None = None        # the user's pronunciation dictionary file
    language: str | None = None          # the transcript's language, a code as the user wrote it (None: English)
    emotion_fade: float = DEFAULT_FADE   # s over which an emotion change (tag, marker) cross-fades
    align: AlignSettings = field(default_factory=AlignSettings)   # the aligner's knobs (its worker processes)
    gestures: bool = True                # blinks, gaze, head and brows beside speech (.gestures)
    gesture_seed: int = 0                # another seed varies the gestures of the same line
    # How the user wrote two of them: the preset's name or file ("" when it
    # was given as a preset) and the frame rate ("24000/1001").  A result is
    # labelled with the first, and a batch output's record of what made it
    # holds both as written.
    emotion_name: str = ""
    fps_text: str = ""

    def __post_init__(self):
        if not isinstance(self.emotion, Preset):
            raise TypeError("LineSettings.emotion is a Preset: build the settings with LineSettings.of(emotion=...)")
        _check("coarticulation", check_model, self.coarticulation)
        if not self.emotion_fade >= 0 or math.isinf(self.emotion_fade):
            raise SettingError("emotion_fade", f"the emotion fade must be 0 s or more, got {self.emotion_fade!r}")
        if not self.fps_text:
            object.__setattr__(self, "fps_text", str(self.fps))
        object.__setattr__(self, "fps", _check("fps", parse_fps, self.fps))
        _check("language", resolve_language, self.language)
        if not isinstance(self.gestures, bool):
            raise SettingError("gestures", f"gestures is on or off (true or false), got {self.gestures!r}")
        if isinstance(self.gesture_seed, bool) or not isinstance(self.gesture_seed, int):
            raise SettingError("gesture_seed", f"the gesture seed must be a whole number, got {self.gesture_seed!r}")

    @classmethod
    def of(cls, emotion: str | os.PathLike | Preset | dict = "neutral", **options) -> LineSettings:
        """Settings from plain values: ``emotion`` is a built-in preset's
        name, a preset file, a :class:`.presets.Preset` or a preset document;
        ``fps`` a number or a text (``24``, ``"29.97"``, ``"24000/1001"``);
        the other options are the fields' own (``viseme_set="arkit"``,
        ``language="de"`` ...).  A bad value is a :class:`.errors.SettingError`
        naming the option (a preset that cannot be read: the
        :class:`.errors.PresetError` saying why)."""
        return cls(**_typed(emotion=emotion, **options))

    def replace(self, **options) -> LineSettings:
        """These settings with ``options`` changed, given as to :meth:`of`."""
        return dataclasses.replace(self, **_typed(**options))

    @cached_property
    def visemes(self) -> visemes.VisemeSet:
        """The line's viseme set (:func:`.presets.viseme_set_for`), read once."""
        return presets.viseme_set_for(self.emotion, self.viseme_set)

    @property
    def emotion_label(self) -> str:
        """What the line's starting emotion is called: the preset's name, else
        the name or file it was given by, else ``preset``."""
        return self.emotion.name or self.emotion_name or "preset"

    def to_dict(self) -> dict:
        """The settings as plain data (JSON-ready), for a process that has no
        access to this one's objects (a Dask worker): :meth:`from_dict`
        gives them back."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        out["emotion"] = self.emotion.to_dict()
        out["align"] = dataclasses.asdict(self.align)
        return out

    @classmethod
    def from_dict(cls, doc: dict) -> LineSettings:
        """Settings written by :meth:`to_dict`."""
        return cls(**{**doc, "emotion": Preset.from_dict(doc["emotion"]), "align": AlignSettings(**doc["align"])})


def _typed(**options) -> dict:
    """Plain values as the fields of :class:`LineSettings`: the emotion as a
    :class:`Preset` and the name it was given by, the frame rate as a number
    and as written."""
    if "emotion" in options:
        emotion = options["emotion"]
        options["emotion"] = presets.as_preset(emotion)
        options["emotion_name"] = os.fspath(emotion) if isinstance(emotion, (str, os.PathLike)) else ""
    if "fps" in options:
        options["fps_text"] = str(options["fps"])
        options["fps"] = _check("fps", parse_fps, options["fps"])
    return options


def _check(option: str, check, value):
    """``check(value)``, its error a :class:`SettingError` naming ``option``."""
    try:
        return check(value)
    except LipSyncError as exc:
        raise SettingError(option, str(exc)) from None


__all__ = ["LineSettings"]
