"""The aligner's settings and results: words and phonemes with their times."""

from __future__ import annotations

from dataclasses import dataclass, field

from ..language.phonemes import VOWELS


FRAME = 0.01  # pocketsphinx's frame period (100 frames per second)
#: The shortest a phone can be aligned: one frame for each of its HMM's 3 states.
SHORTEST_FRAMES = 3


def at_shortest(seconds: float, phones: int = 1) -> bool:
    """Whether ``phones`` phones lasting ``seconds`` in all each have the
    shortest length the decoder gives one (:data:`SHORTEST_FRAMES`)."""
    return seconds <= (SHORTEST_FRAMES * phones + 0.5) * FRAME

#: Typical duration of a phone, seconds, for estimates and for splitting.
TYPICAL_DURATION = {"vowel": 0.10, "diphthong": 0.14, "consonant": 0.07}


def typical_duration(phone: str) -> float:
    if phone in {"AW", "AY", "EY", "OW", "OY"}:
        return TYPICAL_DURATION["diphthong"]
    return TYPICAL_DURATION["vowel" if phone in VOWELS else "consonant"]


def word_frames(kind: str, payload) -> list[tuple[int, int]]:
    """(first frame, end frame) of every word of a decode: its ``payload``
    holds word frames ("words") or each word's phones ("phones")."""
    return payload if kind == "words" else [(ph[0][1], ph[-1][2]) for ph in payload]


class Variants(list):
    """A word's phones, with the other pronunciations (``variants``, lists of
    phones) the aligner may choose between by the sound
    (:mod:`..language.assimilation`), and the phones each of them shows
    (``shown``, where the aligner is given stand-ins)."""

    def __init__(self, phones, variants=(), shown=None):
        super().__init__(phones)
        self.variants = [list(v) for v in variants]
        self.shown = [list(v) for v in (shown if shown is not None else variants)]


def median_fit(words, leave=()) -> float | None:
    """The median fit (:attr:`AlignedWord.fit`) of the ``words`` aligned
    acoustically, but those at the indices ``leave``; None if none was.  A
    word is judged against the line's own median: a hoarse, fast or noisy
    take fits worse all through."""
    fits = sorted(w.fit for k, w in enumerate(words) if w.fit is not None and k not in leave)
    if not fits:
        return None
    m = len(fits) // 2
    return float(fits[m] if len(fits) % 2 else (fits[m - 1] + fits[m]) / 2)


@dataclass
class AlignSettings:
    """Knobs of the aligner.  The defaults were measured on real speech."""

    split_above: float = 10.0    # clips longer than this are aligned in pieces, two at once (both cores), s
    piece: float = 7.0           # length the pieces aim at, s (an even number of them)
    # Clips longer than this are aligned window by window (bounded memory), s;
    # a window holds at most ``window`` seconds of audio.
    stream_above: float = 90.0
    window: float = 20.0
    max_chunk: float = 12.0      # longest chunk of the fallback, s
    min_pause: float = 0.30      # shortest silence the audio may be cut at, s
    margin: float = 0.12         # silence kept around each chunk's speech, s
    beam: float = 1e-200
    pbeam: float = 1e-200
    wbeam: float = 1e-200
    # Chance of a pause between two words.  pocketsphinx's default (0.005)
    # suits dictation decoded with a language model; in dialogue, pauses,
    # breaths and hesitations between words are common.
    silprob: float = 0.1
    workers: int = 0             # processes; 0 = one per core
    # A decode that lets hesitations be filler sounds is kept only if its
    # words lie on at least this much more of the speech, s (see .fillers).
    filler_margin: float = 0.2


@dataclass
class AlignedWord:
    text: str
    start: float
    end: float
    phones: list[str]
    source: str = ""             # where the pronunciation came from
    estimated: bool = False
    #: False for a transcript word the audio does not hold (it has no phones; see :mod:`.verify`).
    spoken: bool = True
    #: True for a word recognised from the audio rather than read in a transcript (:mod:`.recognize`).
    recognized: bool = False
    #: How well the word's phones fit its sound: the acoustic score of its frames in the phone
    #: pass, each frame's against the best senone of that frame, per frame (0 at best, more
    #: negative the worse; a word said as written about -10 to -30, a word the audio does not
    #: hold far below).  None where the phones were not aligned acoustically.
    fit: float | None = None


@dataclass
class AlignedPhone:
    phone: str
    start: float
    end: float
    word_index: int
    estimated: bool = False


@dataclass
class Alignment:
    words: list[AlignedWord]
    phones: list[AlignedPhone]
    duration: float
    notes: list[str] = field(default_factory=list)
    #: Notes the user must see (words of the transcript left out, ...): also in ``notes``.
    warnings: list[str] = field(default_factory=list)
    #: Speech no transcript word lies on: (start, end, recognised text) (see :mod:`.verify`).
    unscripted: list[tuple[float, float, str]] = field(default_factory=list)

    @property
    def n_estimated(self) -> int:
        return sum(p.estimated for p in self.phones)

    @property
    def script(self) -> list[AlignedWord]:
        """The transcript's words, in order (spoken or not), without the words recognised."""
        return [w for w in self.words if not w.recognized]

    def script_phones(self) -> list[tuple[int, AlignedPhone]]:
        """(index in :attr:`script`, phone) for every phone of the transcript's words."""
        index = {wi: k for k, wi in enumerate(wi for wi, w in enumerate(self.words) if not w.recognized)}
        return [(index[p.word_index], p) for p in self.phones if p.word_index in index]
