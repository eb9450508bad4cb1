"""Transcript normalisation: from a dialogue script to a list of spoken words.

Scripts are written for actors, not for aligners.  This module turns one into
the words that are actually heard:

* numbers, ordinals (``3rd``), years (``1999``), currency (``$5.50``) and
  percentages (``50%``) are spelled out; times (``10:30``) too;
* common abbreviations are expanded (``Mr.``, ``Dr.``, ``St.``, ``etc.``);
* curly quotes and apostrophes become straight ones, hyphenated words split;
* stage directions in ``[brackets]``, ``(parentheses)`` or ``*asterisks*`` are
  removed, since nobody says them;
* punctuation that marks a pause (``, ; : . ! ? —``) is kept as a pause hint on
  the word before it, which the aligner uses to split long audio;
* a pronunciation can be forced inline by writing ARPAbet in braces straight
  after a word, ``quokka{K W AA1 K AH0}``; a brace group on its own,
  ``{HH M}``, is a sound with no word (a hum, a breath);
* a word written between slashes is its pronunciation in IPA, ``/pɛs/``
  (read by :mod:`.ipa`; any language's IPA).

All that is for English, the default.  A transcript in another language
(:mod:`.languages`) keeps its words as written, numbers and symbols
included, for eSpeak NG to read in that language (:mod:`.espeak`; Japanese is cut into words and its kanji
read by :mod:`.japanese`); stage directions, pause punctuation (``。、，``
too), braces and slashes work as above.
"""

from __future__ import annotations

import re
import unicodedata
from dataclasses import dataclass

from . import ipa, numbers
from .languages import Language, resolve
from ..errors import TranscriptError

#: Pause strength of each punctuation mark, from 0 (none) to 1 (sentence end).
PAUSE_MARKS = {",": 0.4, ";": 0.6, ":": 0.6, "—": 0.6, "–": 0.5, "...": 0.8, "…": 0.8,
               ".": 1.0, "!": 1.0, "?": 1.0}

ABBREVIATIONS = {
    "mr": "mister", "mrs": "missus", "ms": "miz", "dr": "doctor", "prof": "professor",
    "sr": "senior", "jr": "junior", "st": "saint", "mt": "mount", "ave": "avenue",
    "vs": "versus", "etc": "et cetera", "capt": "captain", "gen": "general",
    "sgt": "sergeant", "lt": "lieutenant", "col": "colonel", "gov": "governor",
    "no": "number", "approx": "approximately", "dept": "department",
}
# Abbreviations only expanded when written with their full stop.
_NEEDS_DOT = {"no", "st", "gen", "col", "gov"}

CURRENCY = {"$": ("dollar", "dollars", "cent", "cents"),
            "£": ("pound", "pounds", "penny", "pence"),
            "€": ("euro", "euros", "cent", "cents"),
            "¥": ("yen", "yen", "sen", "sen")}

SYMBOLS = {"&": "and", "+": "plus", "=": "equals", "@": "at", "%": "percent", "#": "number"}

_QUOTES = str.maketrans({"\u2018": "'", "\u2019": "'", "\u02bc": "'", "\u201c": '"',
                         "\u201d": '"', "\u00ab": '"', "\u00bb": '"', "\u2032": "'",
                         "`": "'", "\u00a0": " "})

_STAGE = re.compile(r"\[[^\]]*\]|\((?![^)]*\{)[^)]*\)|\*[^*\n]+\*|<[^>\n]*>")
_ROMAN = re.compile(r"^(?=[MDCLXVI])M{0,3}(CM|CD|D?C{0,3})(XC|XL|L?X{0,3})(IX|IV|V?I{0,3})$")
_IPA = r"(?<![\w/])/[^/\s]+/(?![\w/])"
_TOKEN = re.compile(
    r"""
    (?P<ipa>(?<![\w/])/[^/\s]+/(?![\w/]))                    # /IPA/
  | (?P<forced>[A-Za-z'][\w'.-]*\{[^}]*\}|\{[^}]*\})          # word{PH ONES} or {PH ONES}
  | (?P<money>[$£€¥]\s?\d[\d,]*(?:\.\d+)?(?:\s?(?:k|m|bn|million|billion|thousand))?)
  | (?P<time>\d{1,2}:\d{2}(?:\s?[ap]\.?m\.?)?)
  | (?P<ordinal>\d+(?:st|nd|rd|th)\b)
  | (?P<percent>\d[\d,]*(?:\.\d+)?\s?%)
  | (?P<number>\d[\d,]*(?:\.\d+)?)
  | (?P<word>[A-Za-z\u00C0-\u024F](?:[A-Za-z\u00C0-\u024F']|\.(?=[A-Za-z]\.))*\.?|'[A-Za-z]+)
  | (?P<pause>\.\.\.|…|[,;:.!?—–])
  | (?P<symbol>[&+=@%#])
    """,
    re.VERBOSE,
)


