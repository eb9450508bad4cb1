"""The boundary-correction model of other languages (``data/boundary_model_other_languages.json``,
the model of lines read through eSpeak NG or IPA) against the English one (``data/boundary_model.json``,
fitted on TIMIT), cross-validated by language family and by EmoDB actor.

Reads ``../shared/data/voxangeles``, ``emodb`` and ``timit_nltk`` (skips cleanly without them).
Every usable word of ``bench/languages.py`` (an IPA transcript, ``/padjan/``) and every EmoDB take
(in German, read through eSpeak NG) is aligned once as the engine aligns it, with the model's step
(the aligner's last) recorded instead of applied.  A word's reference phones are matched to the
aligned ones as ``bench/languages.py`` matches them (a dropped phone is a miss); a take's aligned
starts are paired with the nearest labelled start within 50 ms, and scored as ``bench/emodb.py``
scores them (each labelled start against the nearest aligned one).  The model (the English one's
features and ridge regression) is fitted on the training side's VoxAngeles words and EmoDB takes
and TIMIT's development speakers, for three ridge penalties, and scored beside the same starts
without a model and with the English one:

* VoxAngeles: in-sample, by halves of the languages (``bench/languages.py``'s A and B), one
  language family left out (``crossval_languages.FAMILY``), pooled;
* EmoDB: in-sample, one actor left out, and fitted without EmoDB at all.

Figures: starts within 20 ms and 40 ms.  ``--write`` fits it on everything at the file's penalty
and writes the file.

    .venv/bin/python bench/boundary_model_ipa.py          # about 3 minutes
    .venv/bin/python bench/boundary_model_ipa.py --write
"""

from __future__ import annotations

import argparse
import copy
import json

import numpy as np

from common import need_data
from boundary_model import aligned as timit_aligned, recorded
from crossval_languages import FAMILY
from languages import usable_words

from addon.engine import LineSettings, analyze
from addon.engine import audio as audio_mod
from addon.engine.alignment import refine
from addon.engine.alignment.verify import edit_path
from addon.engine.errors import LipSyncError


def words(limit: int) -> list[dict]:
    """Every usable VoxAngeles word aligned with the model's step recorded, not applied."""
    root = need_data() / "voxangeles"
    doc = refine.model()
    out = []
    with recorded() as calls:
        for folder in sorted((root / "audited").iterdir()):
            for grid, word, phones in usable_words(folder, limit):
                snd = audio_mod.load(grid.with_suffix(".wav"))
                calls.clear()
                line = dict(language=folder.name, family=FAMILY.get(folder.name, folder.name),
                            refs=[a for _, a, _, _ in phones], pairs=[])
                out.append(line)
                try:
                    al = analyze(snd, f"/{word}/", LineSettings.of(fps=100)).alignment
                except LipSyncError:
                    continue
                audio, result, left = calls[-1]
                flat = [p for ph in result if ph for p in ph]
                shown = [p.phone for p in al.phones]
                if len(shown) == len(flat):
                    line.update(audio=audio, result=result, left=left, flat=flat,
                                pairs=[(j, i) for i, j, _ in edit_path([p for p, *_ in phones], shown)],
                                X=refine.features(audio, flat, doc))
    langs = sorted({ln["language"] for ln in out})
    for ln in out:
        ln["half"] = "AB"[langs.index(ln["language"]) % 2]
    return out


