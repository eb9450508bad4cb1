"""Cross-validated figures of the boundary offsets tuned on TIMIT: do they carry over to other speakers?

``data/timing.json`` ``boundary.shift`` holds an offset per pair of phone classes
(:mod:`addon.engine.alignment.boundaries`), chosen on the four development speakers of
``bench/timit.py``: per pair seen at least five times there, in 5 ms steps, the offset that puts the
most phone starts within 20 ms of the hand labels (then within 40 ms).  Scored on the speakers it was
chosen on, such a table flatters itself; this bench measures by how much, and which way of tuning
carries over best to speakers the tuning never saw.  It changes nothing in the engine.  The
boundary-correction model the aligner applies after the offsets (``data/boundary_model.json``) is
left out here, so the figures are the table's alone; ``bench/boundary_model.py`` cross-validates the
model on top of it.

Reads ``../shared/data/timit_nltk`` (skips cleanly without it): 61 sentences, 8 speakers, 2 in each
of the dialect regions 1-4.  Each sentence is aligned once, as the engine aligns it (``align_audio``,
as ``bench/timit.py`` does), with the engine's ``shift_boundaries`` wrapped for the run by a recorder
that keeps every boundary as it was before the correction (no offsets, no /t/ rule), with the audio
it was corrected on.  The hand phones are matched to the aligned ones as ``bench/timit.py`` matches
them, and each scored start is kept with its class pair and its hand start.  The correction is then
re-applied offline under any table (the same steps as ``shift_boundaries``: the /t/ rule,
``min_phone``, the voice onset after silence; many tables at once, with numpy), so a table is scored
without aligning again.  The first lines say how many of the 1,959 starts the offline correction
puts elsewhere than the engine's own run under timing.json's table (none), and that table's figures,
which are bench/timit.py's.  (The correction stays on during the run: what the aligner does after it,
a line slowed and aligned again when its phones are crowded, looks at the corrected phones.)

A tuning *procedure* makes a table from some sentences: first one offset for every boundary (the
default), then per pair of classes seen at least ``n`` times (scored boundaries) an offset on a grid
of ``step`` from -60 to +60 ms, each pair's alone with the others at the default, the most starts
within 20 ms, then 40 ms, winning (a tie: the offset nearest the default).  Variants: the pairs tuned
again with the others at their offsets (3 passes), coarser steps, more boundaries needed (``n``), an
offset kept only when it gains ``g`` starts within 20 ms over the default, each offset shrunk toward
the default by ``n / (n + k)``, one offset per class of the phone after (not per pair), one offset
for all, none.  Each procedure is tuned and scored on:

* **in-sample**: tuned on all 8 speakers, scored on them (what a figure on the tuning data says);
* **dev->dev**, **dev->held**: tuned on the development speakers, scored on them and on the held-out
  ones (bench/timit.py's split; timing.json's own table is scored there too);
* **1 speaker out**: tuned on 7 speakers, scored on the 8th, pooled over the 8;
* **1 region out**: tuned on the 6 speakers of three dialect regions, scored on the 2 of the fourth,
  pooled over the 4.

Three tables, one figure each: matched phone starts within 20 ms of the hand labels, within 40 ms,
and /p b m/ closure onsets within 40 ms (bench/timit.py's "closure" figure).  The first adds the
optimism of the in-sample figure (in-sample less leave-one-speaker-out) and each procedure's
leave-one-speaker-out difference from timing.json's way, with its standard error over sentences drawn
again with replacement.  Then timing.json's table less the one its way makes from today's alignments
of the development speakers, on each half (with its standard error); per speaker, timing.json's way
tuned on all 8, without the speaker and without its region, beside timing.json's table; the /t/ rule
with and without; and timing.json's offsets beside the ones the same procedure picks on today's
alignments.  ``--offsets`` prints every procedure's tables.

    .venv/bin/python bench/crossval.py              # about a minute (2 cores)
    .venv/bin/python bench/crossval.py --offsets
"""

from __future__ import annotations

import argparse
import copy
import time
from collections import Counter, defaultdict
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

