"""Learning speed: fitting a preset to 10 clips of about 3 s with the 52
ARKit channels (target: under 30 s on 2 cores), and synthesis with a learned
preset against a built-in one (target: the same).

The clips are the shipped speech cut into ~3 s pieces at word boundaries,
with tracks from a known model plus noise (as in tests/test_learn.py); only
timing is measured here, so no recordings are needed.

    .venv/bin/python bench/learn_speed.py
"""

from __future__ import annotations

import sys
import time

import numpy as np

from common import ROOT
from addon.engine import audio as audio_mod
from addon.engine import learning, pipeline, presets, visemes
from addon.engine.learning import capture
from addon.engine.alignment import align_audio
from addon.engine.alignment import Alignment
from addon.engine.settings import LineSettings

CHANNELS = list(capture.ARKIT)


def pieces(snd, al, length=3.0):
    """Cut a clip at the word boundaries nearest every ``length`` seconds."""
    out, start = [], 0.0
    words = al.words
    while start < al.duration - 1.0:
        end = min(al.duration, start + length)
        cut = min((w.end for w in words if w.end > start + 1.5), key=lambda e: abs(e - end), default=al.duration)
        a, b = int(start * snd.rate), int(cut * snd.rate)
        sub = audio_mod.Audio(snd.samples[a:b], snd.rate)
        ph = [type(p)(**{**p.__dict__, "start": p.start - start, "end": p.end - start})
              for p in al.phones if p.start >= start - 1e-6 and p.end <= cut + 1e-6]
        ws = [type(w)(**{**w.__dict__, "start": w.start - start, "end": w.end - start})
              for w in words if w.start >= start - 1e-6 and w.end <= cut + 1e-6]
        out.append((sub, Alignment(ws, ph, cut - start)))
        start = cut
    return out


def main():
    speech = ROOT / "sample_rigs" / "speech"
    snd = audio_mod.load(speech / "hello.wav")
    al = align_audio(snd, (speech / "hello.txt").read_text())
    base = pieces(snd, al)
    rng = np.random.default_rng(3)
    vs = visemes.load("arkit")
    poses = {v: {str(c): float(rng.uniform(0.2, 0.9)) for c in rng.choice(CHANNELS, 5, replace=False)}
             for v in vs.visemes if v != "sil"}
    truth = presets.read("neutral")
    truth["learned"] = {"viseme_set": "arkit", "targets": poses}
    truth = presets.validate(truth)
    truth_set = visemes.with_targets(vs, poses)
    clips = []
    k = 0
    while len(clips) < 10:
        sub, sal = base[k % len(base)]
        gain = 0.8 + 0.1 * (k // len(base))       # louder or softer copies: other weights, same timing
        sub = audio_mod.Audio(sub.samples * gain, sub.rate)
        probe = learning.TrainingClip("p", sub, sal, np.array([0.0, sub.duration]), np.zeros((2, 52)), CHANNELS)
        prep = learning.prepare(probe, vs, truth, 60.0, CHANNELS)
        y = learning.synthesise(prep, truth, truth_set, CHANNELS, 60.0, poses)
        y = y + rng.normal(0, 0.01, (len(prep.times), 52))
        clips.append(learning.TrainingClip(f"piece{k}", sub, sal, prep.times, y, CHANNELS))
        k += 1
    secs = sum(c.audio.duration for c in clips)
    t0 = time.perf_counter()
    result = learning.learn(clips, emotion="neutral", viseme_set="arkit", name="bench")
    fit = time.perf_counter() - t0
    r = result.report
    print(f"fit: {len(clips)} clips, {secs:.1f} s of audio ({secs / len(clips):.1f} s each), 52 channels: "
          f"{fit:.2f} s (target < 30 s); {r['fit']['iterations']} iterations, {r['pca']['components']} components, "
          f"held-out RMSE {r['learned']['heldout']['rmse']:.4f} (built-in {r['builtin']['heldout']['rmse']:.4f})")

    # Synthesis: the same line with a built-in and with the learned preset.
    text = (speech / "hello.txt").read_text()
    for label, emotion, vset in (("built-in neutral", "neutral", "arkit"), ("learned", result.preset, None)):
        best = float("inf")
        for _ in range(5):
            t0 = time.perf_counter()
            pipeline.analyze(snd, text, LineSettings.of(emotion=emotion, viseme_set=vset), alignment=al)
            best = min(best, time.perf_counter() - t0)
        print(f"synthesis with the {label} preset ({snd.duration:.1f} s line, alignment given): {1000 * best:.1f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
