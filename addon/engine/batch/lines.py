"""A batch's lines: what each asks for (:class:`Line`; :func:`line_settings`,
the run's settings with the line's own), what became of it
(:class:`Outcome`), and the inputs a line names: its audio, and its words
(:func:`line_text`) from the file :func:`transcript_file` names."""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import AudioError
from ..language.text import read_text_file
from ..settings import LineSettings

#: Manifest columns this module reads; Blender's command also reads the last five.
COLUMNS = ("audio", "transcript", "text", "alignment", "emotion", "viseme_set", "fps", "output", "language",
           "mesh", "strip", "frame", "edits", "lock")
FORMATS = ("json", "csv")
#: The columns that shape a line's outputs, kept in the record of what made them.
ROW_COLUMNS = COLUMNS[:9]
#: The columns that are a line's own settings, overriding the run's (:func:`line_settings`).
SETTING_COLUMNS = ("emotion", "viseme_set", "fps", "language")


@dataclass
class Line:
    """One manifest line, its paths resolved."""

    number: int                        # line number in the manifest file (1 = first line)
    audio: str | None = None
    transcript: str | None = None
    text: str | None = None
    alignment: str | None = None
    emotion: str | None = None
    viseme_set: str | None = None
    fps: str | None = None
    language: str | None = None
    outputs: dict[str, str] = field(default_factory=dict)   # format -> path
    extra: dict[str, str] = field(default_factory=dict)     # mesh, strip, frame, edits, lock (Blender)
    problem: str | None = None          # why the line cannot be run
    row: dict[str, str] = field(default_factory=dict)       # its ROW_COLUMNS as written in the manifest
    record: dict | None = None          # what its outputs will be made from (see produced_by)

    def label(self) -> str:
        return self.audio or self.extra.get("strip") or self.extra.get("mesh") or "-"

    def inputs(self) -> dict[str, str]:
        """The line's own files, by role: its audio, transcript (the .txt
        beside the audio when it names no words) and alignment."""
        out = {k: getattr(self, k) for k in ("audio", "transcript", "alignment") if getattr(self, k)}
        if self.audio and not (self.transcript or self.text is not None or self.alignment):
            out["transcript"] = str(Path(self.audio).with_suffix(".txt"))
        return out


@dataclass
class Outcome:
    """What became of one line."""

    number: int
    label: str
    status: str                         # "ok", "skipped" or "failed"
    outputs: list[str] = field(default_factory=list)
    error: str | None = None
    seconds: float = 0.0
    result: object = None               # the pipeline.Result while it is being written
    record: dict | None = None          # what the result was made from, while it is being written
    reason: str | None = None           # why a line whose outputs existed was done again
    beyond: str = ""                    # how far the take strayed from its script (output.beyond_script)


def line_settings(line: Line, defaults: LineSettings) -> LineSettings:
    """The settings ``line`` is lip-synced with: the run's ``defaults`` with
    what the line says for itself (:data:`SETTING_COLUMNS`), aligned on one
    core (the lines run in parallel)."""
    own = {k: getattr(line, k) for k in SETTING_COLUMNS if getattr(line, k)}
    return defaults.replace(**own, align=dataclasses.replace(defaults.align, workers=1))


def check_audio_path(path: str | os.PathLike) -> None:
    """Raise :class:`AudioError` when ``path`` is missing or a folder: said
    first, before the want of a transcript, which the audio's absence may
    cause (the transcript beside it is looked for by the audio's name)."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise AudioError(f"audio file not found: {path}")
    if os.path.isdir(path):
        raise AudioError(f"audio path is a folder, not a file: {path}")


def transcript_file(line: Line) -> str | None:
    """The file a line's words are read from (its 'transcript', or the .txt
    beside its audio), whose folder preset files named in its tags are
    read from; None for inline text or an alignment alone."""
    if line.text is not None:
        return None
    if line.transcript:
        return line.transcript
    if line.audio and not line.alignment:
        side = Path(line.audio).with_suffix(".txt")
        if side.is_file():
            return str(side)
    return None


def line_text(line: Line) -> str | None:
    """The words of a line (None when only an alignment is given, or when
    there is no transcript at all: the words are then recognised)."""
    if line.text is not None:
        return line.text
    if line.transcript:
        return read_text_file(line.transcript)[0]
    if line.alignment:
        return None
    if line.audio:
        side = Path(line.audio).with_suffix(".txt")
        if side.is_file():
            return read_text_file(side)[0]
    return None
