"""How well the arousal estimate ranks real clips (../shared/data/arousal,
24 clips with human arousal labels in [-1, 1]; skips when absent).

Figures (Spearman's rho between a score and the labels; 1 = same order):

* floor: median pitch (Hz) of the voiced frames alone;
* each feature alone;
* the estimator under nested leave-one-out cross-validation: for each
  clip, an inner leave-one-out on the other 23 picks the speech threshold
  (20-35 dB below the loudest frame) and the ridge strength, the model
  (feature centres, scales, ridge weights) is fitted on those 23 and scores
  the held-out clip; this is the figure for clips the estimator was not
  tuned on;
* plain leave-one-out at the shipped threshold and ridge strength (those
  two were picked looking at all clips, so this one is optimistic);
* the spectral centroid alone under the same nested protocol (its threshold
  picked per fold), the strongest single feature, for comparison;
* the shipped constants (``addon/engine/data/arousal.json``) on the same
  clips, in-sample (they were fitted on all 24), through the public
  ``estimate_file`` path.

    .venv/bin/python bench/arousal.py            # print the figures
    .venv/bin/python bench/arousal.py --write    # refit on all clips and write the data file
"""

from __future__ import annotations

import csv
import json
import sys

import numpy as np

from common import ROOT, need_data
from addon.engine import arousal
from addon.engine import audio as audio_mod
from addon.engine import prosody

NAMES = ("pitch", "centroid", "dynamics", "voiced")
RIDGE = 3.0
RIDGES = (0.3, 1.0, 3.0, 10.0, 30.0)
SPEECH_DB = (20.0, 25.0, 30.0, 35.0)


def ranks(a) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    order = np.argsort(a, kind="stable")
    r = np.empty(len(a))
    r[order] = np.arange(len(a))
    for v in np.unique(a):
        m = a == v
        r[m] = r[m].mean()
    return r


def spearman(a, b) -> float:
    return float(np.corrcoef(ranks(a), ranks(b))[0, 1])


def loo(rows, y, ridge) -> np.ndarray:
    pred = np.zeros(len(y))
    for i in range(len(y)):
        train = [r for k, r in enumerate(rows) if k != i]
        model = arousal.fit(train, np.delete(y, i), NAMES, ridge)
        pred[i] = arousal.score(rows[i], model)
    return pred


def nested_loo(by_db: dict[float, list[dict]], y) -> tuple[np.ndarray, list[tuple[float, float]]]:
    """Outer leave-one-out; inside each fold, an inner leave-one-out on the
    training clips picks the speech threshold and the ridge strength."""
    pred, chosen = np.zeros(len(y)), []
    for i in range(len(y)):
        yt = np.delete(y, i)
        best = max(((db, lam) for db in by_db for lam in RIDGES),
                   key=lambda c: spearman(loo([r for k, r in enumerate(by_db[c[0]]) if k != i], yt, c[1]), yt))
        chosen.append(best)
        rows = by_db[best[0]]
        model = arousal.fit([r for k, r in enumerate(rows) if k != i], yt, NAMES, best[1])
        pred[i] = arousal.score(rows[i], model)
    return pred, chosen


def main() -> None:
    d = need_data() / "arousal"
    labels = list(csv.DictReader(open(d / "labels.csv", encoding="utf-8")))
    y = np.array([float(r["arousal"]) for r in labels])
    sounds = [audio_mod.load(d / r["file"]) for r in labels]
    tracks = [prosody.analyse(s, step=arousal.STEP) for s in sounds]
    by_db = {db: [arousal.features(arousal.frames(s, t, db)) for s, t in zip(sounds, tracks)] for db in SPEECH_DB}
    hz = []
    for t in tracks:
        f0 = t.pitch[np.isfinite(t.pitch)]
        hz.append(float(np.median(f0)))
    print(f"{len(y)} clips in {d}")
    print(f"floor, median pitch (Hz) alone:            rho = {spearman(hz, y):+.3f}")
    shipped = arousal.load_model()
    db0 = float(shipped.get("speech_db", 35.0))
    rows = by_db[db0] if db0 in by_db else [arousal.features(arousal.frames(s, t, db0))
                                            for s, t in zip(sounds, tracks)]
    for n in NAMES:
        print(f"  feature {n:9} alone (speech {db0:g} dB):   rho = {spearman([r[n] for r in rows], y):+.3f}")
    p2, chosen = nested_loo(by_db, y)
    picks = sorted(set(chosen))
    print(f"estimator, nested leave-one-out CV:        rho = {spearman(p2, y):+.3f}  "
          f"(speech dB, ridge chosen per fold: {', '.join(f'{a:g}/{b:g}' for a, b in picks)})")
    # The strongest single feature under the same nested protocol, for comparison.
    single = np.zeros(len(y))
    for i in range(len(y)):
        yt = np.delete(y, i)
        db = max(by_db, key=lambda db: spearman([r["centroid"] for k, r in enumerate(by_db[db]) if k != i], yt))
        train = np.array([r["centroid"] for k, r in enumerate(by_db[db]) if k != i])
        single[i] = (by_db[db][i]["centroid"] - train.mean()) / train.std()   # comparable across folds
    print(f"spectral centroid alone, nested (threshold per fold): rho = {spearman(single, y):+.3f}")
    if "--write" in sys.argv:
        db, lam = max(((db, lam) for db in by_db for lam in RIDGES),
                      key=lambda c: spearman(loo(by_db[c[0]], y, c[1]), y))
        model = arousal.fit(by_db[db], y, NAMES, lam)
        doc = json.loads(arousal.DATA.read_text(encoding="utf-8"))
        doc["speech_db"] = db
        doc["ridge"] = lam
        doc["bias"] = round(model["bias"], 4)
        doc["features"] = {k: {kk: round(vv, 4) for kk, vv in c.items()} for k, c in model["features"].items()}
        arousal.DATA.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
        print(f"wrote {arousal.DATA.relative_to(ROOT)} (speech {db:g} dB, ridge {lam:g}, chosen by leave-one-out "
              "on all clips)")
        shipped = arousal.load_model()
        db0 = db
    lam0 = float(shipped.get("ridge", RIDGE))
    p = loo(by_db.get(db0, rows), y, lam0)
    print(f"estimator, leave-one-out CV at the shipped speech {db0:g} dB / ridge {lam0:g}: rho = {spearman(p, y):+.3f}"
          "  (settings picked on all clips: optimistic)")
    est = [arousal.estimate(s, t, model=shipped) for s, t in zip(sounds, tracks)]  # decoded and tracked above
    print(f"shipped constants, in-sample (all 24):     rho = {spearman([e.value for e in est], y):+.3f}")
    err = np.abs(np.array([e.value for e in est]) - y)
    print(f"  mean absolute error {err.mean():.3f}; estimates span {min(e.value for e in est):+.2f} "
          f"to {max(e.value for e in est):+.2f}")


if __name__ == "__main__":
    main()