from common import need_data
from timit import DEV, HELD, match_sets, sentences

from addon.engine import audio as audio_mod
from addon.engine.alignment import align_audio
from addon.engine.alignment.boundaries import _unreleased, boundary_class, voice_onset
from addon.engine.alignment.estimate import _clean
from addon.engine.pauses import settings as timing_settings

SPAN = 0.06          # offsets tried: -SPAN .. +SPAN


# --- one alignment, its boundaries before the correction ---------------------------------------

@contextmanager
def recording():
    """Alignments made inside are recorded as the engine corrects their boundaries: the engine's
    ``shift_boundaries`` is wrapped for the while; yields the list of (audio, words' phones before
    the correction, after it, estimated, from IPA) of its calls.  The boundary-correction model that
    follows the offsets (:mod:`addon.engine.alignment.refine`) is left out for the while: its own
    bench is bench/boundary_model.py."""
    from addon.engine.alignment import core

    calls: list = []
    from addon.engine.alignment import transcript

    saved, refine = core.shift_boundaries, transcript.refine_alignment

    def record(audio, result, estimated, cfg=None, from_ipa=None, ipa_cfg=None):
        before = copy.deepcopy(result)
        saved(audio, result, estimated, cfg, from_ipa=from_ipa, ipa_cfg=ipa_cfg)
        calls.append((audio, before, copy.deepcopy(result), list(estimated), from_ipa))

    core.shift_boundaries = record
    transcript.refine_alignment = lambda *args, **kw: None
    try:
        yield calls
    finally:
        core.shift_boundaries, transcript.refine_alignment = saved, refine


@dataclass
class Line:
    """One aligned clip, its boundaries before the correction, with what scoring needs."""
    name: str
    groups: dict                      # fold keys: speaker, region, language, family ...
    audio: object                     # the audio the engine corrected the boundaries on
    words: list                       # per word: [(phone, start, end)] before the correction, or None
    est: list                         # per word: not to be corrected (estimated, recognised)
    ipa: list                         # per word: read from IPA (boundary_ipa's table)
    refs: list                        # (flat phone index or None, reference start, scored as closure)
    shown: list                       # every phone's start as the engine gave it (corrected)
    exact: bool = True                # False: the phones were moved after the correction (left as given)
    factor: float = 1.0               # the phones were aligned on a copy slowed this much
    duration: float = 0.0
    # Filled by prepare():
    a: list = field(default_factory=list)
    fixed: dict = field(default_factory=dict)
    steps: list = field(default_factory=list)
    keep: float = 0.03


def line_from(name, groups, snd, al, calls, refs) -> Line:
    """The alignment ``al`` of ``snd`` (as the engine made it) as a :class:`Line`: the recorded call
    whose corrected phones are ``al``'s (on its time, or on a slowed copy's: :mod:`.tempo`) gives the
    phones before the correction, and the audio (a clip cut at the script's edges is silenced outside
    them) and phones (a word read from IPA is aligned, and corrected, by its stand-in phones, shown by
    its own) the engine corrected.  None matching (phones laid out again after the correction), the
    line keeps ``al``'s phones whatever the table."""
    from addon.engine.alignment import tempo

    flat = [(p.start, p.end) for p in al.phones]
    shown = [p.start for p in al.phones]
    for audio, before, after, est, from_ipa in reversed(calls):
        got = [(a, b) for ph in after if ph for _, a, b in _clean(ph)]
        if len(before) != len(al.words) or len(got) != len(flat):
            continue
        for factor in (1.0, tempo.SLOWER):
            if all(abs(min(al.duration, a / factor) - c) < 1e-9 and abs(min(al.duration, b / factor) - d) < 1e-9
                   for (a, b), (c, d) in zip(got, flat)):
                words = [_clean(ph) if ph else ph for ph in before]
                ipa = list(from_ipa) if from_ipa is not None else [False] * len(words)
                return Line(name, groups, audio, words, list(est), ipa, refs, shown, True, factor, al.duration)
    words: list = [None] * len(al.words)
    for p in al.phones:
        words[p.word_index] = (words[p.word_index] or []) + [(p.phone, p.start, p.end)]
    est = [True] * len(al.words)
    return Line(name, groups, snd, words, est, [False] * len(al.words), refs, shown, False, 1.0, al.duration)


