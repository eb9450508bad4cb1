"""The script checked against the take, after alignment.

A forced alignment places every transcript word somewhere, said or not.
Words the actor never said end up squeezed into a pause (placed by estimate,
a few milliseconds each) or in the noise after the last real word; speech
the transcript leaves out (an ad-lib, a revised line) gets no word and the
mouth stays shut while the character talks.  :func:`verify` looks at the
acoustic evidence:

* **Unspoken words.**  The suspects are the words placed by estimate and the
  words lying mostly off the speech (by :func:`.speech.speech_mask`); a run
  of suspects at the end (or start) of the transcript takes in the words
  after (before) it.  The stretch such a run may have been said in (from the
  word before it to the word after it) is recognised (:mod:`.recognize`) and
  the run's phones are matched, in order, with the phones heard there.  A
  word with under half of its phones heard is unspoken: it stays in the
  words with ``spoken = False`` and no phones, at the end of the word
  before it, so the mouth rests over it; a note and a warning name it.
* **Unscripted speech.**  Stretches of speech that no spoken word lies on
  (at least :data:`MIN_UNSCRIPTED` s of it) are recognised; where words
  are heard (two or more), they are added (``recognized = True``) and the
  stretch is listed in :attr:`.Alignment.unscripted` with its text.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..audio import Audio
from .model import FRAME, AlignedPhone, AlignedWord, AlignSettings, Alignment, at_shortest
from .recognize import recognize_spans
from .speech import frame_levels, runs, speech_mask

#: A word lying on less speech than this share of its frames is a suspect.
SUSPECT_SPEECH = 0.5
#: A word is heard when at least this share of its phones is matched.
HEARD = 0.5
#: A checked run this close to the transcript's end (start), in words, reaches it.
EDGE = 3
#: Speech (s) left uncovered by the spoken words that is recognised.
MIN_UNSCRIPTED = 0.4
#: Runs of uncovered speech closer than this (s) are one stretch.
JOIN_GAP = 0.5
#: A stretch of unscripted speech holds at least this many words heard, and phones.
MIN_HEARD_WORDS = 2
MIN_HEARD_PHONES = 5
#: Speech within this much of a spoken word is that word's (s).
WORD_MARGIN = 0.15


def _speech_share(mask: np.ndarray, w: AlignedWord) -> float:
    a, b = int(round(w.start / FRAME)), max(int(round(w.start / FRAME)) + 1, int(round(w.end / FRAME)))
    part = mask[a:b]
    return float(part.mean()) if len(part) else 0.0


def _squeezed(w: AlignedWord) -> bool:
    """Whether every phone of ``w`` has the decoder's shortest length."""
    return len(w.phones) >= 2 and at_shortest(w.end - w.start, len(w.phones))


def _suspect_runs(words: list[AlignedWord], mask: np.ndarray) -> list[tuple[int, int]]:
    """[first, end) word indices of the runs of suspect words to check: runs
    holding a word placed by estimate, and runs at the transcript's end or
    start.  A run within :data:`EDGE` words of the end (start) reaches it:
    appended words may be placed on noise that passes for speech, between
    the suspects; and a run at the end takes in the words squeezed against
    it (each phone as short as the decoder makes one), which the aligner
    puts on the last sound of the last word said."""
    estimated = np.array([w.estimated for w in words])
    suspect = estimated | np.array([_speech_share(mask, w) < SUSPECT_SPEECH for w in words])
    n = len(words)
    out = []
    for i, j in runs(suspect).tolist():
        has_estimate = bool(estimated[i:j].any())
        if n - j <= EDGE:
            j = n
        if i <= EDGE:
            i = 0
        if has_estimate or i == 0 or j == n:
            while j == n and i > 0 and _squeezed(words[i - 1]):
                i -= 1      # a word squeezed against the run at the end: the first of the appended words
            if out and out[-1][1] >= i:
                i = out.pop()[0]
            out.append((i, j))
    return out