@dataclass
class Word:
    """One spoken word of the transcript.

    ``text`` is what the pronunciation is looked up by (lower case, spelled
    out); ``source`` is the piece of the script it came from; ``phones`` is a
    forced pronunciation (ARPAbet, may carry stress digits) or ``None``;
    ``pause_after`` is the strength, 0 to 1, of the punctuation after it;
    ``ipa`` is the IPA the word was written in (``/pɛs/``), whose phones are
    ``phones``.
    """

    text: str
    source: str
    phones: list[str] | None = None
    pause_after: float = 0.0
    ipa: str | None = None


def plain_ipa(text: str) -> str:
    """IPA as :mod:`.ipa` reads it: ``'`` typed for the ejective mark ``ʼ``
    and ``:`` for the length mark ``ː``; superscript modifier letters it has
    no use for (``ˢ`` of a released stop, ``ˀ`` of glottalisation) dropped,
    as they change nothing the mouth shows."""
    text = text.replace("'", "ʼ").replace(":", "ː")
    return "".join(ch for ch in text
                   if ch in ipa.MODIFIERS or unicodedata.category(ch) not in ("Lm", "Sk"))


def ipa_word(tok: str) -> Word:
    """A word written in IPA between slashes; a symbol that is not IPA is a
    :class:`TranscriptError` naming it."""
    body = plain_ipa(tok[1:-1])
    try:
        phones = ipa.to_arpabet(body, word=True)
    except ipa.UnknownSymbol as exc:
        raise TranscriptError(f"{tok!r} is not IPA: {exc.symbol!r} (U+{ord(exc.symbol):04X}) is not an IPA "
                              "symbol; write a word's pronunciation between slashes in IPA, e.g. /pɛs/") from None
    return Word(tok, tok, phones, ipa=body)


def _money(token: str) -> list[str]:
    symbol = token[0]
    one, many, sub_one, sub_many = CURRENCY[symbol]
    body = token[1:].strip().replace(",", "")
    scale = ""
    m = re.match(r"([\d.]+)\s?(k|m|bn|million|billion|thousand)?$", body)
    if m is None:
        raise TranscriptError(f"cannot read the amount {token!r}")
    amount, scale = m.group(1), m.group(2) or ""
    scale_word = {"k": "thousand", "m": "million", "bn": "billion"}.get(scale, scale)
    if scale_word:
        return numbers.decimal(amount) + [scale_word, many]
    whole, _, frac = amount.partition(".")
    n = int(whole or 0)
    words = numbers.cardinal(n) + [one if n == 1 else many]
    if frac:
        cents = int((frac + "0")[:2])
        if cents:
            words += ["and"] + numbers.cardinal(cents) + [sub_one if cents == 1 else sub_many]
    return words


def _number(token: str, next_word: str | None) -> list[str]:
    token = token.replace(",", "")
    if "." in token:
        return numbers.decimal(token)
    n = int(token)
    if len(token) == 4 and 1100 <= n <= 2099 and next_word not in {"dollars", "people", "times"}:
        return numbers.year(n)
    if len(token) > 1 and token.startswith("0"):
        return numbers.digits(token)
    return numbers.cardinal(n)


def _time(token: str) -> list[str]:
    m = re.match(r"(\d{1,2}):(\d{2})\s?([ap])?", token)
    h, mins, ampm = int(m.group(1)), int(m.group(2)), m.group(3)
    words = numbers.cardinal(h)
    if mins == 0:
        words += [] if ampm else ["o'clock"]
    elif mins < 10:
        words += ["oh"] + numbers.cardinal(mins)
    else:
        words += numbers.cardinal(mins)
    if ampm:
        words += [ampm, "m"]  # read as letters: "a m", "p m"
    return words


def _strip_stage_directions(text: str) -> str:
    return _STAGE.sub(" ", text)


