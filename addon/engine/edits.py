"""Hand edits kept over a new run: what an animator changed on the curves a
run keyed, found, anchored to the line's sounds and laid on the next run's
curves.

A run remembers what it keyed on a target (:class:`Take`): its curves as
drawn, on each frame of the line, and the line's words and phones.  On the
next run of that line, the curve now minus the curve remembered is the
animator's work (:func:`find`): each stretch of frames where one channel
differs is an :class:`Edit`, an offset on the curve, or the values
themselves where the animator replaced the keys of the stretch (deleted the
keys the run wrote there and keyed their own).

The new alignment may place the sounds elsewhere: a new take, a transcript
with a word changed, another speed.  :class:`Warp` matches the old words to
the new by their text (the runs of words the two share, in order), then
the phones of each matched word, and maps old times to new ones through those anchors,
piecewise linear; an edit moves and stretches with the sounds it sits on.
An edit on a word the new line does not say is dropped.  :func:`carry` lays
the edits on the new run's curves and says what became of them
(:class:`Carried`); :func:`remembered` is what the new run keeps for the
next one.

Plain arrays in, plain arrays out: the Blender layer reads the curves and
writes the keys.
"""

from __future__ import annotations

import difflib
import math
import re
from dataclasses import dataclass, field

import numpy as np

from .alignment import Alignment

#: How far a curve may differ from the one remembered and still count as
#: untouched (the keys hold 32-bit floats; the copy is read back from them).
THRESHOLD = 1e-4

#: Anchors whose shifts are averaged (s either side): an aligner's boundary
#: wanders by 10-20 ms between takes, and a one-frame edit must not.
SMOOTH = 0.1

#: Keep and discard: what a run does with the edits it finds.
KEEP, DISCARD = "keep", "discard"
MODES = (KEEP, DISCARD)


@dataclass(frozen=True)
class Timing:
    """A line's spoken words (text, start, end) and their phones (phone,
    start, end, index of its word), in s from the line's start: what the
    edits are anchored to."""

    words: tuple[tuple[str, float, float], ...] = ()
    phones: tuple[tuple[str, float, float, int], ...] = ()

    @classmethod
    def of(cls, alignment: Alignment) -> Timing:
        """The spoken words of ``alignment`` and their phones (a transcript
        word the take does not hold has no time of its own)."""
        index, words = {}, []
        for k, w in enumerate(alignment.words):
            if w.spoken:
                index[k] = len(words)
                words.append((w.text, round(float(w.start), 4), round(float(w.end), 4)))
        phones = tuple((p.phone, round(float(p.start), 4), round(float(p.end), 4), index[p.word_index])
                       for p in alignment.phones if p.word_index in index)
        return cls(tuple(words), phones)

    def to_dict(self) -> dict:
        return {"words": [list(w) for w in self.words], "phones": [list(p) for p in self.phones]}

    @classmethod
    def from_dict(cls, doc: dict) -> Timing:
        return cls(tuple((str(t), float(a), float(b)) for t, a, b in doc.get("words", [])),
                   tuple((str(p), float(a), float(b), int(w)) for p, a, b, w in doc.get("phones", [])))

    def by_word(self) -> dict[int, list[tuple[str, float, float, int]]]:
        """Each word's phones, by the word's index."""
        out: dict[int, list] = {}
        for p in self.phones:
            out.setdefault(p[3], []).append(p)
        return out


