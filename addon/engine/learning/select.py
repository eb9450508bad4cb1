"""Which parts of the fit to keep: the held-out check, part by part.

Every fold's fit (each clip held out in turn when there are few) gives
learned values for every part (:mod:`.parts`).  A candidate preset takes
some parts from the fit and the rest from the starting preset; it is scored
on the held-out clips of every fold, each predicted by its own fold's fit:

* per track, the mean over held-out clips of the correlation with the
  measured track and the RMSE (tracks in the capture's units go through the
  gain and offset fitted on the fold's training clips, as in the report);
* the score: mean correlation over tracks minus mean RMSE over tracks, each
  RMSE in units of its track's spread, so every track counts alike;
* a candidate is *admissible* when no track is worse than with the starting
  preset beyond noise: correlation lower by more than ``NOISE_CORRELATION``
  (on a track one of them predicts, correlation ``PREDICTED`` or more) or
  RMSE higher by more than ``NOISE_RMSE`` of the start's (or of the tracks'
  mean spread, if more: a track that only carries the capture's noise may
  not be fitted closer than its noise, but a change far below what the
  other tracks move is no change).

Timing parts change every track, and one set of dominance parameters
serves them all: what helps the jaw may cost the rounding.  So a timing part
may also be taken part of the way, its parameters moved by a share of
``SHARES`` from the start toward the fit (in log space).  The check starts
from the best admissible candidate that moves every timing part by one share
(or from the start), then raises one part's share at a time, the change that
raises the score most first, while the candidate stays admissible and the
score rises by at least ``MIN_GAIN`` and by more than the standard error of
that rise over the held-out clips (a rise one clip alone makes is chance).  Pose parts change only their own
tracks, so with each timing candidate each pose part is learned when that
lowers its tracks' RMSE beyond noise (``NOISE_RMSE``), raises their score
and keeps them admissible, else kept.  The blends
are the fit's own model, which is the engine's synthesis (the test
``test_fit_model_is_the_engines_synthesis``).
"""

from __future__ import annotations

import numpy as np

from . import proxies
from .evaluate import track_correlation
from .model import Model
from .parts import Part

NOISE_CORRELATION = 0.01
#: A track neither preset predicts with a correlation this high is noise to
#: both: its correlations differ by chance, so only its RMSE is guarded.
PREDICTED = 0.3
NOISE_RMSE = 0.005
MIN_GAIN = 1e-3
SHARES = (0.25, 0.5, 1.0)


