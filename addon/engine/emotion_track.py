"""Emotion that changes inside a line.

A transcript may switch preset mid-line with an inline tag::

    I'm fine. [angry] Get out!  [neutral] Sorry.

A tag is a bracketed preset name (built-in or one of the studio's), a
preset file path ending in ``.json``, or either written ``[emotion:NAME]``;
``[neutral]`` returns to the reference preset.  Tags are taken out of the
text before it is normalised, so the aligner never sees them.  Other
bracketed text stays a stage direction (``[sighs]``), except a word that
looks like a misspelt preset name (``[angyr]``), which is an error naming
the tag and its position rather than a silent no-op.  In Blender, timeline
markers named ``emotion:<preset>`` inside a strip do the same at the
marker's time.

Each change takes effect at the start of the word the tag stands before (or
at the marker's time): the curves of the presets involved are computed over
the whole line and mixed frame by frame, the new preset's share rising
linearly from 0 to 1 over the ``fade`` seconds (default 0.3) that end there.
Away from a change, the curves are exactly the preset's own; across it,
they move from one to the other without a jump.
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass
from collections.abc import Callable

import numpy as np

from . import presets as presets_mod
from .errors import TranscriptError
from .language import normalize

#: Seconds over which one preset's numbers give way to the next.
DEFAULT_FADE = 0.3
_BRACKET = re.compile(r"\[([^\[\]\n]*)\]")
_PREFIX = re.compile(r"^\s*emotion\s*:\s*", re.IGNORECASE)


@dataclass
class Tag:
    """An inline emotion tag: the preset it names, the index of the spoken
    word it stands before, and its character position in the transcript."""

    preset: str
    word_index: int
    position: int


@dataclass
class Change:
    """The line switches to ``preset`` at ``time`` s."""

    time: float
    preset: presets_mod.Preset
    label: str


def _is_known(name: str, known: Callable[[str], bool]) -> bool:
    try:
        return known(name)
    except Exception:  # noqa: BLE001 - a lookup that fails means "not a preset"
        return False


def builtin_known(name: str) -> bool:
    try:
        presets_mod.load(name)
        return True
    except presets_mod.PresetError:
        return False


def split_tags(text: str, known: Callable[[str], bool] = builtin_known, names: list[str] | None = None,
               source: str = "the transcript") -> tuple[str, list[Tag]]:
    """Take the emotion tags out of ``text``: (text without them, tags).

    ``known(name)`` says whether a bracketed word names a preset (default:
    the built-in ones and preset files); ``names`` are the names offered
    when a tag looks misspelt.  Raises :class:`TranscriptError` naming the
    tag and its line and column for an explicit tag that names no preset."""
    names = list(names) if names is not None else presets_mod.builtin_names()
    tags: list[Tag] = []
    pieces, last = [], 0
    for m in _BRACKET.finditer(text):
        body = m.group(1).strip()
        explicit = bool(_PREFIX.match(body)) or body.lower().endswith(".json")
        name = _PREFIX.sub("", body).strip()
        line = text.count("\n", 0, m.start()) + 1
        col = m.start() - (text.rfind("\n", 0, m.start()) + 1) + 1
        where = f"{source}, line {line}, column {col}"
        if not name:
            if explicit:
                raise TranscriptError(f"emotion tag {m.group()!r} in {where} names no preset")
            continue
        if not _is_known(name, known):
            if not name.lower().endswith(".json") and _is_known(name.lower(), known):
                name = name.lower()
            elif explicit:
                raise TranscriptError(f"emotion tag {m.group()!r} in {where}: {name!r} is not a preset "
                                      f"(presets: {', '.join(names)})")
            else:
                near = difflib.get_close_matches(name.lower(), names, n=1, cutoff=0.8) if " " not in name else []
                if near:
                    raise TranscriptError(f"emotion tag {m.group()!r} in {where} is not a preset; did you mean "
                                          f"[{near[0]}]? (other bracketed text is a stage direction)")
                continue  # a stage direction: normalize() drops it
        before = "".join(pieces) + text[last:m.start()]
        try:
            count = len(normalize(before)) if before.strip() else 0
        except TranscriptError:
            count = 0
        tags.append(Tag(name, count, m.start()))
        pieces.append(text[last:m.start()] + " ")
        last = m.end()
    pieces.append(text[last:])
    return "".join(pieces), tags


def tag_times(tags: list[Tag], word_starts: list[float], duration: float) -> list[tuple[float, str]]:
    """Each tag's time: the start of the word it stands before (the end of
    the line for a tag after the last word)."""
    out = []
    for t in tags:
        time = word_starts[t.word_index] if t.word_index < len(word_starts) else duration
        out.append((0.0 if t.word_index == 0 else float(time), t.preset))
    return out


def mix(times: np.ndarray, change_times: list[float], n_presets: int, index: list[int],
        fade: float = DEFAULT_FADE) -> np.ndarray:
    """(frames, presets) shares summing to 1: preset 0 first, then each change
    k to preset ``index[k]`` fading in over the ``fade`` s before ``change_times[k]``.
    A change at time 0 (or a zero fade) switches at once."""
    times = np.asarray(times, dtype=float)
    out = np.zeros((len(times), n_presets))
    out[:, 0] = 1.0
    for t, k in sorted(zip(change_times, index), key=lambda c: c[0]):
        if fade > 0 and t > 0:
            alpha = np.clip((times - (t - fade)) / fade, 0.0, 1.0)
            alpha[times >= t] = 1.0   # exactly the new preset from the change on
        else:
            alpha = (times >= t).astype(float)
        one = np.zeros(n_presets)
        one[k] = 1.0
        out = (1.0 - alpha)[:, None] * out + alpha[:, None] * one
    return out


def timeline(base_label: str, changes: list[Change], fade: float) -> list[dict]:
    """The emotion over time as JSON: what plays from when, and each fade."""
    out = [{"emotion": base_label, "time": 0.0, "fade": None}]
    for c in sorted(changes, key=lambda c: c.time):
        if c.time <= 0:
            out = [{"emotion": c.label, "time": 0.0, "fade": None}]
            continue
        out.append({"emotion": c.label, "time": round(c.time, 4),
                    "fade": [round(max(0.0, c.time - fade), 4), round(c.time, 4)] if fade > 0 else None})
    return out