@dataclass
class Take:
    """What a run keyed for one line on one target: ``values`` (frames,
    channels), the curve of each of ``names`` as drawn on the frames from
    ``first`` (with the edits it laid on taken off again), at ``fps``, and
    the line's :class:`Timing`.  ``keys``: the frames (from ``first``) the
    run put keys on, per channel, where that is not every frame; ``held``:
    the stretches (first, last, from ``first``) of a channel whose values an
    animator replaced, which stay replaced on the next run."""

    first: int
    fps: float
    timing: Timing
    names: list[str]
    values: np.ndarray
    keys: dict[str, np.ndarray] | None = None
    held: dict[str, list[tuple[int, int]]] = field(default_factory=dict)

    @property
    def frames(self) -> np.ndarray:
        return self.first + np.arange(len(self.values))

    @property
    def last(self) -> int:
        return self.first + len(self.values) - 1

    def key_offsets(self, name: str) -> np.ndarray:
        """The frames (from :attr:`first`) the run keyed ``name`` on."""
        if self.keys is None or name not in self.keys:
            return np.arange(len(self.values))
        return np.asarray(self.keys[name], dtype=np.float64)

    def meta(self) -> dict:
        """Everything but the values, as plain data (JSON-ready)."""
        return {"first": int(self.first), "fps": float(self.fps), "frames": len(self.values),
                "names": list(self.names), "timing": self.timing.to_dict(),
                "keys": None if self.keys is None else {k: [float(f) for f in v] for k, v in self.keys.items()},
                "held": {k: [list(s) for s in v] for k, v in self.held.items() if v}}

    @classmethod
    def from_meta(cls, meta: dict, values) -> Take:
        """The take :meth:`meta` described, with its ``values`` (flat or
        (frames, channels))."""
        names = list(meta["names"])
        arr = np.asarray(values, dtype=np.float64).reshape(int(meta["frames"]), len(names))
        keys = meta.get("keys")
        return cls(int(meta["first"]), float(meta["fps"]), Timing.from_dict(meta.get("timing", {})), names, arr,
                   None if keys is None else {k: np.asarray(v, dtype=np.float64) for k, v in keys.items()},
                   {k: [(int(a), int(b)) for a, b in v] for k, v in meta.get("held", {}).items()})

    def rewritten(self, frames: np.ndarray, names: list[str], values: np.ndarray) -> Take:
        """This take with the curves of ``names`` on ``frames`` (absolute)
        set to ``values`` (frames, names): another line keyed over them, so
        that what is there now is no edit of this one."""
        out = Take(self.first, self.fps, self.timing, list(self.names), self.values.copy(), self.keys,
                   dict(self.held))
        col = {n: j for j, n in enumerate(self.names)}
        rows = np.asarray(frames) - self.first
        inside = (rows >= 0) & (rows < len(self.values))
        for j, name in enumerate(names):
            if name in col:
                out.values[rows[inside], col[name]] = values[inside, j]
        return out


