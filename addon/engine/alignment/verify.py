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

from collections.abc import Collection, Sequence

import numpy as np

from ..audio import Audio
from .decoding import _decoder
from .fillers import base_token
from .model import FRAME, AlignedPhone, AlignedWord, AlignSettings, Alignment, at_shortest, median_fit
from .recognize import recognize_spans
from .speech import covered_by, frame_levels, runs, speech_mask, syllable_peaks, voice_level

#: A word lying on less speech than this share of its frames is a suspect.
SUSPECT_SPEECH = 0.5
#: A word is heard when at least this share of its phones is matched.
HEARD = 0.5
#: A checked run this close to the transcript's end, in words, reaches it.
EDGE = 3
#: Words fit their sound poorly when at least this much worse (per frame) than the line's median
#: word.  Appended words nobody says, aligned on noise or on the end of the last word said, fit
#: 28-92 worse (bench/false_alarms.py, appended to the MFA lines); the last words of a fast or
#: hoarse line said as written at most 16 worse.
POOR_FIT = 25.0
#: Words left unspoken hold at least this many phones in all (a shorter run is too little evidence).
MIN_PHONES = 3
#: Speech (s) left uncovered by the spoken words that is recognised.
MIN_UNSCRIPTED = 0.4
#: Runs of uncovered speech closer than this (s) are one stretch.
JOIN_GAP = 0.5
#: A stretch of unscripted speech holds at least this many words heard, and phones.
MIN_HEARD_WORDS = 2
MIN_HEARD_PHONES = 5
#: Speech within this much of a spoken word is that word's (s).
WORD_MARGIN = 0.15
#: Unscripted speech holds at least this much (s) within VOICED_DB (dB) of the line's voice.
MIN_VOICED, VOICED_DB = 0.15, 20.0
#: A word heard at most this long (s), running up to the end of a stretch where a spoken word
#: follows and beginning with that word's first phone (or from the start of a stretch after a
#: spoken word, ending with its last phone), is the edge of the spoken word the aligner placed a
#: little late (early): "maw" heard before "montreal" placed 60 ms late on a creaky voice (0.10 s).
EDGE_WORD = 0.2
#: Words are heard only in a stretch whose speech band rises and falls at least MIN_HEARD_WORDS
#: times (:func:`.speech.syllable_peaks`: peaks SYLLABLE_DB above the dips beside them, within
#: VOICED_DB of the voice; a syllable cut off by the stretch's end counts where it is within
#: CUT_SYLLABLE_DB of the voice); others are not recognised.  Of the 306 stretches the checks
#: recognised in bench/offscript.py and bench/false_alarms.py, all 149 in which words were heard
#: have two such peaks, the second standing 4.75 dB or more (3.5 with every cut syllable left
#: out); 110 of the 157 others have fewer (a breath, a hum, a held vowel, the tail of a word) and
#: are not recognised.
SYLLABLE_DB, CUT_SYLLABLE_DB = 2.0, 6.0


def _speech_share(mask: np.ndarray, w: AlignedWord) -> float:
    a, b = int(round(w.start / FRAME)), max(int(round(w.start / FRAME)) + 1, int(round(w.end / FRAME)))
    part = mask[a:b]
    return float(part.mean()) if len(part) else 0.0


def _squeezed(w: AlignedWord) -> bool:
    """Whether every phone of ``w`` has the decoder's shortest length."""
    return len(w.phones) >= 2 and at_shortest(w.end - w.start, len(w.phones))


def _poor(words: Sequence[AlignedWord], block: Sequence[int]) -> bool:
    """Whether the words ``block`` fit their sound :data:`POOR_FIT` worse than
    the line's other words (the fit of each frame, over the block), or were
    placed by estimate."""
    if any(words[k].estimated for k in block):
        return True
    line = median_fit(words, set(block))
    frames = [(words[k].fit, max(1.0, (words[k].end - words[k].start) / FRAME)) for k in block]
    if line is None or any(f is None for f, _ in frames):
        return False
    return sum(f * n for f, n in frames) / sum(n for _, n in frames) <= line - POOR_FIT


