"""False alarms of the script checks: every recording in ../shared/data with
its right transcript, cut the way studios deliver lines (skips when absent).

The checks of a take against its script (words not heard, speech not in
the transcript, a transcript of another recording) must stay silent on a
right transcript.  Every line here is said as written, so every refusal,
every word left ``spoken: false``, every second of ``unscripted`` speech
and every warning is a false alarm.  The lines:

* **pause**: the two MFA monologues (fast, slow, hoarse; a cold) cut at
  every pause of 0.2 s or more between words, each line from the middle of
  the pause before it to the middle of the pause after it (breaths kept);
* **tight**: the same monologues cut at the word boundary nearest every
  3 s inside the speech, with no margin (a phrase cut in mid-flow);
* **sentence**: whole recordings: TIMIT's 61 sentences, EmoDB's acted
  emotional German, the praatIO, LibriSpeech, Common Voice and voice-quality
  clips (whisper, creak, laughter...);
* **digital**: the lines with reference times (the MFA lines, TIMIT, EmoDB)
  with exact digital silence around their speech (0.3 s of zeros each
  side, everything before the first word and after the last zeroed);

each at its own speed and sped up 1.25x and 1.5x with a real time-stretch
(Praat's overlap-add, pitch kept).

Printed per kind of line and per source: lines, lines refused, transcript
words left unspoken, seconds called unscripted, lines warned, and the wall
time of ``analyze`` per second of audio.  The hit rates of the same checks
on wrong transcripts are what ``bench/offscript.py`` prints; ``--hits``
prints its quick ones here too (appended words, another line's transcript).

The sources form the split the checks are judged on: the MFA monologues
and TIMIT are where their constants were chosen; EmoDB, the voice-quality
clips and the other read clips are held out.

    .venv/bin/python bench/false_alarms.py               # everything (about 15 minutes)
    .venv/bin/python bench/false_alarms.py --quick       # speed 1 only
    .venv/bin/python bench/false_alarms.py --only emodb --speeds 1 --show
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from common import DATA, need_data, transcript_clips
from addon.engine import audio as audio_mod
from addon.engine.errors import LipSyncError
from addon.engine.importers import read_textgrid
from addon.engine.pipeline import analyze
from addon.engine.settings import LineSettings

#: Pauses between words at least this long (s) cut the MFA monologues into lines.
PAUSE = 0.2
#: The tight cuts: at the word boundary nearest every this many seconds.
TIGHT = 3.0
#: Zeros around a line's speech in the digital-silence variant (s).
PAD = 0.3
SPEEDS = (1.0, 1.25, 1.5)
#: Sources the checks' constants were chosen on; the rest is held out.
TUNED = {"mfa", "timit"}


@dataclass
class Line:
    name: str
    source: str          # mfa, timit, emodb, other
    kind: str            # pause, tight, sentence, digital
    samples: np.ndarray  # float, 16 kHz
    text: str
    language: str | None = None


def _words(grid: Path) -> list[tuple[str, float, float]]:
    ref = read_textgrid(grid, "arpabet")
    return [(w.text, w.start, w.end) for w in ref.words if w.text]


def _clip(x: np.ndarray, a: float, b: float, rate: int = 16000) -> np.ndarray:
    return x[max(0, int(round(a * rate))):int(round(b * rate))].copy()


def _digital(x: np.ndarray, a: float, b: float, rate: int = 16000) -> np.ndarray:
    """``x`` a..b s with PAD s of zeros on either side."""
    pad = np.zeros(int(PAD * rate), x.dtype)
    return np.concatenate([pad, _clip(x, a, b, rate), pad])


def mfa_lines() -> list[Line]:
    out = []
    for name in ("acoustic_corpus", "cold_corpus"):
        snd = audio_mod.load(DATA / "mfa" / f"{name}.wav")
        x = snd.samples.astype(np.float32)
        words = _words(DATA / "mfa" / f"{name}.TextGrid")
        # At pauses: a line from the middle of the pause before to the middle of the pause after.
        groups, cur = [], [words[0]]
        for w in words[1:]:
            if w[1] - cur[-1][2] >= PAUSE:
                groups.append(cur)
                cur = [w]
            else:
                cur.append(w)
        groups.append(cur)
        for k, g in enumerate(groups):
            a = (groups[k - 1][-1][2] + g[0][1]) / 2 if k else 0.0
            b = (g[-1][2] + groups[k + 1][0][1]) / 2 if k + 1 < len(groups) else snd.duration
            text = " ".join(w[0] for w in g)
            out.append(Line(f"{name}:{g[0][1]:.1f}", "mfa", "pause", _clip(x, a, b), text))
            out.append(Line(f"{name}:{g[0][1]:.1f}", "mfa", "digital", _digital(x, g[0][1], g[-1][2]), text))
        # Tight: at the word boundary nearest every TIGHT s, no margin.
        start, piece = words[0][1], []
        for w in words:
            piece.append(w)
            if w[2] - start >= TIGHT - 0.2:
                out.append(Line(f"{name}:{start:.1f}", "mfa", "tight", _clip(x, start, w[2]),
                                " ".join(p[0] for p in piece)))
                piece, start = [], w[2]
        if piece:
            out.append(Line(f"{name}:{start:.1f}", "mfa", "tight", _clip(x, start, piece[-1][2]),
                            " ".join(p[0] for p in piece)))
        out.append(Line(name, "mfa", "sentence", x, " ".join(w[0] for w in words)))
    return out


def timit_lines() -> list[Line]:
    out = []
    for wav in sorted((DATA / "timit_nltk").glob("*/*.wav")):
        x = audio_mod.load(wav).samples.astype(np.float32)
        text = " ".join(wav.with_suffix(".txt").read_text().split()[2:])
        phones = [line.split() for line in wav.with_suffix(".phn").read_text().splitlines()]
        said = [(int(a) / 16000, int(b) / 16000) for a, b, lab in phones if lab not in {"h#", "pau", "epi"}]
        name = f"{wav.parent.name}/{wav.stem}"
        out.append(Line(name, "timit", "sentence", x, text))
        out.append(Line(name, "timit", "digital", _digital(x, said[0][0], said[-1][1]), text))
    return out


def _lablaut(path: Path) -> tuple[float, float]:
    """(first label, end mark) of an EmoDB label file, s."""
    times = []
    for line in path.read_text(encoding="latin-1").split("#", 1)[1].splitlines():
        parts = line.split()
        if len(parts) >= 3 and parts[1] == "-1":
            times.append(float(parts[0]))
    return times[0], times[-1]


def emodb_lines() -> list[Line]:
    out = []
    for wav in sorted((DATA / "emodb").glob("*.wav")):
        x = audio_mod.load(wav).samples.astype(np.float32)
        text = wav.with_suffix(".txt").read_text(encoding="utf-8").strip()
        a, b = _lablaut(wav.with_suffix(".lablaut"))
        out.append(Line(wav.stem, "emodb", "sentence", x, text, "de"))
        out.append(Line(wav.stem, "emodb", "digital", _digital(x, max(0.0, a - 0.02), b), text, "de"))
    return out


def other_lines() -> list[Line]:
    out = []
    for name, path, text in transcript_clips():
        if name.endswith("_corpus") or path.parent.name == "librivox":
            continue    # the monologues are cut above; the sonnets are 52 s read verse (bench/speed.py)
        snd = audio_mod.load(path)
        x = snd.samples.astype(np.float32)
        if snd.rate != 16000:
            from addon.engine.resampling import resample
            x = resample(x, snd.rate, 16000).astype(np.float32)
        out.append(Line(name, "other", "sentence", x, text))
    return out


def stretched(x: np.ndarray, speed: float) -> np.ndarray:
    """``x`` sped up ``speed`` times, pitch kept (Praat's Lengthen (overlap-add), seeded)."""
    if speed == 1.0:
        return x
    from addon.engine.alignment.tempo import slowed

    return slowed(audio_mod.Audio(x.astype(np.float32), 16000), 1.0 / speed).samples


@dataclass
class Outcome:
    line: Line
    speed: float
    seconds: float
    took: float
    refused: str = ""
    unspoken: list[str] | None = None
    unscripted: float = 0.0
    warnings: list[str] | None = None


def run(line: Line, speed: float) -> Outcome:
    x = stretched(line.samples, speed)
    snd = audio_mod.Audio(x, 16000)
    t0 = time.perf_counter()
    try:
        r = analyze(snd, line.text, LineSettings.of(language=line.language))
    except LipSyncError as exc:
        return Outcome(line, speed, snd.duration, time.perf_counter() - t0, refused=str(exc))
    took = time.perf_counter() - t0
    al = r.alignment
    return Outcome(line, speed, snd.duration, took, unspoken=[w.text for w in al.script if not w.spoken],
                   unscripted=sum(b - a for a, b, _ in al.unscripted), warnings=list(r.warnings))


def lines(only: str | None) -> list[Line]:
    need_data()
    out = []
    for source, make in (("mfa", mfa_lines), ("timit", timit_lines), ("emodb", emodb_lines), ("other", other_lines)):
        if only and only != source:
            continue
        out += make()
    return out


def table(outcomes: list[Outcome], key) -> None:
    groups: dict[str, list[Outcome]] = {}
    for o in outcomes:
        groups.setdefault(key(o), []).append(o)
    print(f"  {'':24s} {'lines':>5s} {'refused':>7s} {'unspoken':>8s} {'unscr s':>7s} {'warned':>6s} {'x rt':>6s}")
    for label in sorted(groups) + ["all"]:
        g = outcomes if label == "all" else groups[label]
        refused = sum(bool(o.refused) for o in g)
        unspoken = sum(len(o.unspoken or []) for o in g)
        unscripted = sum(o.unscripted for o in g)
        warned = sum(bool(o.refused or o.warnings) for o in g)
        rt = sum(o.took for o in g) / sum(o.seconds for o in g)
        print(f"  {label:24s} {len(g):5d} {refused:7d} {unspoken:8d} {unscripted:7.1f} "
              f"{warned:6d} {rt:6.3f}   ({warned / len(g):.1%} warned)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", choices=("mfa", "timit", "emodb", "other"), help="one source")
    ap.add_argument("--speeds", type=float, nargs="+", default=list(SPEEDS))
    ap.add_argument("--quick", action="store_true", help="speed 1 only")
    ap.add_argument("--show", action="store_true", help="print every line with a false alarm")
    ap.add_argument("--hits", action="store_true", help="also the quick hit rates of bench/offscript.py")
    args = ap.parse_args()
    speeds = [1.0] if args.quick else args.speeds
    todo = lines(args.only)
    first = todo[0]
    # the models loaded once, as a batch or a Blender session does
    analyze(audio_mod.Audio(first.samples, 16000), first.text, LineSettings.of(language=first.language))
    outcomes = []
    for speed in speeds:
        for line in todo:
            o = run(line, speed)
            outcomes.append(o)
            if args.show and (o.refused or o.unspoken or o.unscripted or o.warnings):
                what = (f"refused: {o.refused}" if o.refused else
                        "; ".join(([f"unspoken {o.unspoken}"] if o.unspoken else [])
                                  + ([f"unscripted {o.unscripted:.2f} s"] if o.unscripted else [])
                                  + [w[:110] for w in o.warnings or []]))
                print(f"  x{speed:<4g} {line.kind:8s} {line.name:24s} {line.text[:40]!r}: {what}")
    print(f"False alarms on right transcripts: {len(todo)} lines x {len(speeds)} speed(s) "
          f"({', '.join(f'{s:g}' for s in speeds)}); every refusal, unspoken word, unscripted second and "
          "warning is a false alarm")
    print("by kind of line:")
    table(outcomes, lambda o: o.line.kind)
    print("by source (mfa and timit tuned on; emodb and other held out):")
    table(outcomes, lambda o: o.line.source + ("" if o.line.source in TUNED else " (held out)"))
    print("by speed:")
    table(outcomes, lambda o: f"x{o.speed:g}")
    if args.hits:
        import offscript
        offscript.another_line()


if __name__ == "__main__":
    main()