def emodb_takes() -> list[dict]:
    """Every EmoDB take analysed (in German) with the model's step recorded, not applied; each
    aligned phone start after the first paired with the labelled segment start nearest it (within
    50 ms: EmoDB's labels are German SAMPA, scored as bench/emodb.py scores them, by the nearest
    start)."""
    import emodb

    doc = refine.model()
    out = []
    settings = LineSettings.of(language="de")
    with recorded() as calls:
        for wav in sorted((need_data() / "emodb").glob("*.wav")):
            calls.clear()
            text = wav.with_suffix(".txt").read_text(encoding="utf-8").strip()
            labels = np.array([a for _, a, _ in emodb.segments(emodb.labels(wav.with_suffix(".lablaut")))])
            analyze(audio_mod.load(wav), text, settings)
            audio, result, left = calls[-1]
            flat = [p for ph in result if ph for p in ph]
            pairs = []
            for j in range(1, len(flat)):
                i = int(np.argmin(np.abs(labels - flat[j][1])))
                if abs(labels[i] - flat[j][1]) <= 0.05:
                    pairs.append((j, i))
            out.append(dict(actor=wav.stem[:2], audio=audio, result=result, left=left, flat=flat, pairs=pairs,
                            refs=list(labels), X=refine.features(audio, flat, doc)))
    return out


def emodb_errors(takes: list[dict], weights: np.ndarray | None) -> np.ndarray:
    """bench/emodb.py's boundary errors: for every labelled segment start, the distance to the nearest
    aligned phone start, with the model of ``weights`` applied (None: not applied)."""
    doc = refine.model()
    err = []
    for t in takes:
        result = copy.deepcopy(t["result"])
        if weights is not None:
            refine.refine_boundaries(t["audio"], result, t["left"], dict(doc, weights=weights))
        starts = np.array([p[1] for ph in result if ph for p in ph])
        err += [float(np.min(np.abs(starts - a))) for a in t["refs"]]
    return np.array(err)


def design(lines: list[dict], key_ref: str = "refs") -> tuple[np.ndarray, np.ndarray]:
    X, y = [], []
    for ln in lines:
        for j, i in ln["pairs"]:
            if j > 0:
                X.append(ln["X"][j])
                y.append(ln["flat"][j][1] - ln[key_ref][i])
    return np.array(X).reshape(-1, len(refine.model()["weights"])), np.clip(np.array(y), -0.05, 0.05)


def timit_design(lines: list[dict]) -> tuple[np.ndarray, np.ndarray]:
    X = np.concatenate([ln["X"][[i for i, _ in ln["pairs"] if i > 0]] for ln in lines])
    y = np.concatenate([[ln["phones"][i][1] - r for (i, _), r in zip(ln["pairs"], ln["ref"]) if i > 0]
                        for ln in lines])
    return X, np.clip(y, -0.05, 0.05)


def fit(X: np.ndarray, y: np.ndarray, alpha: float) -> np.ndarray:
    return np.linalg.solve(X.T @ X + alpha * np.eye(X.shape[1]), X.T @ y)


def errors(lines: list[dict], weights: np.ndarray | None) -> np.ndarray:
    """|start error| of every reference phone (inf: not matched) with the model of ``weights``
    applied by the engine's step (None: not applied)."""
    doc = refine.model()
    err = []
    for ln in lines:
        e = np.full(len(ln["refs"]), np.inf)
        if ln["pairs"]:
            result = copy.deepcopy(ln["result"])
            if weights is not None:
                refine.refine_boundaries(ln["audio"], result, ln["left"], dict(doc, weights=weights))
            flat = [p for ph in result if ph for p in ph]
            for j, i in ln["pairs"]:
                e[i] = abs(flat[j][1] - ln["refs"][i])
        err.append(e)
    return np.concatenate(err)


def figures(err: np.ndarray) -> str:
    return f"{100 * np.mean(err <= 0.02):5.1f} % {100 * np.mean(err <= 0.04):5.1f} %"


