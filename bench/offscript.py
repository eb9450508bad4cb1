"""Speech beyond the script, on the recordings in ../shared/data (skips when absent).

For every clip with reference phones (bench/common.py ``reference_phones``):

* **No transcript** beside **with it**: the event score, phone starts within
  40 ms of the reference, and wall time as a share of the audio's length.
  The event score is the share of the reference's speech events the mouth
  shows: every vowel (a hit when the mouth is open, some viseme at 0.2 or
  more, on at least half of its 10 ms frames), every /p b m/ (a hit when the
  lips close, closure 0.5 or more, on a frame within 30 ms of it), and every
  pause of 0.3 s or more between the reference's phones (a hit when the
  mouth is at rest, every viseme under 0.2, on at least half of it).  Phone
  starts are matched in order on a minimum edit path (bench/alignment_accuracy.py);
  the figure is the share of reference phones matched and within 40 ms.

On the two long MFA clips (26 s each, reference words):

* **Appended words**: seven words nobody says added to the transcript:
  how many come back ``spoken: false``, and the share of frames after the
  last spoken word (+0.2 s) where the mouth is at rest;
* **Cut words**: ten spoken words (the 10 after the first third; then after
  a sixth, half and two thirds) removed: the share of their reference speech
  inside ``unscripted`` spans, and of their reference vowel frames where the
  mouth is open;
* **Swapped word**: one word replaced by another (the middle word by
  "elephant"; then the words at 20, 35, 50, 65 and 80 % of the transcript by
  a long and a short wrong word): how far (ms) the start of the word before
  and after it moved against the matching transcript, and in how many of
  the ten both stayed within 40 ms.

On pairs of TIMIT sentences by one speaker (``timit_nltk``), joined:

* **Speech after the script** (an ad-lib, the next line left in the take):
  the first sentence's transcript alone: in how many pairs its words start
  and end within 0.1 s of where they do when the sentence is aligned alone,
  and the share of the second sentence's speech inside ``unscripted``;
* **Speech before the script** (a slate, an ad-lib before the line): the
  same with the second sentence's transcript;
* **A line cut from the middle** (three sentences in one take, the middle
  one cut from the transcript): the share of its hand-labelled speech inside
  ``unscripted`` and of its vowel frames where the mouth is open, and in
  how many takes the other two sentences' words stay within 0.1 s of where
  they are when aligned alone;
* **Swapped words** on TIMIT's 61 sentences: the middle word replaced by
  "elephant" and by "blue", how often its neighbours start within 40 ms of
  where they do with the sentence's own transcript;
* **Another line's transcript**: every sentence with its own transcript and
  with another's: how many are refused, warned, or aligned without a word.

    LIPSYNC_DATA=/work/shared/data .venv/bin/python bench/offscript.py
"""

from __future__ import annotations

import os
import resource
import time

import numpy as np

from common import DATA, EVENT_OPEN, events, match, reference_phones
from addon.engine import audio as audio_mod
from addon.engine.errors import LipSyncError
from addon.engine.importers import read_textgrid
from addon.engine.language.phonemes import VOWELS
from addon.engine.pipeline import analyze

APPENDED = "and then the purple elephant quietly danced"
CUT_AT = (1 / 3, 1 / 6, 1 / 2, 2 / 3)
SWAP_AT = (0.2, 0.35, 0.5, 0.65, 0.8)
WRONG = ("elephant", "blue")
OPEN = EVENT_OPEN


def _frames(r, a: float, b: float) -> np.ndarray:
    return np.flatnonzero((r.times >= a) & (r.times < b))


def event_score(r, ref) -> tuple[float, int]:
    """(share of events hit, events) of the reference ``ref`` (a TextGrid's
    phones): bench/common.py ``events``."""
    hits = events(r, [({p.phone}, p.start, p.end) for p in ref.phones]).hits
    return float(np.mean(hits)), len(hits)


