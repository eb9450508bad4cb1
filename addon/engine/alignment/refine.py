"""Phone starts refined by the sound around them: a small boundary-correction model.

After the offsets of :mod:`.boundaries` (one per pair of phone classes), a
boundary still lies on the decoder's 10 ms grid, and how far it is from where
a listener hears the new phone depends on the sound itself: where the energy
of each frequency band rises or falls around it.  HMM aligners are commonly
corrected this way, by a model of the boundary's error trained on
hand-labelled speech (Stolcke et al. 2014).

:func:`refine_boundaries` predicts each boundary's error from

* the classes of the phones on either side (:func:`.boundaries.boundary_class`);
* the change of the level (dB) of five frequency bands (the file's
  ``bands``) over each of the file's ``steps`` either side (20 ms windows
  every 5 ms), at seven times from 30 ms before the boundary to 30 ms after;
* those changes again for each class of the phone after the boundary (the
  same rise means a vowel's start, a fricative's or a stop's release) and,
  where the file's ``by_class`` says so, for each class of the phone before it;

a linear model (ridge regression) whose weights are in
``data/boundary_model.json``, and moves the boundary by the error predicted,
at most ``max_shift`` s either way.  Every phone keeps ``min_phone`` s; a
boundary after a pause moves the phone's start alone; the start of /p b m/
(``leave``: where the lips close) stays.  Words placed by estimate,
recognised words, words not spoken and words that fit their sound poorly (a
word the actor did not say as written) are left as they are.  The model was
fitted on English read speech (the development speakers of TIMIT,
``bench/boundary_model.py``, which also prints its cross-validated figures
and refits it).  A line whose words are mostly read through eSpeak NG or IPA
(other languages, aligned by the English phones of the nearest mouth) takes
a model of the same form fitted on hand-labelled words of 37 languages
(VoxAngeles), acted emotional German (EmoDB) and those TIMIT speakers
(``data/boundary_model_other_languages.json``, :func:`model_for`;
``bench/boundary_model_ipa.py`` prints its figures with one language family
or one EmoDB actor left out, and refits it).

:func:`refine_alignment` is the transcript aligner's last step
(:func:`.transcript.align_audio`), on the alignment the checks of the take
have settled: they weigh the aligner's own phones, and keep doing so.
"""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..audio import Audio
from ..errors import LipSyncError
from .boundaries import boundary_class
from .model import Alignment, median_fit
from .verify import POOR_FIT

MODEL_FILE = Path(__file__).resolve().parent.parent / "data" / "boundary_model.json"
#: The model of lines whose words are read through eSpeak NG or IPA (other languages), the same
#: form fitted on hand-labelled words of 37 languages, acted German and TIMIT's development speakers.
OTHER_LANGUAGES_FILE = MODEL_FILE.with_name("boundary_model_other_languages.json")
#: Pronunciation sources of words aligned through stand-in phones (:class:`..language.Pronunciation`).
STAND_IN_SOURCES = ("ipa", "espeak")
#: The fields a model file must hold.
FIELDS = ("classes", "bands", "hop", "window", "step", "offsets", "max_shift", "min_phone", "weights")


@lru_cache(maxsize=4)
def _load(path: str, stamp: float) -> dict:      # ``stamp``: the file's mtime, so a changed file is read again
    try:
        with open(path, encoding="utf-8") as fh:
            doc = json.load(fh)
    except (OSError, ValueError) as exc:
        raise LipSyncError(f"{path}: the boundary model cannot be read ({exc})") from None
    missing = [f for f in FIELDS if f not in doc]
    if missing:
        raise LipSyncError(f"{path}: the boundary model lacks {', '.join(missing)}")
    doc = dict(doc)
    if "after" not in by_class(doc) or not set(by_class(doc)) <= {"after", "before"}:
        raise LipSyncError(f"{path}: the boundary model's by_class must hold \"after\" and may hold \"before\" "
                           f"(it holds {by_class(doc)})")
    doc["weights"] = np.asarray(doc["weights"], float)
    if doc["weights"].shape != (n_features(doc),):
        raise LipSyncError(f"{path}: the boundary model has {doc['weights'].size} weights where its "
                           f"classes, bands and offsets need {n_features(doc)}")
    return doc