ALPHAS = (50.0, 150.0, 500.0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--limit", type=int, default=0, help="at most N words per language")
    ap.add_argument("--write", action="store_true",
                    help="fit the other languages' model on all the words, takes and TIMIT development "
                         "speakers and write it (data/boundary_model_other_languages.json)")
    args = ap.parse_args()
    lines = words(args.limit)
    takes = emodb_takes()
    english = refine.model()
    timit = timit_aligned(english)
    from timit import DEV
    tX, ty = timit_design([ln for ln in timit if ln["speaker"] in DEV])
    print(f"VoxAngeles: {len(lines)} words, {sum(len(ln['refs']) for ln in lines)} reference phones; EmoDB: "
          f"{len(takes)} takes, {sum(len(t['refs']) for t in takes)} labelled starts; TIMIT development "
          f"speakers: {len(ty)} boundaries")
    print("the model of other languages is fitted on the VoxAngeles words and EmoDB takes of the split's "
          "training side and TIMIT's development speakers; figures: within 20 ms, within 40 ms")
    families = sorted({ln["family"] for ln in lines})
    actors = sorted({t["actor"] for t in takes})

    def every(x):
        return True

    def none(x):
        return False

    # (name, which source is scored, folds: (VoxAngeles training, EmoDB training, scored))
    splits = [
        ("in-sample", "vox", [(every, every, every)]),
        ("halves", "vox", [(lambda ln, h=h: ln["half"] != h, every, lambda ln, h=h: ln["half"] == h)
                           for h in "AB"]),
        ("1 family out", "vox", [(lambda ln, f=f: ln["family"] != f, every, lambda ln, f=f: ln["family"] == f)
                                 for f in families]),
        ("in-sample", "emodb", [(every, every, every)]),
        ("1 actor out", "emodb", [(every, lambda t, a=a: t["actor"] != a, lambda t, a=a: t["actor"] == a)
                                  for a in actors]),
        ("without EmoDB", "emodb", [(every, none, every)]),
    ]
    print(f"{'':24s} {'without':>16s} {'English model':>16s}   "
          + "   ".join(f"other a={a:g}".rjust(16) for a in ALPHAS))
    for name, source, folds in splits:
        cols: dict[str, list] = {k: [] for k in ["without", "english"] + [f"a{a}" for a in ALPHAS]}
        for vox_train, emo_train, test in folds:
            X1, y1 = design([ln for ln in lines if vox_train(ln) and ln["pairs"]])
            trained = [t for t in takes if emo_train(t)]
            X2, y2 = design(trained) if trained else (tX[:0], ty[:0])
            X, y = np.concatenate([X1, X2, tX]), np.concatenate([y1, y2, ty])
            scored = [ln for ln in lines if test(ln)] if source == "vox" else [t for t in takes if test(t)]
            err = errors if source == "vox" else emodb_errors
            cols["without"].append(err(scored, None))
            cols["english"].append(err(scored, english["weights"]))
            for a in ALPHAS:
                cols[f"a{a}"].append(err(scored, fit(X, y, a)))
        label = f"{'VoxAngeles' if source == 'vox' else 'EmoDB'} {name}"
        print(f"{label:24s} " + "   ".join(figures(np.concatenate(v)).rjust(16) for v in cols.values()), flush=True)
    if args.write:
        path = refine.OTHER_LANGUAGES_FILE
        alpha = float(json.loads(path.read_text(encoding="utf-8"))["alpha"]) if path.is_file() else 150.0
        X1, y1 = design([ln for ln in lines if ln["pairs"]])
        X2, y2 = design(takes)
        w = fit(np.concatenate([X1, X2, tX]), np.concatenate([y1, y2, ty]), alpha)
        out = {k: v for k, v in english.items() if k != "weights"}
        out["about"] = OTHER_ABOUT
        out["alpha"] = alpha
        out["weights"] = [round(float(x), 6) for x in w]
        path.write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")
        print(f"written: {path} ({len(w)} weights, ridge penalty {alpha:g})")


OTHER_ABOUT = ("The boundary-correction model of lines whose words are read through eSpeak NG or IPA "
               "(other languages, aligned by the English phones of the nearest mouth; "
               "addon/engine/alignment/refine.py): the English model's features and form, fitted by "
               "bench/boundary_model_ipa.py --write on VoxAngeles' words in 37 languages, EmoDB's acted "
               "German and TIMIT's development speakers. Times in seconds, bands in Hz, offsets in hops.")


if __name__ == "__main__":
    main()