# --- the engine's correction, offline ------------------------------------------------------------

def prepare(line: Line, cfg: dict) -> None:
    """What does not depend on the offsets: every phone's aligned start, the starts the /t/ rule
    fixes, and per boundary an offset may move: (phone, pair, IPA, phone before or None, lower
    bound after a pause, upper bound, voice onset after silence or None).  Mirrors
    ``boundaries.shift_boundaries``."""
    keep = float(cfg.get("min_phone", 0.03))
    unreleased = cfg.get("unreleased", {})
    held = _unreleased(line.words, line.est, set(unreleased.get("stops", ())),
                       set(unreleased.get("before", ())))
    line.a, line.fixed, line.steps = [], {}, []
    pos: dict = {}
    before = prev_end = None
    for wi, ph in enumerate(line.words):
        if not ph:
            continue
        for k, (p, a, b) in enumerate(ph):
            i = len(line.a)
            pos[(wi, k)] = i
            line.a.append(a)
            if line.est[wi]:
                before, prev_end = None, b
                continue
            joined = prev_end is not None and abs(prev_end - a) < 1e-6
            if joined and before is None:
                prev_end = b
                continue
            prev = line.words[before[0]][before[1]] if joined else None
            if (wi, k) in held:
                pass
            elif joined and before in held:
                line.fixed[i] = min(a, prev[1] + keep)
            else:
                left = boundary_class(prev[0] if prev else None, first=prev_end is None)
                right = boundary_class(p)
                if left and right:
                    lo = prev_end if prev_end is not None else 0.0
                    onset = (voice_onset(line.audio, a, b - keep, float(cfg.get("onset_rise", 20.0)),
                                         float(cfg.get("onset_below_peak", 10.0))) if left == "start" else None)
                    line.steps.append((i, f"{left}>{right}", line.ipa[wi], pos[before] if prev else None,
                                       lo, b - keep, onset))
            before, prev_end = (wi, k), b
    line.keep = keep