def _suspect_runs(words: list[AlignedWord], mask: np.ndarray) -> list[tuple[int, int]]:
    """[first, end) word indices of the run of suspect words at the
    transcript's end to check (none, or one).  Suspects are the words placed
    by estimate, those lying mostly off the speech and those that fit their
    sound poorly (:func:`_poor`).  A run within :data:`EDGE` words of the end
    reaches it: appended words may be placed on noise that passes for
    speech, between the suspects; and it takes in the words squeezed against
    it (each phone as short as the decoder makes one), which the aligner
    puts on the last sound of the last word said."""
    n = len(words)
    suspect = np.array([w.estimated or _speech_share(mask, w) < SUSPECT_SPEECH or _poor(words, [k])
                        for k, w in enumerate(words)])
    ends = [(i, j) for i, j in runs(suspect).tolist() if n - j <= EDGE]
    if not ends:
        return []
    i = ends[0][0]
    while i > 0 and _squeezed(words[i - 1]):
        i -= 1      # a word squeezed against the run at the end: the first of the appended words
    return [(i, n)]


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


def dropped(snd: Audio, words: list[AlignedWord], a: int, b: int, settings: AlignSettings) -> set[int]:
    """The words ``a``..``b - 1`` of ``words`` that a word pass over their
    stretch leaves out when each of them may be left out: the audio holds
    no speech that fits them better than silence or noise.  The words
    beside the run (one on either side) are kept, and anchor the pass;
    the stretch runs from the start of the word before to the end of the
    word after (or the clip's start or end).  A pass that finds no path
    leaves none out."""
    lo, hi = max(0, a - 1), min(len(words), b + 1)
    t0 = words[lo].start if lo < a else 0.0
    t1 = words[hi - 1].end if hi > b else snd.duration
    prons = [words[k].phones or ["AH"] for k in range(lo, hi)]
    body = " ".join(f"w{k}" if k < a or k >= b else f"[ w{k} ]" for k in range(lo, hi))
    try:
        decoder = _decoder(prons, lo, settings)
        decoder.add_jsgf_string("optional", f"#JSGF V1.0;\ngrammar optional;\npublic <s> = {body};\n")
        decoder.activate_search("optional")
        decoder.start_utt()
        decoder.process_raw(snd.pcm16(t0, t1), full_utt=True)
        decoder.end_utt()
        segs = decoder.seg()
    except RuntimeError:
        return set()
    if segs is None:
        return set()
    found = {base_token(sg.word) for sg in segs}
    if any(f"w{k}" not in found for k in range(lo, hi) if k < a or k >= b):
        return set()
    return {k for k in range(a, b) if f"w{k}" not in found}


def _unspoken(snd: Audio, al: Alignment, mask: np.ndarray, settings: AlignSettings) -> list[int]:
    """The words of ``al`` the audio does not hold: the last words of the
    transcript, in a suspect run (:func:`_suspect_runs`), that a word pass
    leaves out when it may (:func:`dropped`), of whose phones under
    :data:`HEARD` are heard where they would be, that lie mostly off the
    speech (:data:`SUSPECT_SPEECH`: the aligner found no speech for them)
    and that fit their sound poorly (:func:`_poor`), at least
    :data:`MIN_PHONES` phones in all."""
    words = al.words
    n = len(words)

    def absent(block: Sequence[int]) -> bool:
        """Enough phones, mostly off the speech, fitting poorly: the cheap evidence, weighed first.
        Words placed by estimate (the aligner found no place for them) lie where the estimate put
        them, which says nothing: the speech under the block's other words is weighed."""
        placed = [k for k in block if not words[k].estimated]
        frames = np.concatenate([np.zeros(0, bool)] + [mask[int(round(words[k].start / FRAME)):
                                                            max(int(round(words[k].start / FRAME)) + 1,
                                                                int(round(words[k].end / FRAME)))]
                                                       for k in placed])
        return (sum(len(words[k].phones) for k in block) >= MIN_PHONES
                and (float(frames.mean()) if len(frames) else 0.0) < SUSPECT_SPEECH and _poor(words, block))

    for a, b in _suspect_runs(words, mask):
        if not any(absent(range(k, n)) for k in range(a, n)):
            continue
        gone = dropped(snd, words, a, b, settings)
        if n - 1 not in gone:
            continue
        t0 = words[a - 1].end if a > 0 else 0.0
        t1 = snd.duration
        fa, fb = int(t0 / FRAME), int(np.ceil(t1 / FRAME))
        heard: list[str] = []
        if t1 - t0 >= 0.05 and mask[fa:fb].any():
            found, _ = recognize_spans(snd, [(t0, t1)], settings, check=True)
            heard = [p for w in found for p in w.phones]
        run_phones = [p for w in words[a:b] for p in w.phones]
        hit = _matched(run_phones, heard)
        unheard, k = set(), 0
        for wi in range(a, b):
            m = len(words[wi].phones)
            if wi in gone and (not m or hit[k:k + m].mean() < HEARD):
                unheard.add(wi)
            k += m
        block = []
        for wi in range(n - 1, a - 1, -1):      # the words left out and not heard, back from the end
            if wi not in unheard:
                break
            block.insert(0, wi)
        if block and absent(block):
            return block
    return []