def stage_direction_gaps(text: str, language: str | Language | None = None) -> set[int]:
    """Where the transcript's stage directions (``[laughs]``, ``(sighs)``,
    ``*breathes*``) stand among its spoken words: ``k`` for one before the
    ``k``-th word of :func:`normalize` (the number of words: after the last).
    The sound they stand for is no speech of the script's, and no speech the
    script leaves out."""
    gaps = set()
    for m in _STAGE.finditer(text):
        try:
            gaps.add(len(normalize(text[:m.start()], language)))
        except TranscriptError:
            gaps.add(0)
    return gaps


def normalize(text: str, language: str | Language | None = None) -> list[Word]:
    """Turn a transcript into the list of words that are spoken, in
    ``language`` (a code or :class:`.languages.Language`; default English).

    Raises :class:`TranscriptError` if nothing speakable is left.
    """
    if text is None or not text.strip():
        raise TranscriptError("the transcript is empty")
    lang = resolve(language)
    if not lang.is_english:
        return _normalize_other(text, lang)
    text = text.translate(_QUOTES)
    lines = text.splitlines()
    # A line holding only a roman numeral is a heading (a sonnet's number).
    lines = [(" ".join(numbers.cardinal(_roman_value(ln.strip()))) + ".")
             if _ROMAN.match(ln.strip()) and len(ln.strip()) > 1 else ln for ln in lines]
    text = _strip_stage_directions("\n".join(lines))
    words: list[Word] = []
    tokens = list(_TOKEN.finditer(text))
    for i, m in enumerate(tokens):
        kind, tok = m.lastgroup, m.group()
        following = tokens[i + 1].group().lower() if i + 1 < len(tokens) else None
        if kind == "pause":
            if words:
                words[-1].pause_after = max(words[-1].pause_after, PAUSE_MARKS[tok])
            continue
        if kind == "ipa":
            words.append(ipa_word(tok))
            continue
        if kind == "forced":
            word, _, phones = tok.partition("{")
            phones = phones.rstrip("}").split()
            if not phones:
                raise TranscriptError(f"empty pronunciation in {tok!r}")
            words.append(Word(word.lower().strip("'") or "{" + " ".join(phones) + "}", tok,
                              [p.upper() for p in phones]))
            continue
        if kind == "money":
            spoken = _money(tok)
        elif kind == "time":
            spoken = _time(tok)
        elif kind == "ordinal":
            spoken = numbers.ordinal(int(tok[:-2]))
        elif kind == "percent":
            spoken = _number(tok.rstrip("% ").strip(), None) + ["percent"]
        elif kind == "number":
            spoken = _number(tok, following)
        elif kind == "symbol":
            spoken = [SYMBOLS[tok]]
        else:
            spoken, ends_sentence = _word(tok, following, tokens[i + 1] if i + 1 < len(tokens) else None)
            for s in spoken:
                words.append(Word(s, tok))
            if ends_sentence:
                words[-1].pause_after = 1.0
            continue
        for s in spoken:
            words.append(Word(s, tok))
    if not words:
        skipped = skipped_words(text)
        if skipped:
            raise TranscriptError("the transcript has no words the aligner can use: " + describe_skipped(skipped))
        raise TranscriptError("the transcript has no spoken words (only punctuation or stage directions)")
    return words


def _skip_reason(piece: str) -> str:
    for ch in piece:
        if unicodedata.category(ch).startswith("L") and not ("A" <= ch.upper() <= "Z" or "\u00c0" <= ch <= "\u024f"):
            script = unicodedata.name(ch, "UNKNOWN").split()[0].title()
            return f"not in the Latin alphabet: {'CJK' if script == 'Cjk' else script}"
    if any(unicodedata.category(ch) in ("So", "Sk", "Cs") or ord(ch) >= 0x1F000 for ch in piece):
        return "an emoji or symbol, not a word"
    return "characters the aligner cannot pronounce"


def skipped_words(text: str, language: str | Language | None = None) -> list[tuple[str, str]]:
    """The pieces of a transcript :func:`normalize` leaves out because they
    are not words it can pronounce (other scripts, emoji, stray symbols),
    each with the reason; punctuation and stage directions are not listed."""
    if not resolve(language).is_english:
        return _scan(text)[1]
    text = _strip_stage_directions(text.translate(_QUOTES))
    gaps, last = [], 0
    for m in _TOKEN.finditer(text):
        gaps.append(text[last:m.start()])
        last = m.end()
    gaps.append(text[last:])
    out = []
    for gap in gaps:
        for piece in gap.split():
            core = piece.strip("\"'()[]{}<>*_~`^|\\/")
            if any(unicodedata.category(ch)[0] in "LNS" for ch in core):
                out.append((core, _skip_reason(core)))
    return out