class Judge:
    """The held-out check of candidate presets over every fold."""

    def __init__(self, setup, prepared, folds, timing: list[Part], poses: list[Part]):
        """``folds``: (train indices, held-out indices, :class:`.fit.Fit`) per fold."""
        self.s, self.prepared, self.folds = setup, prepared, folds
        self.timing, self.poses = timing, poses
        self.measured = [[prepared[i].aligned(f.delay) for i in ho] for _tr, ho, f in folds]
        Y = np.concatenate([y for ys in self.measured for y in ys])
        self.spread = np.maximum(Y.std(axis=0), 1e-9)
        self.scale = float(self.spread.mean())   # how much the tracks move, all together
        self.base = self.means(self.table(self._predict({})[0]))

    # --- predictions ------------------------------------------------------------------

    def _blends(self, clips, P) -> list[np.ndarray]:
        s = self.s
        model = Model(clips, s.fps, s.base["smoothing"], [], s.base["closure"]["strength"])
        return model.blend(P, False)[0]

    def _predict(self, timing: dict):
        """Held-out predictions per fold: (with the starting poses, with the
        fold's learned poses or None)."""
        s = self.s
        start, learned = [], []
        for tr, ho, f in self.folds:
            P = shift(s.P0, f.Pm, timing)
            hold = [self.prepared[i] for i in ho]
            if s.calibrated:
                train = [self.prepared[i] for i in tr]
                raw_tr = [np.clip(b * s.gain0, 0, 1) @ s.M0 for b in self._blends(train, P)]
                gain, offset = proxies.calibrate(raw_tr, [c.aligned(f.delay) for c in train])
                start.append([(np.clip(b * s.gain0, 0, 1) @ s.M0) * gain + offset for b in self._blends(hold, P)])
                continue
            bl = self._blends(hold, P)
            start.append([np.clip(np.clip(b * s.gain0, 0, 1) @ s.M0, 0, 1) for b in bl])
            learned.append([np.clip(np.clip(b, 0, 1) @ f.M, 0, 1) for b in bl])
        return start, (None if s.calibrated else learned)

    # --- scores ----------------------------------------------------------------------------

    def table(self, preds) -> tuple[np.ndarray, np.ndarray]:
        """(correlation, RMSE), each (held-out clips, tracks); NaN where the
        measured track does not move."""
        corr, rmse = [], []
        for fold_preds, ys in zip(preds, self.measured):
            for p, y in zip(fold_preds, ys):
                c = [track_correlation(p[:, j], y[:, j]) for j in range(y.shape[1])]
                corr.append([np.nan if v is None else v for v in c])
                rmse.append(np.sqrt(((p - y) ** 2).mean(axis=0)))
        return np.array(corr, float), np.array(rmse, float)

    @staticmethod
    def means(tab) -> list[tuple]:
        """Per track: (mean correlation or None, mean RMSE) over the held-out clips."""
        corr, rmse = tab
        out = []
        for j in range(corr.shape[1]):
            c = corr[:, j][~np.isnan(corr[:, j])]
            out.append((float(c.mean()) if len(c) else None, float(rmse[:, j].mean())))
        return out

    def score(self, means, tracks=None) -> float:
        """Mean correlation minus mean RMSE in units of each track's spread."""
        tracks = range(len(means)) if tracks is None else tracks
        cs = [means[j][0] for j in tracks if means[j][0] is not None]
        rs = [means[j][1] / self.spread[j] for j in tracks]
        return (float(np.mean(cs)) if cs else 0.0) - float(np.mean(rs))

    def per_clip(self, tab) -> np.ndarray:
        """The score of each held-out clip."""
        corr, rmse = tab
        c = np.array([np.nanmean(row) if np.isfinite(row).any() else 0.0 for row in corr])
        return c - (rmse / self.spread).mean(axis=1)

    def worse(self, means, tracks=None) -> list[int]:
        """Tracks worse than with the starting preset beyond noise."""
        tracks = range(len(means)) if tracks is None else tracks
        out = []
        for j in tracks:
            (c, r), (c0, r0) = means[j], self.base[j]
            signal = c is not None and c0 is not None and max(abs(c), abs(c0)) >= PREDICTED
            if (signal and c < c0 - NOISE_CORRELATION) or r > r0 + NOISE_RMSE * max(r0, self.scale) + 1e-12:
                out.append(j)
        return out

    @staticmethod
    def gains(new, old) -> bool:
        """Whether ``new`` beats ``old`` (per-clip scores) by at least
        ``MIN_GAIN`` on average, and by more than the spread of the gain
        over the held-out clips (its standard error)."""
        d = np.asarray(new) - np.asarray(old)
        if d.mean() < MIN_GAIN:
            return False
        return len(d) < 2 or d.mean() > d.std(ddof=1) / np.sqrt(len(d))

    # --- the choice ------------------------------------------------------------------------

    def candidate(self, timing: dict):
        """(score, per-track means, pose parts learned, per-clip scores) of
        the timing parts moved by the shares ``timing`` with the best
        admissible choice of pose parts."""
        start, learned = self._predict(timing)
        corr, rmse = self.table(start)
        means = self.means((corr, rmse))
        chosen = set()
        if learned is not None and self.poses:
            lcorr, lrmse = self.table(learned)
            lmeans = self.means((lcorr, lrmse))
            for part in self.poses:
                cols = list(part.cells)
                closer = sum(lmeans[j][1] for j in cols) < (1 - NOISE_RMSE) * sum(means[j][1] for j in cols)
                gain = self.score(lmeans, cols) - self.score(means, cols)
                if not closer or gain < MIN_GAIN or self.worse(lmeans, cols):
                    continue
                chosen.add(part)
                corr[:, cols], rmse[:, cols] = lcorr[:, cols], lrmse[:, cols]
                for j in cols:
                    means[j] = lmeans[j]
        return self.score(means), means, frozenset(chosen), self.per_clip((corr, rmse))

    def choose(self) -> tuple[dict, frozenset, dict]:
        """(share of each timing part learned, pose parts learned, what the check found)."""
        timing: dict = {}
        best, _means, best_poses, best_clips = self.candidate(timing)
        start_score = self.score(self.base)
        steps = []
        for t in SHARES:
            every = {part: t for part in self.timing}
            sc, means, poses, clips = self.candidate(every)
            if every and not self.worse(means) and self.gains(clips, best_clips):
                timing, best, best_poses, best_clips = every, sc, poses, clips
                steps.append({"every timing part": t, "score": round(sc, 4)})
        while True:
            tried = []
            for part in self.timing:
                for t in SHARES:
                    if t <= timing.get(part, 0.0):
                        continue
                    cand = dict(timing)
                    cand[part] = t
                    sc, means, poses, clips = self.candidate(cand)
                    if not self.worse(means) and self.gains(clips, best_clips):
                        tried.append((sc, part.name, t, cand, poses, clips))
            if not tried:
                break
            sc, name, t, cand, poses, clips = max(tried, key=lambda c: (c[0], c[1], -c[2]))
            timing, best, best_poses, best_clips = cand, sc, poses, clips
            steps.append({name: t, "score": round(sc, 4)})
        found = {"start_score": round(start_score, 4), "score": round(best, 4), "steps": steps,
                 "noise": {"correlation": NOISE_CORRELATION, "rmse": NOISE_RMSE, "predicted": PREDICTED}}
        return timing, best_poses, found


def shift(P0: np.ndarray, Pm: np.ndarray, timing: dict) -> np.ndarray:
    """The starting parameters with each timing part moved by its share
    toward the fitted ones (in log space; share 1: the fitted values)."""
    P = P0.copy()
    for part, t in timing.items():
        for k, p in part.cells:
            P[k, p] = float(np.exp(np.log(P0[k, p]) + t * (np.log(Pm[k, p]) - np.log(P0[k, p]))))
    return P