def phone_starts(r, ref) -> float:
    al = r.alignment
    pairs = match([p.phone for p in al.phones], [p.phone for p in ref.phones])
    err = np.round(np.array([abs(al.phones[i].start - ref.phones[j].start) for i, j in pairs]), 4)
    return float(np.mean(err <= 0.04)) * len(pairs) / max(1, len(ref.phones))


def _cpu() -> float:
    """CPU seconds of this process and its finished workers."""
    return sum(resource.getrusage(who).ru_utime + resource.getrusage(who).ru_stime
               for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))


def no_transcript() -> None:
    from addon.engine.alignment.recognize import _decoder

    t0 = time.perf_counter()
    _decoder()      # the language model, loaded once per process (as a batch or Blender session does)
    loaded = time.perf_counter() - t0
    print("No transcript (recognised) beside the transcript (aligned); x rt: wall time per second of audio, "
          f"cpu: CPU seconds (all processes) per second of audio; load average {os.getloadavg()[0]:.1f} "
          f"on {os.cpu_count()} cores; the recogniser's models loaded first, once, in {loaded:.2f} s")
    print(f"{'clip':16s} {'events':>6s} {'score':>6s} {'scr+txt':>7s} {'<=40ms':>7s} {'+txt':>6s} "
          f"{'x rt':>6s} {'+txt':>6s} {'cpu':>6s} {'+txt':>6s}  recognised")
    rows = []
    for name, audio, text, grid, phoneset in reference_phones():
        ref = read_textgrid(grid, phoneset)
        snd = audio_mod.load(audio)
        t0, c0 = time.perf_counter(), _cpu()
        bare = analyze(snd, None)
        t1, c1 = time.perf_counter(), _cpu()
        given = analyze(snd, text)
        t2, c2 = time.perf_counter(), _cpu()
        (s0, n), (s1, _) = event_score(bare, ref), event_score(given, ref)
        p0, p1 = phone_starts(bare, ref), phone_starts(given, ref)
        d = snd.duration
        rows.append((s0, s1, p0, p1, t1 - t0, t2 - t1, d, n, c1 - c0, c2 - c1))
        words = " ".join(w.text for w in bare.alignment.words)
        print(f"{name:16s} {n:6d} {s0:6.3f} {s1:7.3f} {p0:7.3f} {p1:6.3f} {(t1 - t0) / d:6.3f} {(t2 - t1) / d:6.3f} "
              f"{(c1 - c0) / d:6.3f} {(c2 - c1) / d:6.3f}  {words[:50]}")
    a = np.array(rows)
    w = a[:, 7] / a[:, 7].sum()
    total = a[:, 6].sum()
    print(f"{'mean (by clip)':16s} {'':6s} {a[:, 0].mean():6.3f} {a[:, 1].mean():7.3f} {a[:, 2].mean():7.3f} "
          f"{a[:, 3].mean():6.3f} {a[:, 4].sum() / total:6.3f} {a[:, 5].sum() / total:6.3f} "
          f"{a[:, 8].sum() / total:6.3f} {a[:, 9].sum() / total:6.3f}")
    print(f"{'mean (by event)':16s} {'':6s} {(a[:, 0] * w).sum():6.3f} {(a[:, 1] * w).sum():7.3f}")


def _word_spans(ref):
    return [(w.text, w.start, w.end) for w in ref.words if w.text]