def describe_skipped(skipped: list[tuple[str, str]]) -> str:
    """``'😀' (an emoji or symbol, not a word), '你好' (not in the Latin alphabet: CJK)``."""
    shown = ", ".join(f"{piece!r} ({why})" for piece, why in skipped[:12])
    return shown + (f" and {len(skipped) - 12} more" if len(skipped) > 12 else "")


def _word(tok: str, following: str | None, next_match) -> tuple[list[str], bool]:
    """Expand one written word; returns its spoken words and whether a full
    stop that belonged to it also ends a sentence."""
    has_dot = tok.endswith(".")
    bare = tok.rstrip(".")
    low = bare.lower()
    if low in ABBREVIATIONS and (has_dot or low not in _NEEDS_DOT):
        expansion = ABBREVIATIONS[low]
        if low == "st" and not (following and following[:1].isalpha() and next_match is not None
                                and next_match.group()[:1].isupper()):
            expansion = "street"
        return expansion.split(), False
    if re.fullmatch(r"(?:[A-Za-z]\.){2,}", tok):  # U.S.A. -> u s a
        return [ch.lower() for ch in tok if ch.isalpha()], False
    parts = [p for p in re.split(r"[-.]", low) if p.strip("'")]
    parts = [p.strip("'") if p.count("'") and (p.startswith("'") and not p.startswith("'t")) else p
             for p in parts]
    return [p for p in parts if p], has_dot


# ---------------------------------------------------------------------------
# Other languages: words as written, for eSpeak NG

#: Pause strength of the punctuation of other scripts, besides :data:`PAUSE_MARKS`.
OTHER_PAUSE_MARKS = {**PAUSE_MARKS, "。": 1.0, "．": 1.0, "！": 1.0, "？": 1.0, "、": 0.4, "，": 0.4, "；": 0.6,
                     "：": 0.6, "·": 0.4, "؟": 1.0, "،": 0.4, "؛": 0.6, "।": 1.0, "॥": 1.0, "¿": 0.0, "¡": 0.0}
_OTHER_TOKEN = re.compile(
    r"""
    (?P<ipa>""" + _IPA + r""")
  | (?P<forced>\{[^}]*\})
  | (?P<number>[$£€¥]?\d+(?:[.,:]\d+)*(?:\s?[%€$£¥])?)
  | (?P<pause>\.\.\.|[""" + re.escape("".join(k for k in OTHER_PAUSE_MARKS if len(k) == 1)) + r"""])
    """,
    re.VERBOSE,
)


def _letter(ch: str) -> bool:
    return unicodedata.category(ch)[0] == "L"


def _in_word(ch: str) -> bool:
    return unicodedata.category(ch)[0] in "LMN"


def _scan(text: str, split=None) -> tuple[list[Word], list[tuple[str, str]]]:
    """Words of a transcript in another language, and the pieces left out.
    A word is a run of letters (with their combining marks, digits, and
    ``'`` or ``-`` between letters), as written: a run of Han characters or
    kana between punctuation is one word, unless ``split`` (a run -> its
    words) cuts it."""
    text = _strip_stage_directions(text.translate(_QUOTES))
    words: list[Word] = []
    skipped: list[tuple[str, str]] = []
    i, n = 0, len(text)
    while i < n:
        m = _OTHER_TOKEN.match(text, i)
        ch = text[i]
        if m:
            tok = m.group()
            if m.lastgroup == "pause":
                if words:
                    words[-1].pause_after = max(words[-1].pause_after, OTHER_PAUSE_MARKS.get(tok, 0.8))
            elif m.lastgroup == "ipa":
                words.append(ipa_word(tok))
            elif m.lastgroup == "forced":
                phones = tok[1:-1].split()
                if not phones:
                    raise TranscriptError(f"empty pronunciation in {tok!r}")
                words.append(Word(tok, tok, [p.upper() for p in phones]))
            else:
                words.append(Word(tok.strip(), tok))
            i = m.end()
            continue
        if _letter(ch):
            j = i + 1
            while j < n and (_in_word(text[j]) or (text[j] in "'-" and j + 1 < n and _letter(text[j + 1]))):
                j += 1
            tok = text[i:j]
            if j < n and text[j] == "{":      # word{PH ONES}
                end = text.find("}", j)
                if end > 0:
                    phones = text[j + 1:end].split()
                    if not phones:
                        raise TranscriptError(f"empty pronunciation in {text[i:end + 1]!r}")
                    words.append(Word(tok.lower(), text[i:end + 1], [p.upper() for p in phones]))
                    i = end + 1
                    continue
            words.extend(Word(piece.lower(), piece) for piece in (split(tok) if split else [tok]))
            i = j
            continue
        if not ch.isspace() and unicodedata.category(ch)[0] in "NS" and ch not in "{}/":
            j = i
            while j < n and not text[j].isspace():
                j += 1
            piece = text[i:j].strip("\"'()[]{}<>*_~`^|\\/")
            if piece:
                skipped.append((piece, "an emoji or symbol, not a word"))
            i = j
            continue
        i += 1
    return words, skipped