def edit_path(a: list, b: list, same=lambda x, y: x == y) -> list[tuple[int, int, bool]]:
    """The diagonal steps (i, j, ``same(a[i], b[j])``) of a minimum edit path
    between the sequences ``a`` and ``b`` (substitution, insertion and
    deletion each cost 1), in order."""
    n, m = len(a), len(b)
    cost = np.zeros((n + 1, m + 1))
    cost[:, 0] = np.arange(n + 1)
    cost[0, :] = np.arange(m + 1)
    for i in range(1, n + 1):
        for j in range(1, m + 1):
            sub = 0 if same(a[i - 1], b[j - 1]) else 1
            cost[i, j] = min(cost[i - 1, j] + 1, cost[i, j - 1] + 1, cost[i - 1, j - 1] + sub)
    steps = []
    i, j = n, m
    while i and j:
        sub = 0 if same(a[i - 1], b[j - 1]) else 1
        if cost[i, j] == cost[i - 1, j - 1] + sub:
            steps.append((i - 1, j - 1, sub == 0))
            i, j = i - 1, j - 1
        elif cost[i, j] == cost[i - 1, j] + 1:
            i -= 1
        else:
            j -= 1
    return steps[::-1]


def _matched(run_phones: list[str], heard: list[str]) -> np.ndarray:
    """Which of ``run_phones`` are matched, in order, by ``heard`` on a
    minimum edit path."""
    hit = np.zeros(len(run_phones), bool)
    for i, _j, same in edit_path(run_phones, heard):
        hit[i] = same
    return hit


def _unspoken(snd: Audio, al: Alignment, mask: np.ndarray, settings: AlignSettings) -> list[int]:
    words = al.words
    out: list[int] = []
    for a, b in _suspect_runs(words, mask):
        t0 = words[a - 1].end if a > 0 else 0.0
        t1 = words[b].start if b < len(words) else snd.duration
        fa, fb = int(t0 / FRAME), int(np.ceil(t1 / FRAME))
        heard: list[str] = []
        if t1 - t0 >= 0.05 and mask[fa:fb].any():
            found, _ = recognize_spans(snd, [(t0, t1)], settings)
            heard = [p for w in found for p in w.phones]
        run_phones = [p for w in words[a:b] for p in w.phones]
        hit = _matched(run_phones, heard)
        k = 0
        for wi in range(a, b):
            n = len(words[wi].phones)
            if n and hit[k:k + n].mean() < HEARD:
                out.append(wi)
            k += n
    return out


def _unscripted(snd: Audio, al: Alignment, mask: np.ndarray, settings: AlignSettings,
                left_out: Sequence[tuple[float, float]] = ()) -> list[tuple[float, float]]:
    """Stretches of speech no spoken word lies on, as (start, end) s; runs
    of such speech less than :data:`JOIN_GAP` apart and between the same two
    words are one stretch (recognised together, in context).  The stretches
    ``left_out`` (speech known to be cut from the transcript) are uncovered
    up to the words beside them, without :data:`WORD_MARGIN`."""
    covered = np.zeros(len(mask), bool)
    for w in al.words:
        if w.spoken:
            a = max(0, int((w.start - WORD_MARGIN) / FRAME))
            covered[a:int(np.ceil((w.end + WORD_MARGIN) / FRAME))] = True
    for start, end in left_out:
        covered[int(round(start / FRAME)):int(round(end / FRAME))] = False
    joined: list[list[int]] = []
    for i, j in runs(mask & ~covered).tolist():
        if joined and (i - joined[-1][1]) * FRAME < JOIN_GAP and not covered[joined[-1][1]:i].any():
            joined[-1][1] = j
        else:
            joined.append([i, j])
    spans = []
    for i, j in joined:
        if float(mask[i:j].sum()) * FRAME >= MIN_UNSCRIPTED:
            spans.append((i * FRAME, min(snd.duration, j * FRAME)))
    return spans


def _heard(found: list[AlignedWord], t0: float, t1: float) -> bool:
    """Whether words are heard in t0..t1 s among the recognised words
    ``found``: :data:`MIN_HEARD_WORDS` and :data:`MIN_HEARD_PHONES`.  A
    breath, a noise, a held vowel or the edge of a word the aligner placed
    a little off is heard as one short word at most."""
    inside = [w for w in found if t0 <= w.start < t1]
    return len(inside) >= MIN_HEARD_WORDS and sum(len(w.phones) for w in inside) >= MIN_HEARD_PHONES