class Batch:
    """Many lines corrected at once, under many tables at once (one per row): the boundaries of
    every line are taken in turn, the k-th boundary of all lines together, as ``shift_boundaries``
    takes them one line at a time."""

    def __init__(self, lines: list[Line], decimals: int | None = 4):
        self.lines, self.decimals = lines, decimals
        self.pairs = sorted({st[1] for line in lines for st in line.steps})
        pid = {p: k for k, p in enumerate(self.pairs)}
        a, fixed, ranks = [], {}, defaultdict(list)
        ridx, rstart, rclo, rline = [], [], [], []
        self.first = []
        for n, line in enumerate(lines):
            base = len(a)
            self.first.append(base)
            a += line.a
            fixed.update({base + i: v for i, v in line.fixed.items()})
            for r, (i, pair, ipa, prev, lo, hi, onset) in enumerate(line.steps):
                ranks[r].append((base + i, -1 if prev is None else base + prev, lo, hi,
                                 np.nan if onset is None else onset, pid[pair], ipa))
            for i, ref, clo in line.refs:
                ridx.append(-1 if i is None else base + i)
                rstart.append(ref)
                rclo.append(clo)
                rline.append(n)
        self.keep = lines[0].keep if lines else 0.03
        self.a = np.array(a, float)
        self.s0 = self.a.copy()
        self.s0[list(fixed)] = list(fixed.values())
        self.ranks = [tuple(np.array(col) for col in zip(*ranks[r])) for r in sorted(ranks)]
        self.ridx, self.rstart = np.array(ridx, int), np.array(rstart, float)
        self.rclo, self.rline = np.array(rclo, bool), np.array(rline, int)
        # Scored boundaries an offset may move, per line and pair.
        self.seen = []
        for line in lines:
            scored = {i for i, _, _ in line.refs if i is not None}
            self.seen.append(Counter((st[1], st[2]) for st in line.steps if st[0] in scored))

    def row(self, table: dict, default: float) -> np.ndarray:
        return np.array([table.get(p, default) for p in self.pairs], float)

    def starts(self, en: np.ndarray, ipa: np.ndarray) -> np.ndarray:
        """Every phone's start (rows x phones) with the offsets ``en`` and ``ipa`` (rows x pairs)."""
        s = np.repeat(self.s0[None, :], len(en), axis=0)
        for idx, prev, lo, hi, onset, pair, from_ipa in self.ranks:
            off = np.where(from_ipa, ipa[:, pair], en[:, pair])
            a = self.a[idx]
            low = np.where(prev >= 0, s[:, prev] + self.keep, lo)
            t = np.minimum(np.maximum(a + off, low), hi)
            after_silence = ~np.isnan(onset)
            t = np.where(after_silence & (t > a), np.minimum(t, np.where(after_silence, onset, t)), t)
            s[:, idx] = np.where((t - a) * off > 0, t, a)
        return s

    def shown(self, en: np.ndarray, ipa: np.ndarray) -> np.ndarray:
        """:meth:`starts` on each line's own time (a line aligned on a slowed copy scaled back, as
        ``tempo.scaled`` does)."""
        s = self.starts(en, ipa)
        for line, base in zip(self.lines, self.first):
            if line.factor != 1.0:
                s[:, base:base + len(line.a)] = np.minimum(line.duration, s[:, base:base + len(line.a)] / line.factor)
        return s

    def errors(self, en: np.ndarray, ipa: np.ndarray) -> np.ndarray:
        """|start error| (s, rounded to ``decimals`` as bench/timit.py rounds it to 0.1 ms, or not, as
        bench/languages.py; inf where no aligned phone was matched) of every reference phone, rows x
        references."""
        err = np.abs(self.shown(en, ipa)[:, np.maximum(self.ridx, 0)] - self.rstart)
        if self.decimals is not None:
            err = np.round(err, self.decimals)
        err[:, self.ridx < 0] = np.inf
        return err

    def counts(self, en, ipa, train: np.ndarray) -> np.ndarray:
        """Per row, starts within 20 ms * 100000 + within 40 ms over the references of the ``train``
        lines: the larger, the better."""
        err = self.errors(en, ipa)[:, train[self.rline]]
        return (err <= 0.02).sum(axis=1) * 100000 + (err <= 0.04).sum(axis=1)


def tables(table: dict, default: float, fixed: tuple, ipa: bool) -> dict:
    """{read from IPA?: (offsets by pair, default)} with ``(table, default)`` for the words of ``ipa``."""
    return {ipa: (table, default), not ipa: fixed}


def rows(batch: Batch, tabs: list[dict]) -> tuple[np.ndarray, np.ndarray]:
    return (np.array([batch.row(*t[False]) for t in tabs]), np.array([batch.row(*t[True]) for t in tabs]))


def figures(err: np.ndarray, clo: np.ndarray) -> tuple[float, float, float]:
    """(within 20 ms, within 40 ms, closures within 40 ms) of the |errors| ``err``."""
    return (float(np.mean(err <= 0.02)), float(np.mean(err <= 0.04)),
            float(np.mean(err[clo] <= 0.04)) if clo.any() else float("nan"))


# --- tuning ------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Procedure:
    """How a table of offsets is made from some lines (see the module's docstring)."""
    name: str
    step: float = 0.005
    min_count: int = 5
    min_gain: int = 0
    shrink: float = 0.0
    group: str = "pair"       # "pair", "after" (class after; after silence or a pause apart), "one", "none"
    rounds: int = 1           # passes over the pairs, each with the others at the last pass's offsets


def group_of(pair: str, how: str) -> str:
    left, right = pair.split(">")
    if how == "after":
        return pair if left in ("start", "gap") else f"*>{right}"
    return pair


def grid(step: float, around: float = 0.0) -> list[float]:
    """Offsets from -SPAN to +SPAN in ``step``, nearest ``around`` first (the choice on a tie)."""
    n = int(round(SPAN / step))
    return sorted({round(k * step, 4) for k in range(-n, n + 1)}, key=lambda o: (abs(o - around), o))


