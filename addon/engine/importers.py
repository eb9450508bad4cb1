"""Alignments made by other tools, read into the engine's :class:`Alignment`.

* **Praat TextGrid**, long ("ooTextFile") and short text formats, UTF-8 or
  UTF-16: a phones tier (named ``phones``, ``phone``, ``phons``, ``segments``;
  else the tier with most intervals) and optionally a words tier (``words``,
  ``word``).  Labels may be ARPAbet (stress digits allowed, as Montreal Forced
  Aligner writes them), IPA or SAMPA; runs of ARPAbet such as ``PT`` are split.
* **Rhubarb Lip Sync** mouth cues, JSON (``rhubarb -f json``) or TSV.
* **Papagayo-NG** ``.pgo`` projects.

Mouth-shape cues (Rhubarb, Papagayo's Preston Blair shapes) carry no phones;
each shape is replaced by a representative phone that the viseme sets map back
to the same mouth shape, so coarticulation and weights apply as usual.  An
unknown label raises :class:`UnknownLabelError` naming it and where it is.
"""

from __future__ import annotations

import bisect
import csv
import io
import json
import math
import re
from pathlib import Path

from .alignment import AlignedPhone, AlignedWord, Alignment
from .errors import ImportFormatError, UnknownLabelError
from .language.phonemes import SILENCE, to_arpabet

#: Rhubarb's mouth shapes -> a phone with that mouth shape.
RHUBARB_PHONE = {"A": "M", "B": "K", "C": "EH", "D": "AA", "E": "AO", "F": "UW",
                 "G": "F", "H": "L", "X": SILENCE}

#: Papagayo / Preston Blair shapes -> a phone with that mouth shape.
PRESTON_BLAIR_PHONE = {"AI": "AA", "E": "IY", "O": "AO", "U": "UW", "WQ": "W",
                       "MBP": "M", "FV": "F", "L": "L", "ETC": "K", "REST": SILENCE,
                       "CDGKNRSTHYZ": "K", "CONS": "K"}


def _read_text(path: Path) -> str:
    raw = path.read_bytes()
    for bom, enc in ((b"\xff\xfe", "utf-16-le"), (b"\xfe\xff", "utf-16-be"), (b"\xef\xbb\xbf", "utf-8-sig")):
        if raw.startswith(bom):
            return raw[len(bom):].decode(enc)
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        return raw.decode("latin-1")


#: How far past the end of the audio an imported time may lie (s): rounding
#: and a last frame or a trailing silence interval may overshoot a little.
END_TOLERANCE = 0.5


class _Times:
    """Checks the times read from one alignment file, in file order: each a
    finite, non-negative number, no interval ending before it starts, starts
    never going back (within a tier), nothing past the end of the audio.
    Every message names the file and the line (or cue) and the time."""

    def __init__(self, path: Path, audio_duration: float | None):
        self.path = path
        self.limit = None if audio_duration is None else float(audio_duration) + END_TOLERANCE
        self.audio_duration = audio_duration
        self.last = -math.inf

    def restart(self) -> None:
        """A new tier or voice: its times start again from 0."""
        self.last = -math.inf

    def fail(self, where: str, problem: str):
        raise ImportFormatError(f"{self.path}, {where}: {problem}")

    def time(self, value, where: str, what: str = "time") -> float:
        try:
            t = float(value)
        except (TypeError, ValueError, OverflowError):
            self.fail(where, f"{what} {value!r} is not a number")
        if not math.isfinite(t):
            self.fail(where, f"{what} {value!r} is not a finite number")
        if t < 0:
            self.fail(where, f"{what} {t:g} s is negative")
        if self.limit is not None and t > self.limit:
            self.fail(where, f"{what} {t:g} s is past the end of the audio ({self.audio_duration:.3f} s)")
        return t

    def span(self, a, b, where: str, where_end: str | None = None) -> tuple[float, float]:
        a = self.time(a, where, "start")
        b = self.time(b, where_end or where, "end")
        if b < a:
            self.fail(where, f"ends ({b:g} s) before it starts ({a:g} s)")
        self.order(a, where)
        return a, b

    def order(self, a: float, where: str) -> None:
        if a < self.last - 1e-6:
            self.fail(where, f"time {a:g} s comes before the previous one ({self.last:g} s): "
                             "the entries are out of order")
        self.last = a


