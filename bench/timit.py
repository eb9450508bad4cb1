"""English phone boundaries against TIMIT's hand labels.

Reads ``../shared/data/timit_nltk`` (skips cleanly without it): 61 read
sentences from 8 speakers with hand-verified phone segmentations.  The
speakers are split in two halves, each with two women and two men from four
dialect regions: the *development* half, on which the aligner's timing
constants (``data/timing.json``) were tuned, and the *held-out* half, which
checks them.

Each sentence is aligned from its transcript (``align_audio``).  TIMIT's
labels become ARPAbet: a stop's closure (``bcl``, ``pcl``, ...) belongs to
the stop (or affricate) after it, so a stop starts where its closure starts
(and a closure with no release is the stop); silences (``h#``, ``pau``, ``epi``) and the
glottal stop ``q`` are not scored; the reduced and syllabic labels count as
the phones a dictionary writes for them (``ix`` as IH or AH, ``dx`` as D or
T, ``en`` as N, ...).  Aligned and hand phones are matched in order on a
minimum edit path; the error of a matched phone is its aligned start minus
the hand start (rounded to 0.1 ms).

Printed per half, overall and per class (bilabial /p b m/, labiodental
/f v/, vowel, other), and for the closure onset of /p b m/ (the start of
/m/, and of /p b/ from their closure): the matched phone starts, the share
within 20 ms and 40 ms, and the median signed error (negative: early).
With ``--events`` also the event score of the animation (see
``event_score``), and in every case the sentences whose alignment failed
or was partly estimated.

    .venv/bin/python bench/timit.py                 # both halves
    .venv/bin/python bench/timit.py --half dev --limit 3
    .venv/bin/python bench/timit.py --events
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from common import events, match, need_data
from addon.engine import audio as audio_mod
from addon.engine.alignment import align_audio
from addon.engine.language.phonemes import VOWELS

RATE = 16000
DEV = ("dr1-mcpm0", "dr2-faem0", "dr3-falk0", "dr4-maeb0")      # 32 sentences
HELD = ("dr1-fvmh0", "dr2-marc0", "dr3-madc0", "dr4-falr0")     # 29 sentences
SILENT = {"h#", "pau", "epi", "q"}
CLOSURES = {"bcl", "dcl", "gcl", "pcl", "tcl", "kcl"}
#: TIMIT labels that are not ARPAbet: the phones a dictionary may write for them.
TIMIT = {"ax": {"AH"}, "ax-h": {"AH"}, "axr": {"ER"}, "ix": {"IH", "AH"}, "ux": {"UW"}, "dx": {"D", "T"},
         "nx": {"N"}, "en": {"N"}, "em": {"M"}, "eng": {"NG"}, "el": {"L"}, "hv": {"HH"}}
CLASSES = ("bilabial", "labiodental", "vowel", "other")


def _releases(closure: str, label: str) -> bool:
    """Whether ``label`` releases ``closure``: its stop, or the affricate
    made from it (``tcl ch``, ``dcl jh``)."""
    return label == closure[0] or (closure, label) in (("tcl", "ch"), ("dcl", "jh"))


def hand_phones(phn: Path) -> list[SimpleNamespace]:
    """The hand phones: ``phones`` (the ARPAbet labels it may match),
    ``start`` (s) and ``closure`` (True when a /p b/ starts at its closure)."""
    rows = [line.split() for line in phn.read_text().splitlines() if line.strip()]
    out = []
    for k, (a, b, lab) in enumerate(rows):
        start, closure = int(a) / RATE, False
        if lab in SILENT:
            continue
        if lab in CLOSURES:
            if k + 1 < len(rows) and _releases(lab, rows[k + 1][2]):
                continue            # the release after it carries the stop (below)
            lab, closure = lab[0], True
        elif k > 0 and rows[k - 1][2] in CLOSURES and _releases(rows[k - 1][2], lab):
            start, closure = int(rows[k - 1][0]) / RATE, True
        out.append(SimpleNamespace(phones=TIMIT.get(lab, {lab.upper()}), label=lab, start=start,
                                   end=int(b) / RATE, closure=closure))
    return out


def match_sets(hyp: list[str], ref: list[set[str]]) -> list[tuple[int, int]]:
    """Pairs (i, j) with ``hyp[i]`` in ``ref[j]`` on a minimum edit path."""
    return match(hyp, ref, same=lambda h, r: h in r)


def phone_class(phone: str) -> str:
    if phone in ("P", "B", "M"):
        return "bilabial"
    if phone in ("F", "V"):
        return "labiodental"
    return "vowel" if phone in VOWELS else "other"


def sentences(data: Path, speakers, limit: int | None):
    for spk in speakers:
        for wav in sorted((data / spk).glob("*.wav"))[:limit]:
            text = " ".join(wav.with_suffix(".txt").read_text().split()[2:])
            yield f"{spk}/{wav.stem}", wav, text, hand_phones(wav.with_suffix(".phn"))


def event_score(al, ref, snd) -> list[bool]:
    """The speech events the animation shows (as bench/offscript.py scores
    them): every hand vowel (the mouth open, some viseme at 0.2 or more, on
    at least half of its frames), every hand /p b m/ (the lips closed,
    closure 0.5 or more, on a frame within 30 ms of it) and every pause of
    0.3 s or more between hand phones (the mouth at rest on at least half of
    it); rendered at 100 fps from the alignment, neutral preset."""
    from addon.engine.pipeline import analyze
    from addon.engine.settings import LineSettings

    r = analyze(snd, settings=LineSettings.of(fps=100), alignment=al)
    return events(r, [(p.phones, p.start, p.end) for p in ref]).hits


def run(data: Path, speakers, limit, events: bool, verbose: bool) -> dict:
    rows = []      # (class, error s, pbm closure onset)
    hits: list[bool] = []
    failed, estimated, n_ref, audio_s, wall = [], [], 0, 0.0, 0.0
    for name, wav, text, ref in sentences(data, speakers, limit):
        snd = audio_mod.load(wav)
        t0 = time.perf_counter()
        try:
            al = align_audio(snd, text)
        except Exception as exc:  # noqa: BLE001 - a failure is a figure here, not a stop
            failed.append(f"{name}: {exc}")
            continue
        wall += time.perf_counter() - t0
        audio_s += snd.duration
        if al.n_estimated:
            estimated.append(f"{name}: {al.n_estimated} phones estimated")
        hyp = [p.phone for p in al.phones]
        pairs = match_sets(hyp, [p.phones for p in ref])
        n_ref += len(ref)
        for i, j in pairs:
            ph = al.phones[i].phone
            err = round(al.phones[i].start - ref[j].start, 4)
            rows.append((phone_class(ph), err, ph in ("P", "B", "M")))
            if verbose and abs(err) > 0.04:
                print(f"  {name} {ph:3s} hand {ref[j].start:6.3f} ours {al.phones[i].start:6.3f} {err * 1000:+6.0f} ms")
        if events:
            hits += event_score(al, ref, snd)
    return {"rows": rows, "hits": hits, "failed": failed, "estimated": estimated, "n_ref": n_ref,
            "rt": wall / max(audio_s, 1e-9)}


def line(label: str, err: np.ndarray) -> str:
    if not len(err):
        return f"{label:22s} {0:6d}"
    a = np.abs(err)
    return (f"{label:22s} {len(err):6d} {np.mean(a <= 0.02):7.3f} {np.mean(a <= 0.04):7.3f} "
            f"{np.median(err) * 1000:+8.1f}")


def report(title: str, res: dict) -> None:
    rows = res["rows"]
    err = np.array([e for _, e, _ in rows])
    print(f"\n{title}: {res['n_ref']} hand phones, {len(rows)} matched, alignment {res['rt']:.3f} x real time")
    print(f"{'':22s} {'starts':>6s} {'<=20ms':>7s} {'<=40ms':>7s} {'median':>8s}")
    print(line("all", err))
    for c in CLASSES:
        print(line(c, np.array([e for k, e, _ in rows if k == c])))
    print(line("/p b m/ closure onset", np.array([e for _, e, pbm in rows if pbm])))
    if res["hits"]:
        print(f"event score {np.mean(res['hits']):.3f} ({len(res['hits'])} events)")
    print(f"failures {len(res['failed'])}, partly estimated {len(res['estimated'])}")
    for f in res["failed"] + res["estimated"]:
        print("  " + f)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--half", choices=("dev", "held", "both"), default="both")
    ap.add_argument("--limit", type=int, default=None, help="sentences per speaker (default: all)")
    ap.add_argument("--events", action="store_true", help="also the animation's event score")
    ap.add_argument("--verbose", action="store_true", help="list the starts more than 40 ms off")
    args = ap.parse_args()
    data = need_data() / "timit_nltk"
    halves = {"dev": DEV, "held": HELD}
    for h in (("dev", "held") if args.half == "both" else (args.half,)):
        res = run(data, halves[h], args.limit, args.events, args.verbose)
        report({"dev": "development speakers " + ", ".join(DEV),
                "held": "held-out speakers " + ", ".join(HELD)}[h], res)


if __name__ == "__main__":
    main()