def pair_counts(batch: Batch, train: np.ndarray, ipa: bool = False) -> Counter:
    """Scored boundaries an offset may move, by pair, in the ``train`` lines."""
    n: Counter = Counter()
    for k in np.flatnonzero(train):
        for (pair, from_ipa), m in batch.seen[k].items():
            if from_ipa == ipa:
                n[pair] += m
    return n


def tune(batch: Batch, train: np.ndarray, proc: Procedure, fixed: tuple = ({}, 0.0),
         ipa: bool = False, frozen: dict | None = None) -> dict:
    """The tables ``proc`` makes from the ``train`` lines (a mask over ``batch.lines``); ``ipa``: it
    makes the table of the words read from IPA, the English one held at ``fixed``; ``frozen``: pairs
    whose offsets are given, not tuned."""
    frozen = frozen or {}
    if proc.group == "none":
        return tables(dict(frozen), 0.0, fixed, ipa)
    cands = grid(proc.step)
    got = batch.counts(*rows(batch, [tables(dict(frozen), d, fixed, ipa) for d in cands]), train)
    default = cands[int(np.argmax(got))]
    if proc.group == "one":
        return tables(dict(frozen), default, fixed, ipa)
    n = pair_counts(batch, train, ipa)
    members = defaultdict(list)
    for pair in n:
        if pair not in frozen:
            members[group_of(pair, proc.group)].append(pair)
    table: dict = {}
    for _ in range(proc.rounds):
        last = dict(table)      # the first pass: each pair alone, the others at the default
        for _group, pairs in sorted(members.items()):
            seen = sum(n[p] for p in pairs)
            if seen < proc.min_count:
                continue
            others = {**frozen, **{p: o for p, o in last.items() if p not in pairs}}
            cands = grid(proc.step, default)
            tabs = [tables({**others, **dict.fromkeys(pairs, o)}, default, fixed, ipa) for o in cands]
            got = batch.counts(*rows(batch, tabs), train)
            off = cands[int(np.argmax(got))]
            if proc.min_gain and got.max() // 100000 - got[cands.index(default)] // 100000 < proc.min_gain:
                off = default
            if proc.shrink:
                off = round(default + (off - default) * seen / (seen + proc.shrink), 4)
            for p in pairs:
                table.pop(p, None)
            if off != default:
                table.update(dict.fromkeys(pairs, off))
    return tables({**frozen, **table}, default, fixed, ipa)


# --- the splits --------------------------------------------------------------------------------------

def scored(batch: Batch, folds: dict, tune_on) -> np.ndarray:
    """|error| of every reference phone of the lines of each fold ({name: mask over lines}), with
    the tables ``tune_on(mask)`` makes from the lines of no fold of that name (``~mask``)."""
    err = np.full(len(batch.rline), np.nan)
    for mask in folds.values():
        tabs = tune_on(~mask)
        got = batch.errors(*rows(batch, [tabs]))[0]
        mine = mask[batch.rline]
        err[mine] = got[mine]
    return err


def cell(fig) -> str:
    return f"{fig[0]:.3f} {fig[1]:.3f} {fig[2]:.3f}"


def fold_masks(batch: Batch, key: str) -> dict:
    values = [line.groups[key] for line in batch.lines]
    return {v: np.array([x == v for x in values]) for v in sorted(set(values))}


def bootstrap_se(batch: Batch, diff: np.ndarray, rounds: int = 2000, mask: np.ndarray | None = None) -> float:
    """Standard error of the mean of ``diff`` (per reference phone; only those of ``mask``) when the
    lines are drawn again with replacement."""
    n = len(batch.lines)
    mask = np.ones(len(diff), bool) if mask is None else mask
    per = np.bincount(batch.rline, weights=np.where(mask, diff, 0.0), minlength=n)
    size = np.bincount(batch.rline, weights=mask.astype(float), minlength=n)
    rng = np.random.default_rng(0)
    draws = rng.integers(0, n, size=(rounds, n))
    return float(np.std(per[draws].sum(axis=1) / size[draws].sum(axis=1)))