def _check(path) -> Path:
    path = Path(path)
    if not path.is_file():
        raise ImportFormatError(f"alignment file not found: {path}")
    return path


# --- TextGrid ---------------------------------------------------------------

def parse_textgrid(text: str, source: str = "TextGrid", audio_duration: float | None = None
                   ) -> dict[str, list[tuple[float, float, str]]]:
    """Parse a TextGrid (long or short format) into {tier name: intervals}.
    Point tiers are skipped.  Every time is checked (finite, not negative, in
    order within its tier, not past ``audio_duration`` if given); an error
    names the line."""
    # Tokenise: quoted strings (with "" escapes), numbers, and bare flags.
    # Indices such as "item [1]:" are skipped; they are not values.
    newlines = [m.start() for m in re.finditer("\n", text)]
    values: list[object] = []
    lines: list[int] = []  # the line each value is on
    for m in re.finditer(
            r'"((?:[^"]|"")*)"|(\[\d*\])|([-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?'
            r'|(?<![A-Za-z])[-+]?(?:inf(?:inity)?|nan)(?![A-Za-z]))|(<exists>|<absent>)', text, re.IGNORECASE):
        s, index, num, flag = m.groups()
        if index:
            continue
        if num:
            values.append(float(num))
        elif flag:
            values.append(flag)
        else:
            values.append(s.replace('""', '"'))
        lines.append(bisect.bisect_right(newlines, m.start()) + 1)
    times = _Times(Path(source), audio_duration)
    if len(values) < 2 or values[0] != "ooTextFile" or values[1] != "TextGrid":
        raise ImportFormatError(f"{source}: not a Praat TextGrid (missing 'File type = \"ooTextFile\"' header)")
    pos = 2
    try:
        pos += 2  # xmin xmax
        if values[pos] == "<absent>":
            return {}
        pos += 1
        n_tiers = int(values[pos])
        pos += 1
        tiers: dict[str, list[tuple[float, float, str]]] = {}
        if n_tiers < 0 or n_tiers > len(values):
            raise ValueError(n_tiers)
        for _ in range(n_tiers):
            kind, name = values[pos], values[pos + 1]
            pos += 4  # class, name, xmin, xmax
            count = int(values[pos])
            pos += 1
            if count < 0 or count > len(values):
                raise ValueError(count)
            if kind == "IntervalTier":
                items = []
                times.restart()
                for _ in range(count):
                    where = f"line {lines[pos]}"
                    if not isinstance(values[pos], float) or not isinstance(values[pos + 1], float):
                        raise ValueError(where)
                    a, b = times.span(values[pos], values[pos + 1], where, f"line {lines[pos + 1]}")
                    label = str(values[pos + 2])
                    pos += 3
                    items.append((a, b, label))
                tiers[str(name)] = items
            else:
                pos += 2 * count
        return tiers
    except (IndexError, ValueError, TypeError, OverflowError):
        raise ImportFormatError(f"{source}: the TextGrid is cut short or malformed") from None


_PHONE_TIERS = ("phones", "phone", "phons", "phonemes", "segments", "phoneme")
_WORD_TIERS = ("words", "word", "orthography")


def _pick(tiers, names):
    low = {k.lower(): k for k in tiers}
    for n in names:
        if n in low:
            return tiers[low[n]]
    for k, v in tiers.items():  # MFA with speakers: "speaker - phones"
        if any(k.lower().endswith(" - " + n) for n in names):
            return v
    return None