def scripts() -> None:
    clips = [c for c in reference_phones() if c[0].endswith("corpus")]
    print("\nTakes that differ from their script")
    for name, audio, text, grid, phoneset in clips:
        ref = read_textgrid(grid, phoneset)
        snd = audio_mod.load(audio)
        base = analyze(snd, text)
        # Appended words.
        r = analyze(snd, text.strip() + " " + APPENDED)
        words = r.alignment.words
        unheard = sum(not w.spoken for w in words[-len(APPENDED.split()):])
        last = max(w.end for w in words if w.spoken and not w.recognized)
        f = _frames(r, last + 0.2, r.duration)
        rest = float((r.curves[f].max(axis=1) < OPEN).mean()) if len(f) else 1.0
        f0 = _frames(base, last + 0.2, base.duration)
        rest0 = float((base.curves[f0].max(axis=1) < OPEN).mean()) if len(f0) else 1.0
        print(f"{name:16s} appended: {unheard}/7 spoken false; at rest after the last spoken word "
              f"{rest:.1%} (matching transcript {rest0:.1%}); other words unspoken: "
              f"{sum(not w.spoken for w in words[:-7])}")
        # Cut words: ten spoken words removed, from a sixth, a third (the
        # figure the issue tracks), half and two thirds of the way in.
        spoken = _word_spans(ref)
        tokens = text.split()
        done: set[int] = set()
        for share in CUT_AT:
            _cut(name, snd, ref, base, tokens, spoken, int(len(spoken) * share), share, done)
        # Swapped word: the middle word of the transcript replaced (the figure
        # the issue tracks), then a long and a short wrong word at five places.
        mid = len(tokens) // 2
        moved = _swap(snd, base, tokens, mid, "elephant")
        if moved is None:
            print(f"{name:16s} swapped: word counts differ")
        else:
            print(f"{name:16s} swapped {tokens[mid]!r} -> 'elephant': neighbours moved {moved[0]:.0f} and "
                  f"{moved[1]:.0f} ms")
        worst = []
        for share in SWAP_AT:
            k = int(len(tokens) * share)
            for wrong in WRONG:
                m = _swap(snd, base, tokens, k, wrong)
                worst.append((max(m) if m else float("inf"), f"{tokens[k]}->{wrong}"))
        within = sum(w <= 40 for w, _ in worst)
        print(f"{name:16s} swapped at {len(SWAP_AT)} places x {len(WRONG)} words: neighbours within 40 ms "
              f"in {within} of {len(worst)}; the worst: "
              + ", ".join(f"{label} {w:.0f} ms" for w, label in sorted(worst, reverse=True)[:3]))


def _cut(name, snd, ref, base, tokens, spoken, k0, share, done: set[int]) -> None:
    """Ten spoken words from ``k0`` removed from the transcript: the share
    of their reference speech inside ``unscripted`` spans and of their
    reference vowel frames where the mouth is open.  ``done`` holds the
    transcript positions cut before (a cut is not measured twice)."""
    # Remove the same ten words from the transcript: the first ten reference
    # words from ``k0`` on that the transcript holds in the same order.
    lower = [t.lower().strip(".,!?") for t in tokens]
    for k in range(k0, len(spoken) - 9):
        cut = spoken[k:k + 10]
        at = next((i for i in range(len(lower) - 9) if lower[i:i + 10] == [c[0].lower() for c in cut]), None)
        if at is not None:
            break
    else:
        print(f"{name:16s} cut at {share:.2f}: no ten reference words in the transcript's order")
        return
    if at in done:
        print(f"{name:16s} cut at {share:.2f}: the same ten words as above")
        return
    done.add(at)
    r = analyze(snd, " ".join(tokens[:at] + tokens[at + 10:]))
    a, b = cut[0][1], cut[-1][2]
    grid_t = np.arange(a, b, 0.01)
    inside = np.zeros(len(grid_t), bool)
    for s, e, _ in r.alignment.unscripted:
        inside |= (grid_t >= s) & (grid_t < e)
    speech = np.zeros(len(grid_t), bool)
    for _, s, e in cut:
        speech |= (grid_t >= s) & (grid_t < e)
    active = r.curves.max(axis=1) >= OPEN
    vf = np.concatenate([_frames(r, p.start, p.end) for p in ref.phones
                         if p.phone in VOWELS and a <= p.start < b] or [np.zeros(0, int)])
    base_active = base.curves.max(axis=1) >= OPEN
    print(f"{name:16s} cut at {share:.2f} {' '.join(c[0] for c in cut)!r}: {inside[speech].mean():.1%} of their "
          f"speech unscripted; mouth open on {active[vf].mean():.1%} of their vowel frames "
          f"(matching transcript {base_active[vf].mean():.1%})")