PROCEDURES = (
    Procedure("no offsets (the /t/ rule only)", group="none"),
    Procedure("one offset for every boundary", group="one"),
    Procedure("pairs, 5 ms, n>=5 (timing.json's way)"),
    Procedure("pairs, the others at their offsets", rounds=3),
    Procedure("pairs, 10 ms steps", step=0.01),
    Procedure("pairs, n>=10", min_count=10),
    Procedure("pairs, n>=20", min_count=20),
    Procedure("pairs, 10 ms, n>=20", step=0.01, min_count=20),
    Procedure("pairs, gain>=2 starts", min_gain=2),
    Procedure("pairs, gain>=4 starts", min_gain=4),
    Procedure("pairs, 10 ms, gain>=2", step=0.01, min_gain=2),
    Procedure("pairs, shrunk n/(n+10)", shrink=10),
    Procedure("pairs, shrunk n/(n+30)", shrink=30),
    Procedure("class after, n>=5", group="after"),
    Procedure("class after, n>=20", group="after", min_count=20),
)
MAIN = 2        # timing.json's way


def load(data, limit: int | None = None) -> list[Line]:
    """Every TIMIT sentence aligned without correction, as :class:`Line` s."""
    lines = []
    with recording() as calls:
        for k, (name, wav, text, ref) in enumerate(sentences(data, DEV + HELD, limit)):
            snd = audio_mod.load(wav)
            calls.clear()
            try:
                al = align_audio(snd, text)
            except Exception as exc:  # noqa: BLE001 - a failure is left out, and said
                print(f"  {name}: failed ({exc})")
                continue
            pairs = match_sets([p.phone for p in al.phones], [p.phones for p in ref])
            refs = [(i, ref[j].start, al.phones[i].phone in ("P", "B", "M")) for i, j in pairs]
            spk = name.split("/")[0]
            lines.append(line_from(name, {"speaker": spk, "region": spk[:3], "half": "dev" if spk in DEV else "held"},
                                   snd, al, list(calls), refs))
            if (k + 1) % 10 == 0:
                print(f"  {k + 1} sentences aligned", flush=True)
    return lines


def check(batch: Batch, shipped: dict) -> int:
    """Starts where :class:`Batch` under timing.json's tables and the engine's own run disagree."""
    ours = batch.shown(*rows(batch, [shipped]))[0]
    return sum(abs(ours[base + k] - t) > 1e-9 for line, base in zip(batch.lines, batch.first)
               for k, t in enumerate(line.shown))


def shipped_tables(cfg: dict, ipa_cfg: dict | None = None) -> dict:
    """timing.json's tables as :func:`tables` gives them."""
    def one(c):
        return {str(k): float(v) for k, v in c.get("shift", {}).items()}, float(c.get("default", 0.0))
    return {False: one(cfg), True: one(ipa_cfg if ipa_cfg is not None else cfg)}


