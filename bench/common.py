"""Shared helpers for the benchmarks: where the real recordings are."""

from __future__ import annotations

import os
import sys
import wave
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
DATA = Path(os.environ.get("LIPSYNC_DATA", ROOT.parent / "shared" / "data"))
sys.path.insert(0, str(ROOT))


#: A viseme at this weight or more shows the mouth open; the closure at EVENT_CLOSED or more, the lips shut.
EVENT_OPEN = 0.2
EVENT_CLOSED = 0.5


def events(r, ref):
    """The speech events an analysis ``r`` (rendered at 100 fps) shows, against
    reference phones ``ref`` ((set of phones, start s, end s), in any order):
    ``vowel`` a hit for every vowel with the mouth open (some viseme at
    :data:`EVENT_OPEN` or more) on at least half of its frames, ``pbm`` for
    every /p b m/ with the lips closed (closure :data:`EVENT_CLOSED` or more)
    on a frame within 30 ms of it, ``pause`` for every pause of 0.3 s or more
    between reference phones with the mouth at rest on at least half of it;
    ``vowel_frames`` and ``vowel_closed`` count the vowels' frames and those
    with the lips closed.  The event score of the benchmarks is the mean of
    ``hits``, all three together."""
    from types import SimpleNamespace

    from addon.engine.language.phonemes import VOWELS

    active = r.curves.max(axis=1) >= EVENT_OPEN
    closed = r.closure >= EVENT_CLOSED

    def frames(a, b):
        return np.flatnonzero((r.times >= a) & (r.times < b))

    out = SimpleNamespace(pbm=[], vowel=[], pause=[], vowel_frames=0, vowel_closed=0)
    for phones, a, b in ref:
        if phones & VOWELS:
            f = frames(a, b)
            if len(f):
                out.vowel.append(bool(active[f].mean() >= 0.5))
                out.vowel_frames += len(f)
                out.vowel_closed += int(closed[f].sum())
        elif phones & {"P", "B", "M"}:
            f = frames(a - 0.03, b + 0.03)
            out.pbm.append(bool(len(f)) and bool(closed[f].any()))
    ordered = sorted(ref, key=lambda x: x[1])
    for (_, _, end), (_, start, _) in zip(ordered[:-1], ordered[1:]):
        if start - end >= 0.3:
            f = frames(end, start)
            out.pause.append(bool(len(f)) and bool((~active[f]).mean() >= 0.5))
    out.hits = out.pbm + out.vowel + out.pause
    return out


def need_data() -> Path:
    """The shared recordings folder, or exit cleanly (status 0) when absent."""
    if not DATA.is_dir():
        print(f"skipped: {DATA} is not here (set LIPSYNC_DATA to the recordings folder)")
        raise SystemExit(0)
    return DATA


def transcript_clips() -> list[tuple[str, Path, str]]:
    """Every clip with a transcript: (name, audio path, transcript text)."""
    d = need_data()
    clips = []
    for wav, lab in (("praatio/bobby.wav", "Bobby ripped the ledger"),
                     ("praatio/mary.wav", "Mary rolled the barrel"),
                     ("praatio/damon_set_test.wav", "Damon fried the omelet")):
        clips.append((Path(wav).stem, d / wav, lab))
    for lab in sorted((d / "mfa").glob("*.lab")) + sorted((d / "common_voice").glob("*.lab")):
        audio = next(p for p in lab.parent.glob(lab.stem + ".*") if p.suffix in {".wav", ".flac", ".mp3"})
        clips.append((lab.stem, audio, lab.read_text(encoding="utf-8")))
    for line in (d / "voice_quality" / "transcripts.tsv").read_text(encoding="utf-8").splitlines()[1:]:
        name, text, _ = line.split("\t")
        clips.append((Path(name).stem, d / "voice_quality" / name, text))
    for txt in sorted((d / "librivox").glob("*.txt")):
        clips.append((txt.stem, txt.with_suffix(".mp3"), txt.read_text(encoding="utf-8")))
    return clips


def timed_clips() -> list[tuple[str, Path, str]]:
    """The clips the speed comparisons time: every clip with a transcript
    (:func:`transcript_clips`) and TIMIT's 61 sentences (``speaker/sentence``)."""
    clips = transcript_clips()
    for wav in sorted((DATA / "timit_nltk").glob("*/*.wav")):
        clips.append((f"{wav.parent.name}/{wav.stem}", wav, " ".join(wav.with_suffix(".txt").read_text().split()[2:])))
    return clips


def reference_phones() -> list[tuple[str, Path, str, Path, str]]:
    """Clips with reference phone tiers: (name, audio, transcript, TextGrid, phone set)."""
    d = need_data()
    return [
        ("bobby", d / "praatio/bobby.wav", "Bobby ripped the ledger", d / "praatio/bobby_phones.TextGrid", "arpabet"),
        ("mary", d / "praatio/mary.wav", "Mary rolled the barrel", d / "praatio/mary.TextGrid", "ipa"),
        ("damon", d / "praatio/damon_set_test.wav", "Damon fried the omelet",
         d / "praatio/damon_set_test.TextGrid", "sampa"),
        ("acoustic_corpus", d / "mfa/acoustic_corpus.wav", (d / "mfa/acoustic_corpus.lab").read_text(),
         d / "mfa/acoustic_corpus.TextGrid", "arpabet"),
        ("cold_corpus", d / "mfa/cold_corpus.wav", (d / "mfa/cold_corpus.lab").read_text(),
         d / "mfa/cold_corpus.TextGrid", "arpabet"),
    ]


def write_wav(path, samples, rate=16000):
    """16-bit mono WAV."""
    with wave.open(str(path), "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(rate)
        w.writeframes((np.clip(samples, -1, 1) * 32767).astype("<i2").tobytes())


def match(hyp: list, ref: list, same=lambda h, r: h == r) -> list[tuple[int, int]]:
    """Pairs (i, j) of phones that are ``same`` (default: equal) on a minimum
    edit path between the aligned phones ``hyp`` and the reference ``ref``."""
    from addon.engine.alignment.verify import edit_path

    return [(i, j) for i, j, equal in edit_path(hyp, ref, same) if equal]