def _normalize_other(text: str, lang: Language) -> list[Word]:
    split = None
    if lang.code == "ja":
        from . import japanese

        split = japanese.words
    words, skipped = _scan(text, split)
    if not words:
        if skipped:
            raise TranscriptError("the transcript has no words the aligner can use: " + describe_skipped(skipped))
        raise TranscriptError("the transcript has no spoken words (only punctuation or stage directions)")
    return words


def _roman_value(s: str) -> int:
    values = {"I": 1, "V": 5, "X": 10, "L": 50, "C": 100, "D": 500, "M": 1000}
    total = 0
    for a, b in zip(s, s[1:] + " "):
        v = values[a]
        total += -v if b in values and values[b] > v else v
    return total


# ---------------------------------------------------------------------------
# Reading text files (transcripts) in whatever encoding they were saved

_BOMS = ((b"\xef\xbb\xbf", "utf-8-sig"), (b"\xff\xfe\x00\x00", "utf-32-le"), (b"\x00\x00\xfe\xff", "utf-32-be"),
         (b"\xff\xfe", "utf-16-le"), (b"\xfe\xff", "utf-16-be"))


def decode_text(raw: bytes, source: str = "text") -> tuple[str, list[str]]:
    """Bytes of a text file -> its text and notes.  UTF-8 (with or without a
    byte-order mark), UTF-16 or UTF-32 with one; else Windows-1252 (the
    common Windows "ANSI" encoding, a superset of Latin-1 for text), with a
    note saying so.  Binary data (NUL bytes) is an error naming ``source``."""
    for bom, enc in _BOMS:
        if raw.startswith(bom):
            try:
                return raw[len(bom):].decode(enc.replace("-sig", "")), []
            except UnicodeDecodeError as exc:
                raise TranscriptError(f"{source} starts with a {enc.upper()} byte-order mark but is not valid "
                                      f"{enc.upper()} (byte {exc.start + len(bom)}); save it as UTF-8") from None
    if b"\x00" in raw:
        raise TranscriptError(f"{source} is not a text file (it holds NUL bytes; UTF-16 without a byte-order "
                              "mark?); save it as UTF-8")
    try:
        return raw.decode("utf-8"), []
    except UnicodeDecodeError as exc:
        bad = exc.start
    try:
        text, enc = raw.decode("cp1252"), "Windows-1252 (cp1252)"
    except UnicodeDecodeError:
        text, enc = raw.decode("latin-1"), "Latin-1"
    return text, [f"{source} is not UTF-8 (byte {bad}); read it as {enc}: check its accented letters, "
                  "or save it as UTF-8"]


def read_text_file(path, what: str = "transcript") -> tuple[str, list[str]]:
    """A text file's text and notes (see :func:`decode_text`).  A missing
    file, a folder or an unreadable file is a :class:`TranscriptError`
    naming it."""
    import os

    path = os.fspath(path)
    if not os.path.exists(path):
        raise TranscriptError(f"{what} file not found: {path}")
    if os.path.isdir(path):
        raise TranscriptError(f"{what} path is a folder, not a file: {path}")
    try:
        with open(path, "rb") as fh:
            raw = fh.read()
    except OSError as exc:
        raise TranscriptError(f"cannot read {what} file {path}: {exc.strerror or exc}") from None
    return decode_text(raw, f"{what} file {path}")