def _swap(snd, base, tokens, k, wrong) -> tuple[float, float] | None:
    """How far (ms) the starts of the words before and after transcript word
    ``k`` move when ``wrong`` replaces it; None if the words differ in number."""
    r = analyze(snd, " ".join(tokens[:k] + [wrong] + tokens[k + 1:]))
    bw, sw = base.alignment.script, r.alignment.script
    if len(bw) != len(sw):
        return None
    j = next(i for i, w in enumerate(sw) if w.text == wrong and bw[i].text != wrong)
    return tuple(abs(sw[i].start - bw[i].start) * 1000 if 0 <= i < len(sw) else 0.0 for i in (j - 1, j + 1))


def _tokens(wav) -> list[str]:
    """The words of a TIMIT sentence (its .txt without the two sample counts before them)."""
    return wav.with_suffix(".txt").read_text().split()[2:]


def _joined(first, second):
    return audio_mod.Audio(np.concatenate([first.samples, second.samples]), first.rate)


def _covered(al, speech, t0, t1) -> float:
    """The share of the ``speech`` spans' frames in t0..t1 inside ``al.unscripted``."""
    grid = np.arange(t0, t1, 0.01)
    said = np.zeros(len(grid), bool)
    for s0, s1 in speech:
        said |= (grid >= s0) & (grid < s1)
    covered = np.zeros(len(grid), bool)
    for s0, s1, _ in al.unscripted:
        covered |= (grid >= s0) & (grid < s1)
    return float(covered[said].mean())


def around_the_script() -> None:
    timit = DATA / "timit_nltk"
    if not timit.is_dir():
        print(f"\n({timit} is not here: no speech before or after the script)")
        return
    files = sorted(timit.glob("*/*.wav"))
    pairs = [(a, b) for a, b in zip(files[::4], files[1::4]) if a.parent == b.parent]
    text = {p: " ".join(_tokens(p)) for pair in pairs for p in pair}
    for where in ("after", "before"):
        kept, inside = 0, []
        for a, b in pairs:
            first, second = audio_mod.load(a), audio_mod.load(b)
            line, other, offset = (a, second, 0.0) if where == "after" else (b, first, first.duration)
            alone = analyze(first if where == "after" else second, text[line]).alignment.words
            extra = [(w.start, w.end) for w in analyze(other, text[b if where == "after" else a]).alignment.words]
            al = analyze(_joined(first, second), text[line]).alignment
            own = al.script
            kept += max(max(abs(w.start - offset - v.start), abs(w.end - offset - v.end))
                        for w, v in zip(own, alone)) <= 0.1
            if where == "after":
                inside.append(_covered(al, [(first.duration + s, first.duration + e) for s, e in extra],
                                       first.duration, first.duration + second.duration))
            else:
                inside.append(_covered(al, extra, 0.0, first.duration))
        print(f"{'Speech ' + where + ' the script':32s} ({len(pairs)} pairs of TIMIT sentences joined, one's "
              f"transcript): its words within 0.1 s of their own alignment in {kept} of {len(pairs)}; the other "
              f"sentence's speech inside unscripted {np.mean(inside):.1%} (lowest {min(inside):.1%})")


