"""Lines without a transcript: what the mouth shows when the words are recognised.

Every clip in ../shared/data with a transcript (skips when the folder is
absent) is analysed without it, and scored against reference phones by
group:

* ``timit``: TIMIT's 61 read sentences, hand labels (bench/timit.py);
* ``natural``: the two spontaneous MFA monologues (acoustic_corpus, and
  cold_corpus, the same speaker hoarse), their MFA phone tiers;
* ``read``: the praatio sentences, hand labels;
* ``voice``: the voice-quality clips, the LibriSpeech line and the two
  LibriVox sonnets, whose references are the engine's own alignment with
  the transcript (``silver``: it says which /p b m/ and vowels are there and
  about where, not to the frame).

Per group: the event score of bench/offscript.py (mean by clip; vowels open,
/p b m/ closed within 30 ms, pauses of 0.3 s at rest), and its three parts
counted over the group's events: ``pbm`` the /p b m/ with the lips closed,
``vowel`` the vowels with the mouth open, ``pause`` the pauses at rest; and
``closed-V`` the share of reference vowel frames with the lips closed (a
closure where the mouth should be open); then the wall time per second of
audio.  ``--decoder key=value`` changes one of the recogniser's options
(recognize.DECODER_OPTIONS) for the run, to compare settings on every group
at once; ``--clips`` names clips by substring.

    LIPSYNC_DATA=/work/shared/data .venv/bin/python bench/no_transcript.py
    .venv/bin/python bench/no_transcript.py --decoder ds=1 --decoder lw=3
"""

from __future__ import annotations

import argparse
import ast
import sys
import time

import numpy as np

from common import events, need_data, reference_phones, transcript_clips
from addon.engine import audio as audio_mod
from addon.engine.importers import read_textgrid
from addon.engine.pipeline import analyze
from addon.engine.settings import LineSettings

GROUPS = ("timit", "natural", "read", "voice")


def clips() -> list[tuple[str, str, object, str, list]]:
    """(group, name, audio, transcript, [(phones, start, end)])."""
    from timit import DEV, HELD, sentences

    data = need_data()
    out = []
    with_ref = set()
    for name, audio, text, grid, phoneset in reference_phones():
        group = "natural" if name.endswith("_corpus") else "read"
        ref = [({p.phone}, p.start, p.end) for p in read_textgrid(grid, phoneset).phones]
        out.append((group, name, audio_mod.load(audio), text, ref))
        with_ref.add(audio.stem)
    for name, wav, text, ref in sentences(data / "timit_nltk", DEV + HELD, None):
        out.append(("timit", name, audio_mod.load(wav), text, [(set(p.phones), p.start, p.end) for p in ref]))
    for name, path, text in transcript_clips():
        if path.stem in with_ref or name.startswith("damon") or path.parent.name == "common_voice":
            continue
        snd = audio_mod.load(path)
        al = analyze(snd, text, LineSettings.of(fps=100)).alignment
        out.append(("voice", name, snd, text,
                    [({p.phone}, p.start, p.end) for p in al.phones if al.words[p.word_index].spoken]))
    return out


def part(ss, key: str) -> str:
    """The share of one kind of event hit over the clips ``ss``, and how many there are."""
    hits = [h for s in ss for h in getattr(s, key)]
    return f"{np.mean(hits) if hits else 1:.3f} ({len(hits):3d})"


def _value(text: str):
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--decoder", action="append", default=[], metavar="KEY=VALUE",
                    help="a recogniser option for this run (recognize.DECODER_OPTIONS)")
    ap.add_argument("--clips", nargs="*", help="only clips whose name holds one of these")
    ap.add_argument("--verbose", action="store_true", help="a line per clip")
    args = ap.parse_args(argv)
    from addon.engine.alignment import recognize

    for kv in args.decoder:
        key, _, value = kv.partition("=")
        recognize.DECODER_OPTIONS[key] = _value(value)
    recognize._decoder()        # loaded once, as a batch or a Blender session does
    rows = {g: [] for g in GROUPS}
    for group, name, snd, _text, ref in clips():
        if args.clips and not any(c in name for c in args.clips):
            continue
        t0 = time.perf_counter()
        r = analyze(snd, None, LineSettings.of(fps=100))
        dt = time.perf_counter() - t0
        s = events(r, ref)
        s.events = float(np.mean(s.hits)) if s.hits else 1.0
        s.time, s.duration = dt, snd.duration
        rows[group].append(s)
        if args.verbose:
            print(f"  {group:8s} {name:22s} events {s.events:.3f} pbm {sum(s.pbm)}/{len(s.pbm)} "
                  f"vowels {sum(s.vowel)}/{len(s.vowel)} pauses {sum(s.pause)}/{len(s.pause)}  "
                  f"{' '.join(w.text for w in r.alignment.words)[:60]}")
    print(f"decoder: {dict(recognize.DECODER_OPTIONS)}")
    print(f"{'group':8s} {'clips':>5s} {'events':>7s} {'pbm':>13s} {'vowel':>13s} {'pause':>11s} "
          f"{'closed-V':>8s} {'x rt':>6s}")
    every = []
    for g in GROUPS:
        ss = rows[g]
        if not ss:
            continue
        every += ss

        vf = sum(s.vowel_frames for s in ss)
        print(f"{g:8s} {len(ss):5d} {np.mean([s.events for s in ss]):7.3f} {part(ss, 'pbm'):>13s} "
              f"{part(ss, 'vowel'):>13s} {part(ss, 'pause'):>11s} "
              f"{sum(s.vowel_closed for s in ss) / max(1, vf):8.2%} "
              f"{sum(s.time for s in ss) / sum(s.duration for s in ss):6.3f}")
    print(f"{'all':8s} {len(every):5d} {np.mean([s.events for s in every]):7.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