def read_textgrid(path, phoneset: str = "auto", audio_duration: float | None = None) -> Alignment:
    path = _check(path)
    tiers = parse_textgrid(_read_text(path), str(path), audio_duration)
    if not tiers:
        raise ImportFormatError(f"{path}: the TextGrid has no interval tiers")
    phone_tier = _pick(tiers, _PHONE_TIERS)
    word_tier = _pick(tiers, _WORD_TIERS)
    if phone_tier is None:
        phone_tier = max(tiers.values(), key=len)
        if phone_tier is word_tier:
            raise ImportFormatError(f"{path}: no phones tier (tiers: {', '.join(tiers)})")
    duration = max(b for tier in tiers.values() for _, b, _ in tier) if tiers else 0.0
    words: list[AlignedWord] = []
    if word_tier:
        for a, b, label in word_tier:
            if label.strip() and label.strip().lower() not in {"<eps>", "sil", "sp", "<sil>"}:
                words.append(AlignedWord(label.strip().lower(), a, b, []))
    phones: list[AlignedPhone] = []
    for a, b, label in phone_tier:
        try:
            arpa = to_arpabet(label, phoneset)
        except UnknownLabelError as exc:
            raise UnknownLabelError(label, phoneset, f"{path.name} at {a:.3f} s", exc.symbol) from None
        if arpa == [SILENCE]:
            continue
        step = (b - a) / len(arpa)
        for k, p in enumerate(arpa):
            phones.append(AlignedPhone(p, a + k * step, a + (k + 1) * step, -1))
    return _attach_words(phones, words, duration)


def _attach_words(phones: list[AlignedPhone], words: list[AlignedWord], duration: float) -> Alignment:
    if not words:
        # No word tier: each run of phones between silences counts as a word.
        run: list[AlignedPhone] = []
        for p in phones:
            if run and p.start - run[-1].end > 1e-4:
                words.append(AlignedWord("", run[0].start, run[-1].end, [q.phone for q in run]))
                run = []
            run.append(p)
        if run:
            words.append(AlignedWord("", run[0].start, run[-1].end, [q.phone for q in run]))
    wi = 0
    for p in phones:
        mid = (p.start + p.end) / 2
        while wi + 1 < len(words) and mid >= words[wi].end:
            wi += 1
        p.word_index = wi
    for w in words:
        w.phones = []
    for p in phones:
        if words:
            words[p.word_index].phones.append(p.phone)
    return Alignment(words, phones, duration)


# --- Rhubarb ----------------------------------------------------------------

def read_rhubarb(path, audio_duration: float | None = None) -> Alignment:
    """Rhubarb Lip Sync cues, JSON (``mouthCues``) or TSV (``time<TAB>shape``).
    Every time is checked (finite, not negative, in order, not past
    ``audio_duration`` if given); an error names the cue or line."""
    path = _check(path)
    text = _read_text(path)
    times = _Times(path, audio_duration)
    cues: list[tuple[float, float | None, str]] = []
    if text.lstrip().startswith("{"):
        try:
            doc = json.loads(text)
            mouth = doc["mouthCues"]
            if not isinstance(mouth, list):
                raise TypeError("'mouthCues' is not a list")
            for k, c in enumerate(mouth, 1):
                a, b = times.span(c["start"], c["end"], f"cue {k}")
                cues.append((a, b, str(c["value"])))
            meta = doc.get("metadata") or {}
            if not isinstance(meta, dict):
                raise TypeError("'metadata' is not an object")
            duration = (times.time(meta["duration"], "metadata", "duration") if meta.get("duration")
                        else (cues[-1][1] if cues else 0.0))
        except (KeyError, TypeError, ValueError, AttributeError, json.JSONDecodeError) as exc:
            raise ImportFormatError(f"{path}: not a Rhubarb JSON file ({exc})") from None
    else:
        for lineno, row in enumerate(csv.reader(io.StringIO(text), delimiter="\t"), 1):
            if not row or not "".join(row).strip():
                continue
            if len(row) < 2:
                raise ImportFormatError(f"{path}, line {lineno}: expected 'time<TAB>shape'")
            try:
                float(row[0])
            except ValueError:
                raise ImportFormatError(f"{path}, line {lineno}: {row[0]!r} is not a time") from None
            a = times.time(row[0], f"line {lineno}")
            times.order(a, f"line {lineno}")
            cues.append((a, None, row[1].strip()))
        cues = [(a, cues[k + 1][0] if k + 1 < len(cues) else a, v) for k, (a, _, v) in enumerate(cues)]
        duration = cues[-1][0] if cues else 0.0
    phones = []
    for a, b, shape in cues:
        if shape not in RHUBARB_PHONE:
            raise UnknownLabelError(shape, "rhubarb (A-H, X)", f"{path.name} at {a:.3f} s")
        p = RHUBARB_PHONE[shape]
        if p != SILENCE and b > a:
            phones.append(AlignedPhone(p, a, b, -1))
    return _attach_words(phones, [], duration)