def model(path: str | Path = MODEL_FILE) -> dict:
    """The boundary model at ``path`` (read again when the file changes)."""
    p = Path(path)
    try:
        stamp = p.stat().st_mtime
    except OSError:
        raise LipSyncError(f"{p}: the boundary model is missing") from None
    return _load(str(p), stamp)


def model_for(sources: list[str]) -> dict:
    """The model of a line whose words' pronunciations come from ``sources``
    (:attr:`..language.Pronunciation.source`): :data:`OTHER_LANGUAGES_FILE`
    where most of them are read through eSpeak NG or IPA, else the English
    one (:data:`MODEL_FILE`)."""
    other = sum(s in STAND_IN_SOURCES for s in sources)
    return model(OTHER_LANGUAGES_FILE if sources and 2 * other > len(sources) else MODEL_FILE)


def steps(doc: dict) -> list[float]:
    """The spans (s, either side of a frame) the model reads each band's change over: the file's
    ``steps``, or its one ``step``."""
    return [float(s) for s in doc.get("steps", [doc["step"]])]


def by_class(doc: dict) -> list[str]:
    """Which phone's class the changes are read for: ``after`` (the phone the boundary starts) and,
    if the file says so, ``before`` (the one it ends)."""
    return list(doc.get("by_class", ["after"]))


def n_features(doc: dict) -> int:
    c, a = len(doc["classes"]), len(doc["bands"]) * len(doc["offsets"]) * len(steps(doc))
    return 1 + 2 * c + a + len(by_class(doc)) * c * a


#: Frames transformed at a time: a long clip's samples and spectra are read a block at a time, never
#: held whole (2,000 frames of 5 ms hops are 10 s of audio).
BLOCK = 2000