@dataclass
class Edit:
    """A stretch of frames where an animator changed one channel: from
    absolute frame ``first``, per frame, the offset on the curve the run
    keyed, or (``replace``) the value keyed by hand."""

    channel: str
    first: int
    values: np.ndarray
    replace: bool = False

    @property
    def frames(self) -> np.ndarray:
        return self.first + np.arange(len(self.values))

    @property
    def peak(self) -> int:
        """The frame it changes most."""
        return int(self.first + np.argmax(np.abs(self.values)))


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) index of every run of True in ``mask``."""
    m = np.concatenate([[False], np.asarray(mask, dtype=bool), [False]])
    edges = np.flatnonzero(m[1:] != m[:-1])
    return [(int(a), int(b) - 1) for a, b in zip(edges[0::2], edges[1::2])]


def find(take: Take, current: dict[str, np.ndarray], keys: dict[str, np.ndarray] | None = None,
         threshold: float = THRESHOLD) -> list[Edit]:
    """The edits on ``take``'s channels: ``current`` holds each channel's
    curve now, on the take's frames (a channel missing there is left out:
    its curve was deleted).  ``keys``: the frames each channel has keys on
    now (absolute); a stretch where the animator deleted keys the run wrote
    and keyed their own is a replacement, as is one the take says was
    replaced before (:attr:`Take.held`)."""
    out = []
    for j, name in enumerate(take.names):
        now = current.get(name)
        if now is None:
            continue
        now = np.asarray(now, dtype=np.float64)
        diff = now - take.values[:, j]
        ours = take.key_offsets(name)
        theirs = None if keys is None or name not in keys else np.asarray(keys[name], dtype=np.float64) - take.first
        for s, e in _runs(np.abs(diff) > threshold):
            replace = any(a <= e and b >= s for a, b in take.held.get(name, []))
            if theirs is not None and not replace:
                # Keys on the stretch and its unchanged neighbours: fewer than
                # the run wrote, and some inside it, is keys deleted and keyed anew.
                written = np.count_nonzero((ours >= s - 1) & (ours <= e + 1))
                there = np.count_nonzero((theirs >= s - 1 - 1e-3) & (theirs <= e + 1 + 1e-3))
                inside = np.count_nonzero((theirs > s - 1 + 1e-3) & (theirs < e + 1 - 1e-3))
                replace = there < written and inside > 0
            values = now[s:e + 1] if replace else diff[s:e + 1]
            out.append(Edit(name, take.first + s, values.copy(), replace))
    return out


def _word_key(text: str) -> str:
    """A word as matched between takes: lower case, punctuation gone."""
    return re.sub(r"[^\w']+", "", text.lower())


def _matched(a: list[str], b: list[str]) -> dict[int, int]:
    """The words of ``a`` matched in ``b`` (index -> index), in order: the
    longest run of words the two share, then the longest in what is left on
    either side of it, and so on (:class:`difflib.SequenceMatcher`'s
    matching blocks; a line changes in a few places, and this takes time
    in proportion to its length where a minimum edit path takes it in
    proportion to its square)."""
    out = {}
    for i, j, n in difflib.SequenceMatcher(None, a, b, autojunk=False).get_matching_blocks():
        out.update({i + k: j + k for k in range(n)})
    return out


class Warp:
    """Old line times -> new line times, through the words the two timings
    share (and their phones, where a word's phones are the same in both).
    Where no word matches, times stay as they were."""

    def __init__(self, old: Timing, new: Timing, smooth: float = SMOOTH):
        self.matched = _matched([_word_key(w[0]) for w in old.words], [_word_key(w[0]) for w in new.words])
        self.old = old
        pairs = []
        old_phones, new_phones = old.by_word(), new.by_word()
        for i, j in self.matched.items():
            po, pn = old_phones.get(i, []), new_phones.get(j, [])
            if po and [p[0] for p in po] == [p[0] for p in pn]:
                pairs += [(p[1], q[1]) for p, q in zip(po, pn)] + [(po[-1][2], pn[-1][2])]
            else:
                pairs += [(old.words[i][1], new.words[j][1]), (old.words[i][2], new.words[j][2])]
        self.at, self.shift = self._anchors(pairs, smooth)

    @staticmethod
    def _anchors(pairs: list[tuple[float, float]], smooth: float) -> tuple[np.ndarray, np.ndarray]:
        """Anchor times and the (smoothed) shift at each, time running forward."""
        if not pairs:
            return np.zeros(1), np.zeros(1)
        arr = np.array(sorted(pairs))
        at, idx = np.unique(arr[:, 0], return_inverse=True)
        shift = np.bincount(idx, arr[:, 1] - arr[:, 0]) / np.bincount(idx)
        if smooth > 0:   # the mean shift of the anchors within ``smooth`` s
            lo = np.searchsorted(at, at - smooth - 1e-9, side="left")
            hi = np.searchsorted(at, at + smooth + 1e-9, side="right")
            total = np.concatenate([[0.0], np.cumsum(shift)])
            shift = (total[hi] - total[lo]) / (hi - lo)
        new = at + shift
        keep = np.ones(len(at), dtype=bool)
        top = -math.inf
        for k, t in enumerate(new):     # an anchor that would run time backwards is left out
            keep[k] = t > top
            top = max(top, t) if keep[k] else top
        return at[keep], shift[keep]

    def __call__(self, t) -> np.ndarray:
        t = np.asarray(t, dtype=np.float64)
        return t + np.interp(t, self.at, self.shift)

    def gone(self, t: float) -> str | None:
        """The old word at time ``t`` the new timing does not hold, if any."""
        for i, (text, start, end) in enumerate(self.old.words):
            if start <= t <= end and i not in self.matched:
                return text
        return None


@dataclass
class Carried:
    """A new run's curves with the edits laid on them (``values``, frames x
    channels) and what became of the edits: kept where they were, moved
    with their sound, dropped (why, each), left in the locked frames; the
    stretches each channel holds replaced values on (from the line's first
    frame, for :attr:`Take.held`)."""

    values: np.ndarray
    kept: int = 0
    moved: int = 0
    dropped: list[str] = field(default_factory=list)
    locked: int = 0
    held: dict[str, list[tuple[int, int]]] = field(default_factory=dict)

    @property
    def carried(self) -> int:
        return self.kept + self.moved

    def message(self) -> str:
        """The report's words ("" when there was no edit)."""
        parts = []
        if self.kept:
            parts.append(f"{self.kept} kept")
        if self.moved:
            parts.append(f"{self.moved} moved with their sound")
        if self.locked:
            parts.append(f"{self.locked} in the locked frames")
        if self.dropped:
            parts.append(f"{len(self.dropped)} dropped ({'; '.join(self.dropped)})")
        return f"hand edits: {', '.join(parts)}" if parts else ""


def locked_frames(frames: np.ndarray, lock: tuple[int, int] | None) -> np.ndarray:
    """Which of ``frames`` lie in the ``lock`` range (first, last; None: none)."""
    frames = np.asarray(frames)
    if lock is None:
        return np.zeros(len(frames), dtype=bool)
    return (frames >= lock[0]) & (frames <= lock[1])