def cut_line() -> None:
    """Three TIMIT sentences by one speaker joined, the middle one cut from the transcript: the share of
    its hand-labelled speech inside ``unscripted``, of its vowel frames where the mouth is open, in how
    many takes the other two sentences' words stay within 0.1 s of their own alignment, and the CPU time."""
    from timit import hand_phones

    timit = DATA / "timit_nltk"
    if not timit.is_dir():
        return
    files = sorted(timit.glob("*/*.wav"))
    triples = [t for t in zip(files[::4], files[1::4], files[2::4]) if t[0].parent == t[1].parent == t[2].parent]
    text = {p: " ".join(_tokens(p)) for t in triples for p in t}
    covered, shown, kept, cpu, seconds = [], [], 0, 0.0, 0.0
    for a, b, c in triples:
        clips = [audio_mod.load(p) for p in (a, b, c)]
        take = audio_mod.Audio(np.concatenate([x.samples for x in clips]), clips[0].rate)
        c0 = _cpu()
        r = analyze(take, text[a] + " " + text[c])
        cpu += _cpu() - c0
        seconds += take.duration
        start, end = clips[0].duration, clips[0].duration + clips[1].duration
        ref = hand_phones(b.with_suffix(".phn"))
        covered.append(_covered(r.alignment, [(start + p.start, start + p.end) for p in ref], start, end))
        vowels = np.concatenate([_frames(r, start + p.start, start + p.end) for p in ref if p.phones & VOWELS]
                                or [np.zeros(0, int)])
        shown.append(float((r.curves[vowels].max(axis=1) >= OPEN).mean()))
        alone = [(w.start, w.end) for w in analyze(clips[0], text[a]).alignment.words]
        alone += [(w.start + end, w.end + end) for w in analyze(clips[2], text[c]).alignment.words]
        own = r.alignment.script
        kept += len(own) == len(alone) and all(abs(w.start - s0) <= 0.1 and abs(w.end - s1) <= 0.1
                                               for w, (s0, s1) in zip(own, alone))
    print(f"{'A line cut from the middle':32s} ({len(triples)} takes of three TIMIT sentences, the middle one "
          f"cut from the transcript): its speech inside unscripted {np.mean(covered):.1%} (lowest "
          f"{min(covered):.1%}); mouth open on {np.mean(shown):.1%} of its vowel frames (lowest {min(shown):.1%}); "
          f"the other words within 0.1 s of their own alignment in {kept} of {len(triples)}; "
          f"{cpu / seconds:.3f} CPU s per s of audio")


def swapped_words() -> None:
    """Each TIMIT sentence with its middle word replaced by a long and by a short wrong word: the share
    of swaps whose neighbours start within 40 ms of where they do with the sentence's own transcript."""
    timit = DATA / "timit_nltk"
    if not timit.is_dir():
        return
    moved = {wrong: [] for wrong in WRONG}
    for f in sorted(timit.glob("*/*.wav")):
        tokens = _tokens(f)
        snd = audio_mod.load(f)
        base = analyze(snd, " ".join(tokens))
        for wrong in WRONG:
            m = _swap(snd, base, tokens, len(tokens) // 2, wrong)
            moved[wrong].append(max(m) if m else float("inf"))
    print(f"{'Swapped words':32s} ({len(moved[WRONG[0]])} TIMIT sentences, the middle word replaced): "
          "neighbours within 40 ms in " + ", ".join(
              f"{np.mean(np.array(m) <= 40):.1%} with {w!r} (median {np.median(m):.0f} ms)" for w, m in moved.items()))


def another_line() -> None:
    """Each TIMIT sentence with its own transcript and with another sentence's (seven on): how many are
    refused, and how many warned that the transcript may belong to another recording."""
    timit = DATA / "timit_nltk"
    if not timit.is_dir():
        return
    files = sorted(timit.glob("*/*.wav"))
    texts = [" ".join(_tokens(f)) for f in files]

    def outcome(path, text) -> str:
        try:
            r = analyze(str(path), text)
        except LipSyncError:
            return "refused"
        return "warned" if any("belong to this recording" in w for w in r.warnings) else "aligned"

    for label, pairs in (("its own transcript", zip(files, texts)),
                         ("another sentence's", [(f, texts[(k + 7) % len(texts)]) for k, f in enumerate(files)])):
        got = [outcome(f, t) for f, t in pairs]
        print(f"{len(got)} TIMIT sentences with {label}: refused {got.count('refused')}, warned "
              f"{got.count('warned')}, aligned without a word {got.count('aligned')}")


if __name__ == "__main__":
    no_transcript()
    scripts()
    print()
    around_the_script()
    cut_line()
    swapped_words()
    another_line()