def _unscripted(snd: Audio, al: Alignment, mask: np.ndarray, settings: AlignSettings,
                left_out: Sequence[tuple[float, float]] = (), directions: Collection[int] = ()
                ) -> list[tuple[float, float]]:
    """Stretches of speech no spoken word lies on, as (start, end) s; runs
    of such speech less than :data:`JOIN_GAP` apart and between the same two
    words are one stretch (recognised together, in context).  A stretch
    holds at least :data:`MIN_UNSCRIPTED` s of speech, :data:`MIN_VOICED` s of
    it within :data:`VOICED_DB` of the line's voice (:func:`.speech.voice_level` on its spoken words): a
    breath, a lip smack, the decay of the last word or room noise is
    quieter, and so is a low rumble or thump in the speech band (the
    levels are :func:`.speech.frame_levels` with ``emphasis``).  Stretches
    between two words where the transcript has a stage direction
    (``directions``: gaps, :func:`..language.stage_direction_gaps`)
    are the sound it stands for.  The stretches ``left_out`` (speech known to
    be cut from the transcript) are uncovered up to the words beside them,
    without :data:`WORD_MARGIN`."""
    covered = covered_by(al.words, len(mask), WORD_MARGIN)
    for start, end in left_out:
        covered[int(round(start / FRAME)):int(round(end / FRAME))] = False
    joined: list[list[int]] = []
    for i, j in runs(mask & ~covered).tolist():
        if joined and (i - joined[-1][1]) * FRAME < JOIN_GAP and not covered[joined[-1][1]:i].any():
            joined[-1][1] = j
        else:
            joined.append([i, j])
    if not joined:
        return []
    # Loud in the speech band: a low rumble, a handling thump or a breath's pop as loud as the voice
    # is not speech (the sound before the first word of the MFA clip "acoustic_corpus").
    band = frame_levels(snd, emphasis=True)
    loud = band[:len(mask)] >= voice_level(band, covered_by(al.script, len(band))) - VOICED_DB
    script = al.script
    said = [k for k, w in enumerate(script) if w.spoken]
    spans = []
    for i, j in joined:
        if float(mask[i:j].sum()) * FRAME < MIN_UNSCRIPTED or float((mask[i:j] & loud[i:j]).sum()) * FRAME < MIN_VOICED:
            continue
        if directions:      # the gaps between the spoken words on either side
            before = sum(script[k].end <= i * FRAME + WORD_MARGIN for k in said)
            lo = said[before - 1] + 1 if before else 0
            hi = said[before] if before < len(said) else len(script)
            if any(lo <= g <= hi for g in directions):
                continue
        spans.append((i * FRAME, min(snd.duration, j * FRAME)))
    return spans


def _edges_of_spoken(found: list[AlignedWord], spans: Sequence[tuple[float, float]],
                     words: Sequence[AlignedWord]) -> set[int]:
    """Indices of the words ``found`` that are the edge of a spoken word of
    ``words`` beside their stretch of ``spans`` (:data:`EDGE_WORD`): the
    stretch ends :data:`WORD_MARGIN` before that word, so the part of it the
    aligner left outside is heard as a short word of its own."""
    spoken = [w for w in words if w.spoken and w.phones]
    touch = WORD_MARGIN + 1.5 * FRAME
    out = set()
    for k, w in enumerate(found):
        if w.end - w.start > EDGE_WORD or not w.phones:
            continue
        for t0, t1 in spans:
            if not t0 <= w.start < t1:
                continue
            if w.end >= t1 - FRAME and any(0 <= s.start - t1 <= touch and s.phones[0] == w.phones[0] for s in spoken):
                out.add(k)
            if w.start <= t0 + FRAME and any(0 <= t0 - s.end <= touch and s.phones[-1] == w.phones[-1] for s in spoken):
                out.add(k)
    return out