def ms(table: dict, default: float, pair: str) -> str:
    return f"{1000 * table.get(pair, default):+.0f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--offsets", action="store_true", help="print the tables each procedure makes")
    ap.add_argument("--limit", type=int, default=None, help="sentences per speaker (default: all)")
    args = ap.parse_args()
    data = need_data() / "timit_nltk"
    if not data.is_dir():
        print(f"skipped: {data} is not here")
        return
    t0 = time.perf_counter()
    cfg = timing_settings()["boundary"]
    lines = load(data, args.limit)
    for line in lines:
        prepare(line, cfg)
    batch = Batch(lines)
    shipped = shipped_tables(cfg)
    dev = np.array([line.groups["half"] == "dev" for line in lines])
    on_dev, on_held = dev[batch.rline], ~dev[batch.rline]
    print(f"TIMIT: {len(lines)} sentences, 8 speakers, aligned once in {time.perf_counter() - t0:.0f} s; "
          f"{len(batch.rline)} matched phone starts ({on_dev.sum()} of the development speakers, {on_held.sum()} "
          f"held out); {sum(line.factor != 1 for line in lines)} sentences aligned on a slowed copy, "
          f"{sum(not line.exact for line in lines)} whose phones were moved after the correction (left as they are)")
    print(f"the correction re-applied offline with timing.json's table: {check(batch, shipped)} of {len(batch.a)} "
          "starts differ from the engine's")
    err = batch.errors(*rows(batch, [shipped]))[0]
    print("timing.json's table scored here (20 ms, 40 ms, closures 40 ms): dev "
          + cell(figures(err[on_dev], batch.rclo[on_dev])) + ", held "
          + cell(figures(err[on_held], batch.rclo[on_held])) + " (the boundary model left out: "
          "bench/boundary_model.py's 'without')")

    t1 = time.perf_counter()
    everyone = np.ones(len(lines), bool)
    splits = {"in-sample": None, "dev->dev": None, "dev->held": None,
              "1 speaker out": fold_masks(batch, "speaker"), "1 region out": fold_masks(batch, "region")}
    results, made = {}, {}
    for proc in PROCEDURES:
        def run(train, proc=proc):
            return tune(batch, train, proc)
        made[proc.name] = {"dev": run(dev), "all": run(everyone)}
        on_all = batch.errors(*rows(batch, [made[proc.name]["all"]]))[0]
        on_split = batch.errors(*rows(batch, [made[proc.name]["dev"]]))[0]
        results[proc.name] = {
            "in-sample": (on_all, np.ones_like(on_dev)),
            "dev->dev": (on_split, on_dev), "dev->held": (on_split, on_held),
            "1 speaker out": (scored(batch, splits["1 speaker out"], run), np.ones_like(on_dev)),
            "1 region out": (scored(batch, splits["1 region out"], run), np.ones_like(on_dev)),
        }
        print(f"  {proc.name}: tuned and scored", flush=True)
    results["timing.json as shipped (tuned on dev)"] = {
        "in-sample": (err, np.ones_like(on_dev)), "dev->dev": (err, on_dev), "dev->held": (err, on_held)}
    report(batch, results, list(splits), f"{len(batch.rline)} starts of 8 speakers", "in-sample",
           "1 speaker out", PROCEDURES[MAIN].name)
    print(f"(tuning and scoring: {time.perf_counter() - t1:.0f} s)")
    retuned = results[PROCEDURES[MAIN].name]["dev->held"][0]
    diff = (err <= 0.02).astype(float) - (retuned <= 0.02)
    print(f"on the held-out speakers, timing.json's table less the table {PROCEDURES[MAIN].name!r} makes from "
          f"today's alignments of the development speakers: {diff[on_held].mean():+.3f} +- "
          f"{bootstrap_se(batch, diff, mask=on_held):.3f} within 20 ms (on the development speakers "
          f"{diff[on_dev].mean():+.3f} +- {bootstrap_se(batch, diff, mask=on_dev):.3f})")

    res = results[PROCEDURES[MAIN].name]
    print(f"\nper speaker, {PROCEDURES[MAIN].name!r}, within 20 ms: tuned on all 8 / without the speaker / "
          "without its region; timing.json's table")
    print(f"{'speaker':14s} {'half':4s} {'starts':>6s} {'all 8':>6s} {'1 out':>6s} {'region':>6s} {'shipped':>7s}")
    speakers = fold_masks(batch, "speaker")
    for spk, mask in list(speakers.items()) + [("dev speakers", dev), ("held speakers", ~dev)]:
        m = mask[batch.rline]
        half = lines[int(np.flatnonzero(mask)[0])].groups["half"] if spk in speakers else ""
        print(f"{spk:14s} {half:4s} {m.sum():6d} " + " ".join(
            f"{np.mean(res[s][0][m] <= 0.02):6.3f}" for s in ("in-sample", "1 speaker out", "1 region out"))
            + f" {np.mean(err[m] <= 0.02):7.3f}")

    plain = {k: v for k, v in cfg.items() if k != "unreleased"}
    for line in lines:
        prepare(line, plain)
    loose = Batch(lines).errors(*rows(batch, [shipped]))[0]
    clo = {h: [figures(e[m], batch.rclo[m])[2] for e in (err, loose)] for h, m in (("dev", on_dev), ("held", on_held))}
    print("\nthe /t/ rule (boundary.unreleased, chosen on dev), timing.json's table, with / without it: /p b m/ "
          f"closure onsets within 40 ms: dev {clo['dev'][0]:.3f} / {clo['dev'][1]:.3f}, held {clo['held'][0]:.3f}"
          f" / {clo['held'][1]:.3f}; all starts within 20 ms: dev "
          f"{np.mean(err[on_dev] <= 0.02):.3f} / {np.mean(loose[on_dev] <= 0.02):.3f}, held "
          f"{np.mean(err[on_held] <= 0.02):.3f} / {np.mean(loose[on_held] <= 0.02):.3f}")

    main_made = made[PROCEDURES[MAIN].name]
    (dev_t, dev_d), (all_t, all_d) = main_made["dev"][False], main_made["all"][False]
    ship_t, ship_d = shipped[False]
    n_dev, n_all = pair_counts(batch, dev), pair_counts(batch, everyone)
    print(f"\ntiming.json's offsets beside {PROCEDURES[MAIN].name!r} re-run on today's alignments, ms; n: "
          f"scored boundaries of the pair; default: shipped {1000 * ship_d:+.0f}, dev {1000 * dev_d:+.0f}, "
          f"all {1000 * all_d:+.0f}")
    print(f"{'pair':20s} {'n dev':>5s} {'n all':>5s} {'shipped':>7s} {'dev':>5s} {'all':>5s}")
    for pair in sorted(set(ship_t) | set(n_all)):
        print(f"{pair:20s} {n_dev[pair]:5d} {n_all[pair]:5d} {ms(ship_t, ship_d, pair) if pair in ship_t else '-':>7s} "
              f"{ms(dev_t, dev_d, pair):>5s} {ms(all_t, all_d, pair):>5s}")
    if args.offsets:
        for proc in PROCEDURES:
            for where in ("dev", "all"):
                t, d = made[proc.name][where][False]
                print(f"{proc.name} on {where}: default {1000 * d:+.1f} ms; "
                      + ", ".join(f"{p} {1000 * o:+.1f}" for p, o in sorted(t.items())))
    print(f"\ntotal {time.perf_counter() - t0:.0f} s")


