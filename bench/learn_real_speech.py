"""Learning on real speech: is the preset ``learn`` writes, with its
defaults, at least as good as the one it started from on a sentence it did
not see, track by track?

Reads ``../shared/data/timit_nltk`` (skips cleanly without it): read
sentences of real speakers with hand-verified phone boundaries.  There are
no face or articulography captures in the shared data, so each sentence's
"capture" is made from its hand-labelled phones by the articulatory model of
``tests/mismatch.py`` (targets per phoneme tracked by a damped system, not
the engine's dominance model; a delay, sensor units and noise), while
``learn`` gets what a user gives it: the audio and the transcript, aligned
by the engine.  Per speaker, each sentence is held out in turn; ``learn``
runs with its defaults on the others (its own leave-one-out check decides
what to keep) and the preset it writes is scored on the held-out sentence
against the starting preset: correlation and RMSE of jaw, lip aperture and
rounding (gain and offset fitted on the training sentences for both
presets, as the training report does).  Prints per held-out sentence and
the means, and which parts were learned.

    .venv/bin/python bench/learn_real_speech.py [--speakers 3] [--sentences 4] [--emotion neutral]
"""

from __future__ import annotations

import argparse
import sys
import time
from types import SimpleNamespace

import numpy as np

from common import ROOT, need_data

sys.path.insert(0, str(ROOT / "tests"))
import mismatch
from addon.engine import audio as audio_mod
from addon.engine import learning, pipeline, presets, visemes
from addon.engine.learning import proxies
from addon.engine.learning.evaluate import track_scores
from addon.engine.learning.model import viseme_curves

RATE = 16000
#: TIMIT labels that are not ARPAbet; stop closures join the stop after them.
TIMIT = {"h#": "SIL", "pau": "SIL", "epi": "SIL", "q": "SIL", "ax": "AH", "ax-h": "AH", "axr": "ER", "ix": "IH",
         "ux": "UW", "dx": "D", "nx": "N", "en": "N", "em": "M", "eng": "NG", "el": "L", "hv": "HH"}
CLOSURES = {"bcl", "dcl", "gcl", "pcl", "tcl", "kcl"}


def hand_phones(phn):
    """The hand-labelled phones as ARPAbet spans (a closure belongs to its stop)."""
    rows = [line.split() for line in phn.read_text().splitlines() if line.strip()]
    out = []
    for k, (a, b, lab) in enumerate(rows):
        start, end = int(a) / RATE, int(b) / RATE
        if lab in CLOSURES:
            nxt = rows[k + 1][2] if k + 1 < len(rows) else ""
            if nxt == lab[0]:
                continue            # the stop's span starts at its closure (below)
            lab = lab[0]            # a closure with no release: the stop
        if k > 0 and rows[k - 1][2] in CLOSURES and rows[k - 1][2][0] == lab:
            start = int(rows[k - 1][0]) / RATE
        out.append(SimpleNamespace(phone=TIMIT.get(lab, lab.upper()), start=start, end=end))
    return out


def sentences(folder, limit):
    out = []
    for wav in sorted(folder.glob("*.wav"))[:limit]:
        text = wav.with_suffix(".txt").read_text().split(maxsplit=2)[2].strip()
        out.append((wav.stem, wav, text, hand_phones(wav.with_suffix(".phn"))))
    return out


def clip_of(name, wav, text, phones, rng, delay):
    snd = audio_mod.load(wav)
    truth = SimpleNamespace(phones=phones)
    times, y = mismatch.capture(truth, snd.duration, delay=delay, rng=rng)
    al = pipeline.align_audio(snd, text)
    return learning.TrainingClip(name, snd, al, times, y, list(mismatch.TRACKS))


def scores(preset, base, train, held, vset, delay, fps=30.0):
    """Per track on ``held``: scores of ``preset``, calibrated on ``train``."""
    M0 = proxies.poses(vset, list(mismatch.TRACKS))
    prep = [learning.prepare(c, vset, base, fps, list(mismatch.TRACKS)) for c in train + [held]]
    raw = [viseme_curves(p, preset, vset, fps) @ M0 for p in prep]
    gain, offset = proxies.calibrate(raw[:-1], [p.aligned(delay) for p in prep[:-1]])
    y = prep[-1].aligned(delay)
    pred = raw[-1] * gain + offset
    return {ch: track_scores(pred[:, j], y[:, j], fps) for j, ch in enumerate(mismatch.TRACKS)}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--speakers", type=int, default=3)
    ap.add_argument("--sentences", type=int, default=4, help="per speaker (each held out in turn)")
    ap.add_argument("--emotion", default="neutral")
    ap.add_argument("--delay-ms", type=float, default=40.0)
    ap.add_argument("--keep-learned", action="store_true", help="score every learned part (learn --keep-learned)")
    args = ap.parse_args()
    data = need_data() / "timit_nltk"
    vset = visemes.load("arkit")
    base = presets.load(args.emotion)
    rng = np.random.default_rng(0)
    speakers = [d for d in sorted(data.iterdir()) if d.is_dir() and len(list(d.glob("*.wav"))) >= 3]
    rows = []
    t0 = time.perf_counter()
    for spk in speakers[:args.speakers]:
        clips = [clip_of(n, w, t, p, rng, args.delay_ms / 1000) for n, w, t, p in sentences(spk, args.sentences)]
        for i, held in enumerate(clips):
            train = clips[:i] + clips[i + 1:]
            result = learning.learn(train, emotion=args.emotion, viseme_set="arkit", name="bench",
                                 keep_learned=args.keep_learned)
            delay = result.report["delay_ms"] / 1000
            learned = scores(result.preset, base, train, held, vset, delay)
            start = scores(base, base, train, held, vset, delay)
            rows.append((f"{spk.name}/{held.name}", learned, start, result.report["parts"]["learned"]))
            print(f"{spk.name}/{held.name}: " + "; ".join(
                f"{ch} r {learned[ch]['correlation']:.3f}/{start[ch]['correlation']:.3f} "
                f"RMSE {learned[ch]['rmse']:.4f}/{start[ch]['rmse']:.4f}" for ch in mismatch.TRACKS)
                + f"  (learned: {', '.join(rows[-1][3]) or 'nothing'})", flush=True)
    print(f"\n{len(rows)} held-out sentences of {min(args.speakers, len(speakers))} speakers in "
          f"{time.perf_counter() - t0:.0f} s; learned/start on the sentence each preset did not see:")
    for ch in mismatch.TRACKS:
        lc = np.mean([r[1][ch]["correlation"] for r in rows])
        sc = np.mean([r[2][ch]["correlation"] for r in rows])
        lr = np.mean([r[1][ch]["rmse"] for r in rows])
        sr = np.mean([r[2][ch]["rmse"] for r in rows])
        print(f"  {ch:13} correlation {lc:.3f} / {sc:.3f} ({lc - sc:+.3f})   RMSE {lr:.4f} / {sr:.4f} "
              f"({100 * (lr / sr - 1):+.1f} %)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