def _heard(found: list[AlignedWord], t0: float, t1: float) -> bool:
    """Whether words are heard in t0..t1 s among the recognised words
    ``found``: :data:`MIN_HEARD_WORDS` and :data:`MIN_HEARD_PHONES`.  A
    breath, a noise, a held vowel or the edge of a word the aligner placed
    a little off is heard as one short word at most."""
    inside = [w for w in found if t0 <= w.start < t1]
    return len(inside) >= MIN_HEARD_WORDS and sum(len(w.phones) for w in inside) >= MIN_HEARD_PHONES


def may_hold_words(snd: Audio, spans: Sequence[tuple[float, float]], mask: np.ndarray | None = None) -> list[bool]:
    """Whether each (start, end) s span of ``snd`` rises and falls as words
    do (:data:`SYLLABLE_DB`), the cheap evidence asked for before it is
    recognised.  ``mask``: the clip's speech mask, if known; the voice's
    level is the 90th percentile of the speech band's on it."""
    if not spans:
        return []
    band = frame_levels(snd, emphasis=True)
    if mask is None:
        mask, _ = speech_mask(frame_levels(snd), snd)
    voice = voice_level(band, mask)
    return [syllable_peaks(band[int(t0 / FRAME):int(np.ceil(t1 / FRAME))], voice - VOICED_DB, SYLLABLE_DB,
                           voice - CUT_SYLLABLE_DB, most=MIN_HEARD_WORDS) >= MIN_HEARD_WORDS
            for t0, t1 in spans]


def words_heard(snd: Audio, spans: list[tuple[float, float]], settings: AlignSettings) -> list[bool]:
    """Whether words are heard (:func:`_heard`) in each (start, end) s span of
    ``snd``; a span that does not rise and fall as words do
    (:func:`may_hold_words`) is not recognised."""
    worth = may_hold_words(snd, spans)
    listen = [span for span, ok in zip(spans, worth) if ok]
    found, _ = recognize_spans(snd, listen, settings, check=True, fewest=MIN_HEARD_WORDS) if listen else ([], [])
    return [_heard(found, t0, t1) for t0, t1 in spans]


def _plural(n: int, word: str) -> str:
    return f"{n} {word}{'s' if n != 1 else ''}"


def verify(snd: Audio, al: Alignment, settings: AlignSettings | None = None, english: bool = True,
           left_out: Sequence[tuple[float, float]] = (), directions: Collection[int] = ()) -> Alignment:
    """Mark the transcript's unspoken words and recognise the unscripted
    speech of ``al`` (aligned to ``snd``), in place; returns ``al``.
    ``left_out``: stretches known to hold speech cut from the transcript
    (:func:`.edges.left_out`), unscripted up to the words beside them;
    ``directions``: where the transcript has stage directions (:func:`_unscripted`).
    Uncovered speech in which no words are heard is a breath or a noise:
    the aligner's warning of speech the transcript's words do not cover
    gives way to this judgement.

    Recognition is English: in a line in another language (not ``english``)
    the unscripted speech is animated from the phones heard, and its words
    and text are left empty rather than given as English words."""
    settings = settings or AlignSettings()
    if not al.words:
        return al
    levels = frame_levels(snd)
    mask, _ = speech_mask(levels, snd)
    al.warnings = [w for w in al.warnings if "not covered by the transcript's words" not in w]
    al.notes = [n for n in al.notes if "not covered by the transcript's words" not in n]
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
    spans = _unscripted(snd, al, mask, settings, left_out, directions)
    spans = [span for span, ok in zip(spans, may_hold_words(snd, spans, mask)) if ok]
    found, phones = recognize_spans(snd, spans, settings, check=True, fewest=MIN_HEARD_WORDS) if spans else ([], [])
    edge = _edges_of_spoken(found, spans, al.words)
    heard = [w for k, w in enumerate(found) if k not in edge]
    spans = [(t0, t1) for t0, t1 in spans if _heard(heard, t0, t1)]
    keep = [k for k, w in enumerate(found) if k not in edge and any(t0 <= w.start < t1 for t0, t1 in spans)]
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