def carry(take: Take, edits: list[Edit], timing: Timing, first: int, fps: float, names: list[str],
          values: np.ndarray, lock: tuple[int, int] | None = None) -> Carried:
    """Lay ``edits`` (found on ``take``) on a new run's curves: ``values``
    (frames, ``names``) from frame ``first`` at ``fps``, its line's words
    and phones ``timing``.

    Each edit's frames go through the line's time (from the take's first
    frame) and the :class:`Warp` to the new line's frames, stretched as the
    sounds under it are; its largest change lands on a whole frame, so a
    one-frame edit keeps its size.  Offsets add to the new curve;
    replacements are the values there.  An edit is dropped when the word
    its weight sits on is not in the new line, when the new run does not
    key its channel, or when it lands outside the new line.  Frames in
    ``lock`` are the animator's: no edit is laid there, and an edit
    entirely inside them stays as it is (counted as locked)."""
    warp = Warp(take.timing, timing)
    out = np.array(values, dtype=np.float64, copy=True)
    n = len(out)
    col = {name: j for j, name in enumerate(names)}
    result = Carried(out)
    later = []
    for e in edits:
        old = e.frames
        if locked_frames(old, lock).all():
            result.locked += 1
            continue
        where = f"{e.channel} at frame {e.peak}"
        t = (old - take.first) / take.fps
        weight = np.abs(e.values)
        centre = float((weight * t).sum() / weight.sum()) if weight.sum() > 0 else float(t.mean())
        word = warp.gone(centre)
        if word is not None:
            result.dropped.append(f"{where}: on {word!r}, which the new line does not say")
            continue
        if e.channel not in col:
            result.dropped.append(f"{where}: this run does not key {e.channel}")
            continue
        pos = first + warp(t) * fps
        k = int(np.argmax(weight))
        pos = pos + (round(pos[k]) - pos[k])
        if len(pos) == 1:
            frames, vals = np.array([int(round(pos[0]))]), e.values
        else:
            frames = np.arange(math.ceil(pos[0] - 1e-6), math.floor(pos[-1] + 1e-6) + 1)
            vals = np.interp(frames, pos, e.values)
        use = (frames >= first) & (frames < first + n) & ~locked_frames(frames, lock)
        if not use.any():
            why = "in the locked frames" if locked_frames(frames, lock).any() else "outside the new line"
            result.dropped.append(f"{where}: it would land {why}")
            continue
        rows, vals = frames[use] - first, vals[use]
        if e.replace:
            later.append((col[e.channel], rows, vals))
            result.held.setdefault(e.channel, []).append((int(rows[0]), int(rows[-1])))
        else:
            out[rows, col[e.channel]] += vals
        if len(frames) == len(old) and frames[0] == old[0]:
            result.kept += 1
        else:
            result.moved += 1
    for j, rows, vals in later:
        out[rows, j] = vals
    return result


def remembered(fresh: np.ndarray, final: np.ndarray, drawn: np.ndarray, first: int, names: list[str],
               lock: tuple[int, int] | None = None, old: Take | None = None) -> np.ndarray:
    """What a run keeps as its curves for the next (:attr:`Take.values`):
    the curves as drawn after keying, the edits it laid (``final`` minus
    ``fresh``) taken off, so that they are found again next time, and no
    more (a curve keyed within a tolerance differs from its values by the
    reduction, which is no edit).  On the ``lock`` frames the run wrote
    nothing: the previous run's copy stands there (``old``, frame for frame)
    where it had one, else the curve as it is."""
    out = np.asarray(drawn, dtype=np.float64) - (np.asarray(final) - np.asarray(fresh))
    frames = first + np.arange(len(out))
    mask = locked_frames(frames, lock)
    if mask.any():
        out[mask] = np.asarray(drawn)[mask]
        if old is not None:
            col = {n: j for j, n in enumerate(old.names)}
            rows = frames[mask] - old.first
            inside = (rows >= 0) & (rows < len(old.values))
            for j, name in enumerate(names):
                if name in col:
                    out[np.flatnonzero(mask)[inside], j] = old.values[rows[inside], col[name]]
    return out


__all__ = ["Carried", "DISCARD", "Edit", "KEEP", "MODES", "THRESHOLD", "Take", "Timing", "Warp", "carry", "find",
           "locked_frames", "remembered"]