# --- Papagayo ---------------------------------------------------------------

def read_papagayo(path, audio_duration: float | None = None) -> Alignment:
    """A Papagayo-NG ``.pgo`` project: frame-numbered phonemes per word, in
    Preston Blair shapes or CMU phones; all voices are merged.  The frame rate
    must be positive and every frame (as a time) not negative, in order within
    its word and not past ``audio_duration`` if given; an error names the line."""
    path = _check(path)
    lines = [ln.strip() for ln in _read_text(path).splitlines()]
    if not lines or not lines[0].lower().startswith("lipsync version"):
        raise ImportFormatError(f"{path}: not a Papagayo project (first line must be 'lipsync version 1')")
    times = _Times(path, audio_duration)
    try:
        try:
            fps = float(lines[2])
        except ValueError:
            times.fail("line 3", f"frame rate {lines[2]!r} is not a number")
        if not (math.isfinite(fps) and fps > 0):
            times.fail("line 3", f"frame rate {lines[2]!r} must be a positive number")
        n_frames = int(lines[3])
        if n_frames < 0:
            times.fail("line 4", f"frame count {n_frames} is negative")
        times.time(n_frames / fps, "line 4", f"project length ({n_frames} frames)")
        n_voices = int(lines[4])
        pos = 5
        words: list[AlignedWord] = []
        raw: list[tuple[int, str, int]] = []  # (frame, label, word index)
        for _ in range(n_voices):
            pos += 2  # voice name, full text
            n_phrases = int(lines[pos])
            pos += 1
            for _ in range(n_phrases):
                pos += 3  # phrase text, start, end
                n_words = int(lines[pos])
                pos += 1
                for _ in range(n_words):
                    text, start, end, n_ph = lines[pos].split()[:4]
                    where = f"line {pos + 1}"
                    pos += 1
                    times.restart()
                    a, b = times.span(int(start) / fps, int(end) / fps, f"{where} (word {text!r})")
                    words.append(AlignedWord(text.lower(), a, b + 1 / fps, []))
                    times.restart()
                    for _ in range(int(n_ph)):
                        frame, label = lines[pos].split()[:2]
                        where = f"line {pos + 1}"
                        pos += 1
                        times.order(times.time(int(frame) / fps, f"{where} (frame {frame})"), where)
                        raw.append((int(frame), label, len(words) - 1))
    except (IndexError, ValueError, OverflowError):
        raise ImportFormatError(f"{path}: the Papagayo project is cut short or malformed") from None
    phones: list[AlignedPhone] = []
    for k, (frame, label, wi) in enumerate(raw):
        nxt = raw[k + 1][0] if k + 1 < len(raw) and raw[k + 1][2] == wi else None
        end = nxt / fps if nxt is not None else words[wi].end
        key = label.upper()
        if key in PRESTON_BLAIR_PHONE:
            arpa = [PRESTON_BLAIR_PHONE[key]]
        else:
            arpa = to_arpabet(label, "arpabet") if label.upper() == label else None
            if arpa is None:
                raise UnknownLabelError(label, "papagayo", f"{path.name} frame {frame}")
        if arpa[0] == SILENCE:
            continue
        phones.append(AlignedPhone(arpa[0], frame / fps, max(end, frame / fps + 1 / fps), wi))
    for p in phones:
        words[p.word_index].phones.append(p.phone)
    duration = max(n_frames / fps, words[-1].end if words else 0.0)
    return Alignment(words, phones, duration)


def read_alignment(path, phoneset: str = "auto", audio_duration: float | None = None) -> Alignment:
    """Read any supported alignment file, chosen by its extension.  With
    ``audio_duration`` (s), a time past the end of the audio (by more than
    :data:`END_TOLERANCE`) is an error naming the file and line."""
    path = Path(path)
    ext = path.suffix.lower()
    if ext == ".textgrid":
        return read_textgrid(path, phoneset, audio_duration)
    if ext in {".json", ".tsv", ".txt"}:
        return read_rhubarb(path, audio_duration)
    if ext == ".pgo":
        return read_papagayo(path, audio_duration)
    raise ImportFormatError(
        f"{path}: unknown alignment format {ext or '(no extension)'}; "
        "use .TextGrid, Rhubarb .json/.tsv or Papagayo .pgo")
