"""Alignment of words in many languages, written in IPA, against hand-corrected phone boundaries.

Reads ``../shared/data/voxangeles`` (one spoken word per file in 37 languages, each with a TextGrid whose
``words`` tier holds the word's IPA and whose ``phones`` tier its IPA phones with hand-corrected
boundaries; CC BY-NC 4.0, read in place, never copied).  Each word is given to the engine as an IPA
transcript (``/padjan/``) and aligned with the whole pipeline (:func:`addon.engine.analyze`, 100 fps).
Prints:

* phone starts within 40 ms and 20 ms of the reference: the reference phones (their base symbols, marks
  and length dropped, each read by ``ipa.to_arpabet``) are matched in order to the aligned phones by an
  edit-distance alignment (a substituted phone still counts as matched, a dropped one as a miss);
* lips closed: the share of reference /p b m/ (and /ɓ/, /mː/ ...) with a frame whose closure is at
  least 0.5 within 30 ms of the phone;
* failures: words the engine refused, and words whose phones were placed by estimate;
* speed: seconds of audio per second of work (real-time factor);
* the same phone-start figures for the raw Montreal Forced Aligner alignments of the set (``mfa/``),
  measured the same way, so that the two can be compared;
* the figures of two halves of the languages, A and B (every other one of the languages with usable
  words, in alphabetical order): a setting tuned on A is judged on B, whose languages it never saw.

    .venv/bin/python bench/languages.py [--limit N] [--lang ISO ...] [--per-language] [--no-stand-ins]
"""

from __future__ import annotations

import argparse
import re
import sys
import time
import unicodedata
from collections import defaultdict
from pathlib import Path

import numpy as np

from common import need_data

from addon.engine import LineSettings, analyze
from addon.engine import audio as audio_mod
from addon.engine.alignment.verify import edit_path
from addon.engine.errors import LipSyncError
from addon.engine.language import ipa
from addon.engine.language.text import plain_ipa

_INTERVAL = re.compile(r'xmin = ([\d.eE+-]+)\s*\n\s*xmax = ([\d.eE+-]+)\s*\n\s*text = "((?:[^"]|"")*)"')


def read_tiers(path: Path) -> dict[str, list[tuple[float, float, str]]]:
    text = path.read_text(encoding="utf-8")
    tiers = {}
    for block in re.split(r'\n\s*item \[\d+\]:', text)[1:]:
        name = re.search(r'name = "([^"]*)"', block).group(1)
        tiers[name] = [(float(a), float(b), t.replace('""', '"').strip()) for a, b, t in _INTERVAL.findall(block)]
    return tiers


def base_phone(label: str) -> str | None:
    """The first engine phone of a reference label (None: not IPA, or silence)."""
    try:
        ph = ipa.to_arpabet(plain_ipa(label))
    except ipa.UnknownSymbol:
        return None
    return ph[0] if ph else None


def closes_lips(label: str) -> bool:
    """A bilabial stop or nasal (p b m ɓ ...), marks and length dropped."""
    base = unicodedata.normalize("NFD", label)[:1]
    return base in ("p", "b", "m", "ɓ")


def match_starts(ref: list[tuple[str, float]], hyp: list[tuple[str, float]]) -> list[float | None]:
    """For each reference phone the start error (s) of the aligned phone it is matched to (None: none),
    by an edit-distance alignment of the two phone sequences (a substituted phone counts as matched)."""
    out: list[float | None] = [None] * len(ref)
    for i, j, _same in edit_path([p for p, _ in ref], [p for p, _ in hyp]):
        out[i] = hyp[j][1] - ref[i][1]
    return out


def reference(tiers) -> tuple[str, list[tuple[str, float, float, str]]] | None:
    words = [t for a, b, t in tiers.get("words", []) if t]
    phones = [(base_phone(t), a, b, t) for a, b, t in tiers.get("phones", []) if t]
    if len(words) > 1 or not phones or any(p is None for p, *_ in phones):
        return None
    # A word tier left empty: the word is its phones.
    return (words[0] if words else "".join(t for *_, t in phones)), phones