def report(batch: Batch, results: dict, splits: list[str], pooled: str, inside: str, crossed: str,
           main_name: str) -> None:
    """The three tables: within 20 ms (with the optimism of the in-sample figure and the
    cross-validated difference from ``main_name``), within 40 ms, closures within 40 ms."""
    for k, what in enumerate(("phone starts within 20 ms", "phone starts within 40 ms",
                              "/p b m/ closure onsets within 40 ms")):
        extra = k == 0
        count = f"{batch.rclo.sum()} of the {pooled}" if k == 2 else pooled
        print(f"\n{what} ({count}; dev/held: bench/timit.py's halves)")
        print(f"{'procedure':40s} " + " ".join(f"{s:>13s}" for s in splits)
              + (f" {'optimism':>8s} {crossed + ' vs main':>22s}" if extra else ""))
        base = results[main_name][crossed][0] <= 0.02
        for name, res in results.items():
            cells = []
            for s in splits:
                if s not in res:
                    cells.append(f"{'':>13s}")
                    continue
                err, mask = res[s]
                cells.append(f"{figures(err[mask], batch.rclo[mask])[k]:13.3f}")
            line = f"{name:40s} " + " ".join(cells)
            if extra and crossed in res:
                inside_f, crossed_f = (float(np.mean(res[s][0][res[s][1]] <= 0.02)) for s in (inside, crossed))
                diff = (res[crossed][0] <= 0.02).astype(float) - base
                line += (f" {inside_f - crossed_f:+8.3f} {diff.mean():+13.3f} +- {bootstrap_se(batch, diff):.3f}")
            print(line)


if __name__ == "__main__":
    main()