def band_changes(audio: Audio, doc: dict) -> np.ndarray:
    """Per ``hop`` (frame k centred at k * hop s), the change (dB) of each
    band's level from each step (:func:`steps`) before to that step after:
    one column per band for the first step, then for the next."""
    rate, total = audio.rate, len(audio.samples)
    n, h = int(round(doc["window"] * rate)), int(round(doc["hop"] * rate))
    count = -(-(total + n // 2 + 1) // h)            # frames whose window starts within the clip (or its padding)
    freq = np.fft.rfftfreq(n, 1.0 / rate)
    # Each band's bins as a slice (summed, not multiplied by a band matrix: a matrix product spins
    # up the BLAS library's threads, which take the other core from a batch's second worker).
    bands = [(int(np.searchsorted(freq, lo)), int(np.searchsorted(freq, hi))) for lo, hi in doc["bands"]]
    window = np.hanning(n)
    levels = np.empty((count, len(doc["bands"])))
    for k0 in range(0, count, BLOCK):
        k1 = min(count, k0 + BLOCK)
        lo, hi = k0 * h - n // 2, (k1 - 1) * h + n - n // 2
        seg = np.zeros(hi - lo)
        a, b = max(0, lo), min(total, hi)
        if b > a:
            seg[a - lo:b - lo] = audio.samples[a:b]
        f = np.fft.rfft(np.lib.stride_tricks.sliding_window_view(seg, n)[::h] * window, axis=1)
        power = f.real ** 2 + f.imag ** 2
        levels[k0:k1] = 10 * np.log10(np.stack([power[:, i:j].sum(axis=1) for i, j in bands], 1) + 1e-4)
    out = []
    for step in steps(doc):
        s = int(round(step / doc["hop"]))
        change = np.zeros_like(levels)
        if len(levels) > 2 * s:
            change[s:-s] = levels[2 * s:] - levels[:-2 * s]
        out.append(change)
    return np.concatenate(out, axis=1)


def features(audio: Audio, phones: list[tuple[str, float, float]], doc: dict,
             change: np.ndarray | None = None) -> np.ndarray:
    """The model's features of the start of every phone of ``phones`` (in
    order; the phone before each is the one before it in the list), one row
    per phone; the first phone's row is zeros."""
    classes = list(doc["classes"])
    c = len(classes)
    change = band_changes(audio, doc) if change is None else change
    offsets = np.asarray(doc["offsets"], int)
    before = "before" in by_class(doc)
    rows = np.zeros((len(phones), n_features(doc)))
    for i in range(1, len(phones)):
        k = int(round(phones[i][1] / doc["hop"]))
        acoustic = change[np.clip(k + offsets, 0, len(change) - 1)].ravel() / 10.0
        onehot = np.zeros(2 * c)
        right, left = boundary_class(phones[i][0]), boundary_class(phones[i - 1][0])
        if right in classes:
            onehot[classes.index(right)] = 1.0
        if left in classes:
            onehot[c + classes.index(left)] = 1.0
        rows[i] = np.concatenate([[1.0], onehot, acoustic, np.outer(onehot[:c], acoustic).ravel()]
                                 + ([np.outer(onehot[c:], acoustic).ravel()] if before else []))
    return rows


def refine_boundaries(audio: Audio, result: list, left: list[bool], doc: dict | None = None) -> None:
    """Move the phone starts of ``result`` (per word, [(phone, start, end)])
    by the error the boundary model predicts, in place.  The words ``left``
    (placed by estimate, recognised) keep theirs."""
    doc = model() if doc is None else doc
    where = [(wi, k) for wi, ph in enumerate(result) if ph for k in range(len(ph))]
    if len(where) < 2:
        return
    flat = [result[wi][k] for wi, k in where]
    shift = np.clip(features(audio, flat, doc) @ doc["weights"], -doc["max_shift"], doc["max_shift"])
    keep = float(doc["min_phone"])
    leave = set(doc.get("leave", ()))
    for i in range(1, len(where)):
        wi, k = where[i]
        if left[wi] or shift[i] == 0.0 or flat[i][0] in leave:
            continue
        pw, pk = where[i - 1]
        prev = result[pw][pk]
        p, a, b = result[wi][k]
        joined = abs(prev[2] - a) < 1e-6
        if joined and left[pw]:
            continue            # the phone before keeps its end
        low = prev[1] + keep if joined else max(prev[2], prev[1] + keep)
        if low > b - keep:
            continue            # two phones too short to share (a line aligned on a slowed copy)
        t = min(max(a - float(shift[i]), low), b - keep)
        if (t - a) * -shift[i] <= 0:        # no room to move the way the model says
            continue
        result[wi][k] = (p, t, b)
        if joined:
            result[pw][pk] = (prev[0], prev[1], t)


def refine_alignment(audio: Audio, al: Alignment, doc: dict | None = None) -> None:
    """:func:`refine_boundaries` on the phones of ``al`` (aligned to
    ``audio``), in place; the words' times follow their phones."""
    result, phones, left = by_word(al)
    refine_boundaries(audio, result, left, doc)
    for k, w in enumerate(al.words):
        for p, (_, a, b) in zip(phones[k], result[k]):
            p.start, p.end = a, b
        if phones[k]:
            w.start, w.end = phones[k][0].start, phones[k][-1].end


def by_word(al: Alignment) -> tuple[list, list, list[bool]]:
    """The phones of ``al`` per word as :func:`refine_boundaries` takes them
    ([(phone, start, end)]), the phones themselves, and the words it leaves
    as they are: placed by estimate, recognised, not spoken, or fitting their
    sound :data:`.verify.POOR_FIT` worse than the line's median word (a word
    the actor did not say as written: the model's corrections assume the
    phones on either side of a boundary are the ones said, and would move the
    words beside a wrong word by its phones)."""
    result: list[list[tuple[str, float, float]]] = [[] for _ in al.words]
    phones: list[list] = [[] for _ in al.words]
    for p in al.phones:
        result[p.word_index].append((p.phone, p.start, p.end))
        phones[p.word_index].append(p)
    median = median_fit(al.words)
    left = [w.estimated or w.recognized or not w.spoken or any(p.estimated for p in phones[k])
            or (median is not None and w.fit is not None and median - w.fit >= POOR_FIT)
            for k, w in enumerate(al.words)]
    return result, phones, left
