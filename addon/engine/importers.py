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

import csv
import io
import json
import re
from pathlib import Path

from .align import AlignedPhone, AlignedWord, Alignment
from .errors import ImportFormatError, UnknownLabelError
from .phonemes import SILENCE, to_arpabet

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


def _check(path) -> Path:
    path = Path(path)
    if not path.is_file():
        raise ImportFormatError(f"alignment file not found: {path}")
    return path


# --- TextGrid ---------------------------------------------------------------

def parse_textgrid(text: str, source: str = "TextGrid") -> dict[str, list[tuple[float, float, str]]]:
    """Parse a TextGrid (long or short format) into {tier name: intervals}.
    Point tiers are skipped."""
    # Tokenise: quoted strings (with "" escapes), numbers, and bare flags.
    # Indices such as "item [1]:" are skipped; they are not values.
    tokens = re.findall(
        r'"((?:[^"]|"")*)"|(\[\d*\])|(-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?)|(<exists>|<absent>)', text)
    values: list[object] = []
    for s, index, num, flag in tokens:
        if index:
            continue
        if num:
            values.append(float(num))
        elif flag:
            values.append(flag)
        else:
            values.append(s.replace('""', '"'))
    if len(values) < 2 or values[0] != "ooTextFile" or values[1] != "TextGrid":
        raise ImportFormatError(f"{source}: not a Praat TextGrid (missing 'File type = \"ooTextFile\"' header)")
    pos = 2
    try:
        pos += 2  # xmin xmax
        if values[pos] == "<absent>":
            return {}
        pos += 1
        n_tiers = int(values[pos]); pos += 1
        tiers: dict[str, list[tuple[float, float, str]]] = {}
        for _ in range(n_tiers):
            kind, name = values[pos], values[pos + 1]
            pos += 4  # class, name, xmin, xmax
            count = int(values[pos]); pos += 1
            if kind == "IntervalTier":
                items = []
                for _ in range(count):
                    a, b, label = float(values[pos]), float(values[pos + 1]), str(values[pos + 2])
                    pos += 3
                    items.append((a, b, label))
                tiers[str(name)] = items
            else:
                pos += 2 * count
        return tiers
    except (IndexError, ValueError, TypeError):
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


def read_textgrid(path, phoneset: str = "auto") -> Alignment:
    path = _check(path)
    tiers = parse_textgrid(_read_text(path), str(path))
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
            raise UnknownLabelError(label, phoneset, f"{path.name} at {a:.3f} s") from exc
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

def read_rhubarb(path) -> Alignment:
    """Rhubarb Lip Sync cues, JSON (``mouthCues``) or TSV (``time<TAB>shape``)."""
    path = _check(path)
    text = _read_text(path)
    cues: list[tuple[float, float | None, str]] = []
    if text.lstrip().startswith("{"):
        try:
            doc = json.loads(text)
            for c in doc["mouthCues"]:
                cues.append((float(c["start"]), float(c["end"]), str(c["value"])))
            duration = float(doc.get("metadata", {}).get("duration") or (cues[-1][1] if cues else 0.0))
        except (KeyError, TypeError, ValueError, json.JSONDecodeError) as exc:
            raise ImportFormatError(f"{path}: not a Rhubarb JSON file ({exc})") from None
    else:
        for lineno, row in enumerate(csv.reader(io.StringIO(text), delimiter="\t"), 1):
            if not row or not "".join(row).strip():
                continue
            if len(row) < 2:
                raise ImportFormatError(f"{path}, line {lineno}: expected 'time<TAB>shape'")
            try:
                cues.append((float(row[0]), None, row[1].strip()))
            except ValueError:
                raise ImportFormatError(f"{path}, line {lineno}: {row[0]!r} is not a time") from None
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

def read_papagayo(path) -> Alignment:
    """A Papagayo-NG ``.pgo`` project: frame-numbered phonemes per word, in
    Preston Blair shapes or CMU phones; all voices are merged."""
    path = _check(path)
    lines = [l.strip() for l in _read_text(path).splitlines()]
    if not lines or not lines[0].lower().startswith("lipsync version"):
        raise ImportFormatError(f"{path}: not a Papagayo project (first line must be 'lipsync version 1')")
    try:
        fps = float(lines[2])
        n_frames = int(lines[3])
        n_voices = int(lines[4])
        pos = 5
        words: list[AlignedWord] = []
        raw: list[tuple[int, str, int]] = []  # (frame, label, word index)
        for _ in range(n_voices):
            pos += 2  # voice name, full text
            n_phrases = int(lines[pos]); pos += 1
            for _ in range(n_phrases):
                pos += 3  # phrase text, start, end
                n_words = int(lines[pos]); pos += 1
                for _ in range(n_words):
                    text, start, end, n_ph = lines[pos].split()[:4]
                    pos += 1
                    words.append(AlignedWord(text.lower(), int(start) / fps, (int(end) + 1) / fps, []))
                    for _ in range(int(n_ph)):
                        frame, label = lines[pos].split()[:2]
                        pos += 1
                        raw.append((int(frame), label, len(words) - 1))
    except (IndexError, ValueError):
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


def read_alignment(path, phoneset: str = "auto") -> Alignment:
    """Read any supported alignment file, chosen by its extension."""
    path = Path(path)
    ext = path.suffix.lower()
    if ext == ".textgrid":
        return read_textgrid(path, phoneset)
    if ext in {".json", ".tsv", ".txt"}:
        return read_rhubarb(path)
    if ext == ".pgo":
        return read_papagayo(path)
    raise ImportFormatError(
        f"{path}: unknown alignment format {ext or '(no extension)'}; "
        "use .TextGrid, Rhubarb .json/.tsv or Papagayo .pgo")
