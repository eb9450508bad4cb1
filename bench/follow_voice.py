"""Before/after figure for ``weights.follow_voice``: viseme weights of an
excited and a calm reading with the amount at 0 (equations 1-2 alone, each
line weighed against itself) and above 0 (ranges scaled by the voice's
arousal, on one scale across lines).

Lines: the same speaker saying "montreal forced aligner" in falsetto and in
a breathy voice (../shared/data/voice_quality; skipped when absent), and
the tests' synthetic voice at full and at no vocal effort (always run).

    .venv/bin/python bench/follow_voice.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from common import DATA, ROOT
from addon.engine import presets
from addon.engine.language.phonemes import MANNER
from addon.engine.pipeline import analyze
from addon.engine.settings import LineSettings

sys.path.insert(0, str(ROOT / "tests"))
from voice_synth import voice

AMOUNTS = (0.0, 0.5, 1.0)


def preset(amount):
    p = presets.read("neutral")
    p["weights"]["follow_voice"] = amount
    return p


def row(label, make):
    out = []
    for a in AMOUNTS:
        r = make(preset(a))
        vowels = [w for p, w in zip(r.alignment.phones, r.weights) if MANNER.get(p.phone) == "vowel"]
        out.append((float(np.mean(vowels)), float(r.curves.max(axis=1).mean())))
    arousal = r.arousal.value
    cells = "  ".join(f"{v:.3f} / {c:.3f}" for v, c in out)
    print(f"{label:34} {arousal:+.3f}   {cells}")


def main() -> None:
    print("mean vowel weight / mean of each frame's largest viseme value, by follow_voice amount")
    print(f"{'line':34} arousal  " + "  ".join(f"{'amount ' + format(a, 'g'):>15}" for a in AMOUNTS))
    for label, effort in (("synthetic, full effort", 1.0), ("synthetic, no effort", 0.0)):
        snd, al = voice(effort)
        row(label, lambda p, snd=snd, al=al: analyze(snd, settings=LineSettings.of(emotion=p), alignment=al))
    vq = Path(DATA) / "voice_quality"
    if not vq.is_dir():
        print(f"skipped the recorded lines: {vq} is not here")
        return
    text = "montreal forced aligner"
    for name in ("mfa_falsetto", "mfa_breathy"):
        al = analyze(vq / f"{name}.flac", text).alignment     # align once, reuse for every amount
        row(f"recorded, {name}", lambda p, name=name, al=al: analyze(vq / f"{name}.flac",
                                                                     settings=LineSettings.of(emotion=p), alignment=al))


if __name__ == "__main__":
    main()