def usable_words(folder: Path, limit: int = 0):
    """(TextGrid, word, reference phones) of every word of one language's folder this bench scores
    (a single word with IPA phones and its .wav beside it); at most ``limit`` TextGrids read (0: all)."""
    grids = sorted(folder.glob("*.TextGrid"))
    for grid in grids[:limit] if limit else grids:
        ref = reference(read_tiers(grid))
        if ref is not None and grid.with_suffix(".wav").is_file():
            yield grid, ref[0], ref[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--limit", type=int, default=0, help="at most N words per language")
    ap.add_argument("--lang", nargs="*", help="only these languages (ISO 639-3 folder names)")
    ap.add_argument("--per-language", action="store_true", help="print the figures of each language")
    ap.add_argument("--no-stand-ins", action="store_true",
                    help="align every phone as the phone it shows (no acoustic stand-ins), to measure them")
    args = ap.parse_args()
    if args.no_stand_ins:
        from addon.engine.language import pronounce

        pronounce.stand_ins = dict
    root = need_data() / "voxangeles"
    if not root.is_dir():
        print(f"skipped: {root} is not here")
        return
    stats = defaultdict(lambda: {"errors": [], "mfa": [], "closures": [], "words": 0, "failed": 0,
                                 "estimated": 0, "audio": 0.0, "work": 0.0})
    unusable = 0
    for folder in sorted((root / "audited").iterdir()):
        if args.lang and folder.name not in args.lang:
            continue
        grids = sorted(folder.glob("*.TextGrid"))
        if args.limit:
            grids = grids[:args.limit]
        for grid in grids:
            ref = reference(read_tiers(grid))
            wav = grid.with_suffix(".wav")
            if ref is None or not wav.is_file():
                unusable += 1
                continue
            word, phones = ref
            s = stats[folder.name]
            s["words"] += 1
            snd = audio_mod.load(wav)
            t0 = time.perf_counter()
            try:
                result = analyze(snd, f"/{word}/", LineSettings.of(fps=100))
            except LipSyncError as exc:
                s["failed"] += 1
                s["work"] += time.perf_counter() - t0
                s["errors"] += [None] * len(phones)
                print(f"failed: {grid.relative_to(root)}: {exc}", file=sys.stderr)
                continue
            s["work"] += time.perf_counter() - t0
            s["audio"] += snd.duration
            al = result.alignment
            s["estimated"] += any(w.estimated for w in al.words)
            hyp = [(p.phone, p.start) for p in al.phones]
            s["errors"] += match_starts([(p, a) for p, a, _, _ in phones], hyp)
            for _p, a, b, label in phones:
                if closes_lips(label):
                    near = (result.times >= a - 0.03) & (result.times <= b + 0.03)
                    s["closures"].append(bool(np.any(result.closure[near] >= 0.5)))
            mfa = root / "mfa" / folder.name / grid.name
            if mfa.is_file():
                try:
                    got = [(base_phone(t), a) for a, b, t in read_tiers(mfa).get("phones", []) if t]
                except (OSError, UnicodeDecodeError, AttributeError):
                    got = []
                if got and all(p is not None for p, _ in got):
                    s["mfa"] += match_starts([(p, a) for p, a, _, _ in phones], got)

    def figures(rows):
        err = [e for r in rows for e in r["errors"]]
        ok = np.array([e is not None for e in err])
        absd = np.array([abs(e) if e is not None else np.inf for e in err])
        mfa = np.array([abs(e) if e is not None else np.inf for r in rows for e in r["mfa"]])
        clo = [c for r in rows for c in r["closures"]]
        audio = sum(r["audio"] for r in rows)
        work = sum(r["work"] for r in rows)
        return (f"{sum(r['words'] for r in rows):5d} words {len(err):5d} phones | starts within 40 ms "
                f"{100 * np.mean(absd <= 0.04):5.1f} %, 20 ms {100 * np.mean(absd <= 0.02):5.1f} % "
                f"(median {1000 * np.median(absd[ok]) if ok.any() else float('nan'):.0f} ms) | "
                f"/p b m/ closed {100 * np.mean(clo) if clo else float('nan'):5.1f} % of {len(clo)} | "
                f"failed {sum(r['failed'] for r in rows)}, estimated {sum(r['estimated'] for r in rows)} | "
                f"{work / max(audio, 1e-9):.3f}x real time | raw MFA: 40 ms {100 * np.mean(mfa <= 0.04):5.1f} %, "
                f"20 ms {100 * np.mean(mfa <= 0.02):5.1f} %")

    if args.per_language:
        for lang in sorted(stats):
            print(f"{lang:4s} {figures([stats[lang]])}")
    # Two halves of the languages (every other one, in alphabetical order, of the 36 with usable words):
    # settings chosen on one half are checked on the other, whose languages they never saw.
    if not args.lang:
        for half, name in ((0, "A"), (1, "B")):
            print(f"{name}    {figures([stats[lang] for lang in sorted(stats)[half::2]])}")
    print(f"all  {figures(list(stats.values()))}")
    print(f"({unusable} words left out: several words, no phones, or phones that are not IPA)")


if __name__ == "__main__":
    main()
