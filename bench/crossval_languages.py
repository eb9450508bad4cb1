"""Cross-validated figures of the boundary offsets of words read from IPA, tuned on VoxAngeles.

``data/timing.json`` ``boundary_ipa`` holds the offsets of the boundaries of words read from IPA
(another language, or ``/.../``): the English ones (``boundary.shift``) but for four pairs, and none
after silence (``alignment/onsets.py`` places a word's first phone).  The four were chosen on
``bench/languages.py``'s words by tuning each half of its languages alone (from the English offsets,
5 ms steps, pairs seen 20 times, a step kept when it gains two starts within 20 ms) and keeping the
changes both halves made, at the smaller size.  This bench re-runs that procedure, and others, on
languages it never saw, and prints what they carry over.  It changes nothing in the engine.

Reads ``../shared/data/voxangeles`` (skips cleanly without it): the words ``bench/languages.py``
scores (1,110 in 36 languages with usable words), each given to the engine as an IPA transcript
(``/padjan/``) and aligned once with the whole pipeline (``analyze``, as ``bench/languages.py`` does),
its boundaries recorded before the correction (``bench/crossval.py``; the onsets are placed before
it, and stay).  The reference phones are matched to the aligned ones as ``bench/languages.py``
matches them (an edit-distance alignment; a substituted phone counts, a dropped one is a miss, and so
are the phones of a word the engine refused).  Any table is then applied offline; the first lines say
how many starts that puts elsewhere than the engine's own run under timing.json's tables (none), and
give timing.json's figures, which are bench/languages.py's without the boundary-correction model
that follows the offsets (``data/boundary_model.json``, fitted on English; it is left out here, as
in ``bench/crossval.py``, and adds 2.2 points within 20 ms on these words).

The procedures (the English table stays timing.json's; every ``start>`` pair stays at 0):

* **English offsets as they are**: ``boundary.shift``, nothing tuned on these words;
* **timing.json's way**: from the English offsets, each pair seen 20 times (alone, the others at
  their English offsets) moved in 5 ms steps while a step gains two starts within 20 ms, on each half
  of the training languages (every other one, alphabetically) alone; the changes both halves made in
  the same direction kept, at the smaller size;
* the same on all the training languages at once (no halves), and in 10 ms steps;
* **TIMIT's way** (``bench/crossval.py``): one default offset, then per pair seen 5 (or 20) times the
  offset on a 5 ms grid with the most starts within 20 ms (then 40 ms);
* **no offsets**.

Splits: **in-sample** (tuned and scored on all the languages), **halves** (tuned on
``bench/languages.py``'s half A, scored on B, and the other way, pooled), **1 family out** (tuned on
the languages of every other family, scored on this one's, pooled over the 10 families of the table
``FAMILY``, Glottolog's top level; Atlantic-Congo holds 24 of the 36), **1 language out** (36 folds).
Each cell: the share of reference phones whose matched start lies within 20 ms (then 40 ms), as
``bench/languages.py`` counts them.  The same on the words with a raw Montreal Forced Aligner
alignment, beside that alignment's own figure.  The first table adds the optimism of the in-sample
figure (in-sample less one family out) and each procedure's one-family-out difference from
timing.json's way, with its standard error over words drawn again with replacement.  Then per family,
timing.json's way tuned on all and without the family, beside timing.json's ``boundary_ipa`` and the
English offsets; and ``boundary_ipa`` beside the table timing.json's way makes today on all the
languages.  ``--offsets`` prints the tables the procedures make on all the languages.

    .venv/bin/python bench/crossval_languages.py        # 2-4 minutes (2 cores)
    .venv/bin/python bench/crossval_languages.py --limit 5 --offsets
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass

import numpy as np

from common import need_data
from crossval import (Batch, Line, Procedure, bootstrap_se, check, fold_masks, recording, line_from,
                      pair_counts, prepare, rows, scored, shipped_tables, tables, tune)
from languages import base_phone, closes_lips, match_starts, read_tiers, usable_words

from addon.engine import LineSettings, analyze
from addon.engine import audio as audio_mod
from addon.engine.alignment.verify import edit_path
from addon.engine.errors import LipSyncError
from addon.engine.pauses import settings as timing_settings

#: The top-level family (Glottolog) of each language of VoxAngeles, by ISO 639-3 code.
FAMILY = {
    "ace": "Austronesian", "bhk": "Austronesian", "sbc": "Austronesian",
    "aeb": "Afro-Asiatic", "bwr": "Afro-Asiatic",
    "hni": "Sino-Tibetan", "njm": "Sino-Tibetan",
    "bfq": "Dravidian", "brv": "Austroasiatic", "cji": "Nakh-Daghestanian", "col": "Salishan",
    "led": "Central Sudanic", "kri": "Creole (Krio)",
    **dict.fromkeys(("aka", "bem", "bfd", "bin", "bsq", "cpn", "dag", "deg", "dyo", "efi", "ema", "ffm",
                     "fub", "gaa", "gwx", "idu", "its", "kub", "kye", "lar", "lgq", "ozm", "run", "tsw"),
                    "Atlantic-Congo"),
}


@dataclass(frozen=True)
class Climb:
    """timing.json's way for words read from IPA (see the module's docstring)."""
    name: str
    step: float = 0.005
    min_count: int = 20
    min_gain: int = 2
    halves: bool = True


def load(root, limit: int) -> tuple[list[Line], list]:
    """Every usable word aligned without correction, as a :class:`Line`; and per line the raw MFA
    errors of its reference phones (inf: not matched), or None where it has no usable MFA
    alignment."""
    lines, mfa = [], []
    folders = sorted((root / "audited").iterdir())
    with recording() as calls:
        for k, folder in enumerate(folders):
            for grid, word, phones in usable_words(folder, limit):
                snd = audio_mod.load(grid.with_suffix(".wav"))
                groups = {"language": folder.name, "family": FAMILY.get(folder.name, folder.name)}
                calls.clear()
                try:
                    al = analyze(snd, f"/{word}/", LineSettings.of(fps=100)).alignment
                except LipSyncError as exc:
                    print(f"  failed: {grid.relative_to(root)}: {exc}", file=sys.stderr)
                    lines.append(Line(grid.stem, groups, snd, [], [], [],
                                      [(None, a, closes_lips(label)) for _, a, _, label in phones], []))
                else:
                    hyp = [p.phone for p in al.phones]
                    matched = {i: j for i, j, _same in edit_path([p for p, *_ in phones], hyp)}
                    refs = [(matched.get(i), a, closes_lips(label)) for i, (_, a, _, label) in enumerate(phones)]
                    lines.append(line_from(grid.stem, groups, snd, al, list(calls), refs))
                mfa.append(raw_mfa(root / "mfa" / folder.name / grid.name, phones))
            print(f"  {folder.name}: {k + 1} of {len(folders)} languages aligned", flush=True)
    langs = sorted({line.groups["language"] for line in lines})
    for line in lines:
        line.groups["half"] = "AB"[langs.index(line.groups["language"]) % 2]
    return lines, mfa


def raw_mfa(path, phones) -> np.ndarray | None:
    """|start error| of each reference phone in the raw MFA alignment (inf: not matched), as
    bench/languages.py measures it; None without a usable one."""
    if not path.is_file():
        return None
    try:
        got = [(base_phone(t), a) for a, b, t in read_tiers(path).get("phones", []) if t]
    except (OSError, UnicodeDecodeError, AttributeError):
        return None
    if not got or any(p is None for p, _ in got):
        return None
    return np.array([abs(e) if e is not None else np.inf for e in match_starts([(p, a) for p, a, _, _ in phones], got)])


def climb(batch: Batch, train: np.ndarray, proc: Climb, english: tuple, frozen: dict) -> dict:
    """The IPA table ``proc`` makes from the ``train`` lines, from the English offsets."""
    table0, default = english
    base = {**table0, **frozen}

    def one(mask) -> dict:
        n = pair_counts(batch, mask, ipa=True)
        out = dict(base)
        for pair in sorted(n):
            if pair in frozen or n[pair] < proc.min_count:
                continue
            at = base.get(pair, default)

            def score(o, pair=pair):
                tabs = tables({**base, pair: o}, default, english, True)
                return int(batch.counts(*rows(batch, [tabs]), mask)[0] // 100000)

            now = score(at)
            up, down = score(round(at + proc.step, 4)), score(round(at - proc.step, 4))
            way = proc.step if up >= down else -proc.step
            while True:
                nxt = score(round(at + way, 4))
                if nxt - now < proc.min_gain:
                    break
                at, now = round(at + way, 4), nxt
            out[pair] = at
        return out

    if not proc.halves:
        return tables(one(train), default, english, True)
    langs = sorted({line.groups["language"] for line, t in zip(batch.lines, train) if t})
    halves = [np.array([t and line.groups["language"] in langs[h::2] for line, t in zip(batch.lines, train)])
              for h in (0, 1)]
    a, b = one(halves[0]), one(halves[1])
    out = dict(base)
    for pair in set(a) | set(b):
        e = base.get(pair, default)
        da, db = a.get(pair, default) - e, b.get(pair, default) - e
        if da * db > 0:
            out[pair] = round(e + np.sign(da) * min(abs(da), abs(db)), 4)
    return tables(out, default, english, True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--limit", type=int, default=0, help="at most N words per language")
    ap.add_argument("--offsets", action="store_true", help="print the tables the procedures make on all")
    args = ap.parse_args()
    root = need_data() / "voxangeles"
    if not root.is_dir():
        print(f"skipped: {root} is not here")
        return
    t0 = time.perf_counter()
    timing = timing_settings()
    cfg, ipa_cfg = timing["boundary"], timing["boundary_ipa"]
    lines, mfa = load(root, args.limit)
    for line in lines:
        prepare(line, cfg)
    batch = Batch(lines, decimals=None)
    shipped = shipped_tables(cfg, ipa_cfg)
    english = shipped[False]
    frozen = {p: o for p, o in shipped[True][0].items() if p.startswith("start>")}
    err = batch.errors(*rows(batch, [shipped]))[0]
    half_a = np.array([line.groups["half"] == "A" for line in lines])
    on_a = half_a[batch.rline]
    print(f"VoxAngeles: {len(lines)} words in {len({line.groups['language'] for line in lines})} languages, "
          f"{len({line.groups['family'] for line in lines})} families, aligned once in "
          f"{time.perf_counter() - t0:.0f} s; "
          f"{len(batch.rline)} reference phones; {sum(not line.words for line in lines)} words refused, "
          f"{sum(line.factor != 1 for line in lines)} aligned on a slowed copy, "
          f"{sum(not line.exact for line in lines if line.words)} whose phones were moved after the correction "
          "(left as they are)")
    print(f"the correction re-applied offline with timing.json's tables: {check(batch, shipped)} of "
          f"{len(batch.a)} starts differ from the engine's")
    print(f"timing.json's tables scored here, within 40 / 20 ms: A {100 * np.mean(err[on_a] <= 0.04):.1f} / "
          f"{100 * np.mean(err[on_a] <= 0.02):.1f} %, B {100 * np.mean(err[~on_a] <= 0.04):.1f} / "
          f"{100 * np.mean(err[~on_a] <= 0.02):.1f} %, all {100 * np.mean(err <= 0.04):.1f} / "
          f"{100 * np.mean(err <= 0.02):.1f} % (bench/languages.py's figures)")

    t1 = time.perf_counter()
    everyone = np.ones(len(lines), bool)
    splits = {"halves": {"A": half_a, "B": ~half_a}, "1 family out": fold_masks(batch, "family"),
              "1 language out": fold_masks(batch, "language")}
    procs = {
        "no offsets": lambda train: tables(dict(frozen), 0.0, english, True),
        "English offsets as they are": lambda train: tables({**english[0], **frozen}, english[1], english, True),
        "timing.json's way (halves agree)": Climb("halves"),
        "the same, all training languages": Climb("all", halves=False),
        "the same, 10 ms steps": Climb("10 ms", step=0.01),
        "TIMIT's way, n>=5": Procedure("timit"),
        "TIMIT's way, n>=20": Procedure("timit 20", min_count=20),
        "TIMIT's way, n>=20, gain>=2": Procedure("timit 20 2", min_count=20, min_gain=2),
    }
    results, made = {}, {}
    for name, proc in procs.items():
        if isinstance(proc, Climb):
            def run(train, proc=proc):
                return climb(batch, train, proc, english, frozen)
        elif isinstance(proc, Procedure):
            def run(train, proc=proc):
                return tune(batch, train, proc, fixed=english, ipa=True, frozen=frozen)
        else:
            run = proc
        made[name] = run(everyone)
        results[name] = {"in-sample": batch.errors(*rows(batch, [made[name]]))[0],
                         **{s: scored(batch, folds, run) for s, folds in splits.items()}}
        print(f"  {name}: tuned and scored ({time.perf_counter() - t1:.0f} s)", flush=True)
    results["timing.json's boundary_ipa (tuned on all)"] = {"in-sample": err}

    has_mfa = np.concatenate([np.full(len(line.refs), m is not None) for line, m in zip(lines, mfa)]) \
        if lines else np.zeros(0, bool)
    mfa_err = np.concatenate([m if m is not None else np.full(len(line.refs), np.inf)
                              for line, m in zip(lines, mfa)]) if lines else np.zeros(0)
    main_name = "timing.json's way (halves agree)"
    for where, mask in (("all the words", np.ones(len(batch.rline), bool)),
                        (f"the {len({line.name for line, m in zip(lines, mfa) if m is not None})} words with a "
                         "raw MFA alignment", has_mfa)):
        for limit in (0.02, 0.04):
            print(f"\nreference phones whose start is within {1000 * limit:.0f} ms ({mask.sum()} phones of {where})")
            print(f"{'procedure':42s} " + " ".join(f"{s:>14s}" for s in ["in-sample", *splits])
                  + (f" {'optimism':>8s} {'1 family out vs main':>21s}" if limit == 0.02 else ""))
            base = results[main_name]["1 family out"] <= limit
            for name, res in results.items():
                cells = [f"{np.mean(res[s][mask] <= limit):14.3f}" if s in res else f"{'':14s}"
                         for s in ["in-sample", *splits]]
                out = f"{name:42s} " + " ".join(cells)
                if limit == 0.02 and "1 family out" in res:
                    diff = (res["1 family out"] <= limit).astype(float) - base
                    inside = np.mean(res["in-sample"][mask] <= limit) - np.mean(res["1 family out"][mask] <= limit)
                    out += (f" {inside:+8.3f} {diff[mask].mean():+12.3f} +- "
                            f"{bootstrap_se(batch, diff, mask=mask):.3f}")
                print(out)
            if where != "all the words":
                print(f"{'raw MFA (english_mfa, before correction)':42s} {np.mean(mfa_err[mask] <= limit):14.3f}")
    print(f"(tuning and scoring: {time.perf_counter() - t1:.0f} s)")

    fam = fold_masks(batch, "family")
    print("\nper family, within 20 ms: timing.json's way tuned on all / without the family; timing.json's "
          "boundary_ipa; English offsets as they are")
    print(f"{'family':20s} {'langs':>5s} {'phones':>6s} {'all':>6s} {'out':>6s} {'shipped':>7s} {'English':>7s}")
    res, plain = results[main_name], results["English offsets as they are"]["in-sample"]
    for f, m in fam.items():
        r = m[batch.rline]
        print(f"{f:20s} {len({line.groups['language'] for line, x in zip(lines, m) if x}):5d} {r.sum():6d} "
              f"{np.mean(res['in-sample'][r] <= 0.02):6.3f} {np.mean(res['1 family out'][r] <= 0.02):6.3f} "
              f"{np.mean(err[r] <= 0.02):7.3f} {np.mean(plain[r] <= 0.02):7.3f}")

    ship_t, ship_d = shipped[True]
    n_all = pair_counts(batch, everyone, ipa=True)
    print(f"\nboundary_ipa beside {main_name!r} re-run on all the languages, ms (English: boundary.shift)")
    print(f"{'pair':20s} {'n':>5s} {'English':>7s} {'shipped':>7s} {'re-run':>6s}")
    rerun_t, rerun_d = made[main_name][True]
    for pair in sorted(p for p in set(n_all) | set(ship_t) if n_all[p] >= 20 or ship_t.get(p) != english[0].get(p)):
        print(f"{pair:20s} {n_all[pair]:5d} {1000 * english[0].get(pair, english[1]):+7.0f} "
              f"{1000 * ship_t.get(pair, ship_d):+7.0f} {1000 * rerun_t.get(pair, rerun_d):+6.0f}")
    if args.offsets:
        for name, tabs in made.items():
            t, d = tabs[True]
            print(f"{name} on all: default {1000 * d:+.1f} ms; "
                  + ", ".join(f"{p} {1000 * o:+.1f}" for p, o in sorted(t.items()) if not p.startswith("start>")))
    print(f"\ntotal {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
