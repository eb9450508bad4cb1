"""The boundary-correction model on words read from IPA (other languages): the English model
(``data/boundary_model.json``, fitted on TIMIT) against one fitted on VoxAngeles' own words,
cross-validated by language family.

Reads ``../shared/data/voxangeles`` and ``../shared/data/timit_nltk`` (skips cleanly without
them).  Every usable word of ``bench/languages.py`` is aligned once as the engine aligns it (an IPA
transcript, ``/padjan/``), with the model's step (the aligner's last) recorded instead of applied;
the reference phones are matched to the aligned ones as ``bench/languages.py`` matches them (a
dropped phone is a miss).  Then, each beside the same starts without the model and with the
English one:

* **ipa**: a model of the English one's features fitted on VoxAngeles' words alone;
* **both**: fitted on TIMIT's development speakers and VoxAngeles' words together;

each fitted on the languages of every family but one and scored on that family's (pooled over
the families of ``crossval_languages.FAMILY``), on one half of the languages and scored on the
other (``bench/languages.py``'s halves A and B), and in-sample.  Figures: reference phone starts
within 20 ms and 40 ms.  With ``--emodb``, the IPA model fitted on all the words is also tried on
EmoDB's acted German (``bench/emodb.py``'s takes and figures), which neither model saw, beside the
English one.

    .venv/bin/python bench/boundary_model_ipa.py     # about 6 minutes (2 cores)
    .venv/bin/python bench/boundary_model_ipa.py --emodb
"""

from __future__ import annotations

import argparse
import copy

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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--limit", type=int, default=0, help="at most N words per language")
    ap.add_argument("--emodb", action="store_true", help="also try the IPA model fitted on all the words on EmoDB")
    args = ap.parse_args()
    lines = words(args.limit)
    english = refine.model()
    timit = timit_aligned(english)
    from timit import DEV
    tX, ty = timit_design([ln for ln in timit if ln["speaker"] in DEV])
    print(f"VoxAngeles: {len(lines)} words, {sum(len(ln['refs']) for ln in lines)} reference phones; "
          f"TIMIT development speakers: {len(ty)} boundaries")
    families = sorted({ln["family"] for ln in lines})
    splits = {"in-sample": [(lambda ln: True, lambda ln: True)],
              "halves": [(lambda ln, h=h: ln["half"] != h, lambda ln, h=h: ln["half"] == h) for h in "AB"],
              "1 family out": [(lambda ln, f=f: ln["family"] != f, lambda ln, f=f: ln["family"] == f)
                               for f in families]}
    print(f"{'':14s} {'without':>16s} {'English model':>16s}   " +
          "   ".join(f"{kind} a={a:g}".rjust(16) for kind in ("ipa", "both") for a in (50, 150, 500)))
    for name, folds in splits.items():
        fitted = [f"{kind}{a}" for kind in ("ipa", "both") for a in (50, 150, 500)]
        cols: dict[str, list] = {k: [] for k in ["without", "english"] + fitted}
        for train, test in folds:
            tr = [ln for ln in lines if train(ln) and ln["pairs"]]
            te = [ln for ln in lines if test(ln)]
            X, y = design(tr)
            cols["without"].append(errors(te, None))
            cols["english"].append(errors(te, english["weights"]))
            for a in (50, 150, 500):
                cols[f"ipa{a}"].append(errors(te, fit(X, y, a)))
                cols[f"both{a}"].append(errors(te, fit(np.concatenate([X, tX]), np.concatenate([y, ty]), a)))
        print(f"{name:14s} " + "   ".join(figures(np.concatenate(v)).rjust(16) for v in cols.values()), flush=True)
    if args.emodb:
        X, y = design([ln for ln in lines if ln["pairs"]])
        on_emodb(dict(english, weights=fit(X, y, 150.0)))


def on_emodb(ipa: dict) -> None:
    """EmoDB's takes analysed with the English model and with ``ipa`` (the model in its place):
    boundaries within 20 and 40 ms, lips closed during labelled /p b m/ (``bench/emodb.py``'s figures)."""
    import emodb

    takes = sorted((need_data() / "emodb").glob("*.wav"))
    settings = LineSettings.of(language="de")
    shipped = refine.model
    for label, doc in (("English model", None), ("IPA model", ipa)):
        errors, closed = [], []
        refine.model = shipped if doc is None else (lambda path=None, doc=doc: doc)
        try:
            for wav in takes:
                r = analyze(audio_mod.load(wav), wav.with_suffix(".txt").read_text(encoding="utf-8").strip(), settings)
                e, lab = emodb.score(r, emodb.segments(emodb.labels(wav.with_suffix(".lablaut"))))
                errors += e
                closed += [c for _, _, c in lab]
        finally:
            refine.model = shipped
        err = np.array(errors)
        print(f"EmoDB ({len(takes)} takes), {label}: within 20 ms {np.mean(err <= 0.02):.3f}, within 40 ms "
              f"{np.mean(err <= 0.04):.3f}, lips closed during {np.mean(closed):.3f} of labelled /p b m/", flush=True)


if __name__ == "__main__":
    main()