def words_heard(snd: Audio, spans: list[tuple[float, float]], settings: AlignSettings) -> list[bool]:
    """Whether words are heard (:func:`_heard`) in each (start, end) s span of ``snd``."""
    found, _ = recognize_spans(snd, spans, settings) if spans else ([], [])
    return [_heard(found, t0, t1) for t0, t1 in spans]


def _plural(n: int, word: str) -> str:
    return f"{n} {word}{'s' if n != 1 else ''}"


def verify(snd: Audio, al: Alignment, settings: AlignSettings | None = None, english: bool = True,
           left_out: Sequence[tuple[float, float]] = ()) -> Alignment:
    """Mark the transcript's unspoken words and recognise the unscripted
    speech of ``al`` (aligned to ``snd``), in place; returns ``al``.
    ``left_out``: stretches known to hold speech cut from the transcript
    (:func:`.edges.left_out`), unscripted up to the words beside them.

    Recognition is English: in a line in another language (not ``english``)
    the unscripted speech is animated from the phones heard, and its words
    and text are left empty rather than given as English words."""
    settings = settings or AlignSettings()
    if not al.words:
        return al
    mask, _ = speech_mask(frame_levels(snd), snd)
    gone = set(_unspoken(snd, al, mask, settings))
    if gone:
        last_end = 0.0
        for wi, w in enumerate(al.words):
            if wi in gone:
                w.spoken = False
                w.start = w.end = last_end
                w.phones = []
            else:
                last_end = w.end
        al.phones = [p for p in al.phones if p.word_index not in gone]
        names = ", ".join(f"'{al.words[wi].text}'" for wi in sorted(gone))
        warning = (f"{_plural(len(gone), 'word')} of the transcript not heard in the audio, left unspoken "
                   f"(the mouth rests there): {names}")
        al.notes.insert(0, warning)
        al.warnings.insert(0, warning)
        # The warning that speech lacks transcript words is replaced by the unscripted stretches below.
    spans = _unscripted(snd, al, mask, settings, left_out)
    found, phones = recognize_spans(snd, spans, settings) if spans else ([], [])
    spans = [(t0, t1) for t0, t1 in spans if _heard(found, t0, t1)]
    keep = [k for k, w in enumerate(found) if any(t0 <= w.start < t1 for t0, t1 in spans)]
    renumber = {k: i for i, k in enumerate(keep)}
    found = [found[k] for k in keep]
    phones = [p for p in phones if p.word_index in renumber]
    for p in phones:
        p.word_index = renumber[p.word_index]
    if spans:
        if not english:
            for w in found:
                w.text = ""
        _merge(al, found, phones)
        for t0, t1 in spans:
            text = " ".join(w.text for w in found if t0 <= w.start < t1 and w.text)
            al.unscripted.append((t0, t1, text))
        seconds = sum(b - a for a, b in spans)
        al.warnings = [w for w in al.warnings if "not covered by the transcript's words" not in w]
        al.notes = [n for n in al.notes if "not covered by the transcript's words" not in n]
        stretches = f"{len(spans)} stretch{'es' if len(spans) != 1 else ''}"
        how = "recognition" if english else "the sounds the English recogniser heard (no words: it knows English only)"
        note = (f"{seconds:.1f} s of speech not in the transcript ({stretches}), animated from {how}: "
                + "; ".join(f"{a:.2f}-{b:.2f} s" + (f" '{t}'" if t else "") for a, b, t in al.unscripted))
        al.notes.append(note)
        al.warnings.append(note)
    return al


def _merge(al: Alignment, found: list[AlignedWord], phones: list[AlignedPhone]) -> None:
    """Insert recognised words and their phones among the alignment's, in time order."""
    if not found:
        return
    words = [(w.start, 0, k, w) for k, w in enumerate(al.words)] + [(w.start, 1, k, w) for k, w in enumerate(found)]
    order = sorted(words, key=lambda x: (x[0], x[1]))
    new_index = {}
    for ni, (_, src, k, _) in enumerate(order):
        new_index[(src, k)] = ni
    for p in al.phones:
        p.word_index = new_index[(0, p.word_index)]
    for p in phones:
        p.word_index = new_index[(1, p.word_index)]
    al.words = [w for _, _, _, w in order]
    al.phones = sorted(al.phones + phones, key=lambda p: p.word_index)  # stable: phones keep their order
