"""The boundary-correction model (``data/boundary_model.json``, :mod:`addon.engine.alignment.refine`):
how much it gains on TIMIT's hand labels, cross-validated, and its fit.

Reads ``../shared/data/timit_nltk`` (skips cleanly without it): 61 sentences, 8 speakers, 2 in each
of the dialect regions 1-4.  Every sentence is aligned once as the engine aligns it, with the model's
step (the aligner's last) recorded instead of applied: the phones it would move, the audio, which
words it would leave.
Then the model (a ridge regression from the engine's own features, :func:`refine.features`, to each
boundary's error against the hand labels, errors clipped at 50 ms) is fitted on some speakers and
applied, by the engine's own :func:`refine.refine_boundaries`, to the others:

* **in-sample**: fitted on all 8 speakers, scored on them;
* **dev->held**, **held->dev**: fitted on one half of ``bench/timit.py`` and scored on the other;
* **1 speaker out**: fitted on 7 speakers, scored on the 8th, pooled over the 8;
* **1 region out**: fitted on the 6 speakers of three dialect regions, scored on the fourth's 2.

Each beside the same starts without the model: matched phone starts within 20 ms and 40 ms of the
hand labels and /p b m/ closure onsets within 40 ms (``bench/timit.py``'s figures), for ridge
penalties around the file's.  The shipped model is fitted on the development speakers (so
``bench/timit.py``'s held-out half stays held out); ``--write`` fits it again and writes the file.

    .venv/bin/python bench/boundary_model.py            # about 20 s
    .venv/bin/python bench/boundary_model.py --write    # refit on the development speakers
"""

from __future__ import annotations

import argparse
import copy
import json
from contextlib import contextmanager

import numpy as np

from common import need_data
from timit import DEV, HELD, match_sets, sentences

from addon.engine import audio as audio_mod
from addon.engine.alignment import align_audio, refine, transcript

PBM = {"P", "B", "M"}


@contextmanager
def recorded():
    """The aligner's last step (the boundary model) recorded instead of applied, within the block:
    yields the list its calls are appended to, as (audio, phones per word, words it leaves)."""
    calls: list = []
    saved = transcript.refine_alignment

    def record(audio, al, doc=None):
        result, _, left = refine.by_word(al)
        calls.append((audio, result, left))

    transcript.refine_alignment = record
    try:
        yield calls
    finally:
        transcript.refine_alignment = saved


def aligned(doc: dict) -> list[dict]:
    """Every sentence aligned with the model's step recorded, not applied."""
    lines = []
    with recorded() as calls:
        for name, wav, text, ref in sentences(need_data() / "timit_nltk", DEV + HELD, None):
            calls.clear()
            al = align_audio(audio_mod.load(wav), text)
            audio, result, left = calls[-1]
            flat = [p for ph in result if ph for p in ph]
            pairs = match_sets([p.phone for p in al.phones], [p.phones for p in ref])
            lines.append(dict(name=name, speaker=name.split("/")[0], audio=audio, result=result, left=left,
                              phones=flat, pairs=pairs, ref=[ref[j].start for _, j in pairs],
                              pbm=[al.phones[i].phone in PBM for i, _ in pairs],
                              X=refine.features(audio, flat, doc)))
    return lines


def fit(lines: list[dict], alpha: float) -> np.ndarray:
    X = np.concatenate([ln["X"][[i for i, _ in ln["pairs"] if i > 0]] for ln in lines])
    y = np.concatenate([[ln["phones"][i][1] - r for (i, _), r in zip(ln["pairs"], ln["ref"]) if i > 0]
                        for ln in lines])
    y = np.clip(y, -0.05, 0.05)
    return np.linalg.solve(X.T @ X + alpha * np.eye(X.shape[1]), X.T @ y)


def errors(lines: list[dict], doc: dict, weights: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """(|start error| of every matched phone, whether it is a /p b m/), with the model of ``weights``
    applied by the engine's step (None: not applied)."""
    err, pbm = [], []
    for ln in lines:
        result = copy.deepcopy(ln["result"])
        if weights is not None:
            refine.refine_boundaries(ln["audio"], result, ln["left"], dict(doc, weights=weights))
        flat = [p for ph in result if ph for p in ph]
        err += [round(abs(flat[i][1] - r), 4) for (i, _), r in zip(ln["pairs"], ln["ref"])]
        pbm += ln["pbm"]
    return np.array(err), np.array(pbm, bool)


def figures(err: np.ndarray, pbm: np.ndarray) -> str:
    return f"{np.mean(err <= 0.02):.3f} {np.mean(err <= 0.04):.3f} {np.mean(err[pbm] <= 0.04):.3f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--write", action="store_true", help="refit on the development speakers and write the file")
    args = ap.parse_args()
    doc = refine.model()
    lines = aligned(doc)
    speakers = sorted({ln["speaker"] for ln in lines})
    print(f"TIMIT: {len(lines)} sentences, {len(speakers)} speakers, "
          f"{sum(len(ln['pairs']) for ln in lines)} matched phone starts; the model's file: alpha "
          f"{doc['alpha']}, {len(doc['weights'])} weights")
    print("figures: within 20 ms, within 40 ms, /p b m/ closure onsets within 40 ms; "
          "'without' is the same starts with the model's step left out")

    def split(name: str, folds: list[tuple[list[str], list[str]]], alpha: float) -> None:
        out_err, out_pbm, base_err, base_pbm = [], [], [], []
        for train, test in folds:
            w = fit([ln for ln in lines if ln["speaker"] in train], alpha)
            e, p = errors([ln for ln in lines if ln["speaker"] in test], doc, w)
            b, q = errors([ln for ln in lines if ln["speaker"] in test], doc, None)
            out_err.append(e), out_pbm.append(p), base_err.append(b), base_pbm.append(q)
        e, p = np.concatenate(out_err), np.concatenate(out_pbm)
        b, q = np.concatenate(base_err), np.concatenate(base_pbm)
        print(f"  {name:14s} with the model {figures(e, p)}   without {figures(b, q)}")

    regions = sorted({s.split("-")[0] for s in speakers})
    for alpha in sorted({float(doc["alpha"]) / 3, float(doc["alpha"]), float(doc["alpha"]) * 3}):
        print(f"ridge penalty {alpha:g}:")
        split("in-sample", [(speakers, speakers)], alpha)
        split("dev->held", [(list(DEV), list(HELD))], alpha)
        split("held->dev", [(list(HELD), list(DEV))], alpha)
        split("1 speaker out", [([s for s in speakers if s != t], [t]) for t in speakers], alpha)
        split("1 region out", [([s for s in speakers if not s.startswith(r)], [s for s in speakers if s.startswith(r)])
                               for r in regions], alpha)
    shipped = doc["weights"]
    for half, names in (("dev", DEV), ("held", HELD)):
        e, p = errors([ln for ln in lines if ln["speaker"] in names], doc, shipped)
        print(f"the shipped model on the {half} speakers: {figures(e, p)}")
    if args.write:
        w = fit([ln for ln in lines if ln["speaker"] in DEV], float(doc["alpha"]))
        out = {k: v for k, v in json.loads(refine.MODEL_FILE.read_text(encoding="utf-8")).items()}
        out["weights"] = [round(float(x), 6) for x in w]
        refine.MODEL_FILE.write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")
        print(f"written: {refine.MODEL_FILE} ({len(w)} weights, fitted on {', '.join(DEV)})")


if __name__ == "__main__":
    main()
