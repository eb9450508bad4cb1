"""Learn an emotion preset from example animation (the second paper, 5.2-5.3).

Input: clips of one character speaking in one emotion, each with its audio,
its phoneme timings (from the aligner or an imported alignment) and the
measured tracks: shape-key values per frame, hand-keyed in Blender or
captured (ARKit CSV, see :mod:`.capture`).

Model: the one the engine synthesises with.  Each viseme event i of the
clip has a dominance function D_i(t) with its class's (alpha, theta, phi, c)
and the engine's plateau, and a target: its weight w_i (equations 1-2) times
the viseme's pose.  The predicted tracks are

    Y(t) = smooth( sum_i D_i(t) w_i e_{v_i} / sum_i D_i(t) ) @ M

where M (visemes x channels) holds each viseme's pose.  As in the paper the
poses live in a PCA basis of the training tracks: M = A P^T with P the
components keeping ``variance`` (default 99 %) of the tracks' energy.

Fit: Levenberg-Marquardt on the dominance parameters in log space (bounds
keep every alpha, theta, phi positive and finite, c in [0.5, 2]), with the
analytic Jacobian, while the poses A, linear in the model, are solved
exactly at every step (variable projection).  The vowels' alpha stays at the
base preset's value: only ratios of alphas change the blend.  A share of the
clips is held out; training stops when the held-out error has not fallen for
``patience`` steps, and the parameters with the lowest held-out error win.

Output: a preset in the built-in format (the base preset of the same
emotion, with the fitted dominance parameters and a ``learned`` section with
the viseme set and poses), and a report: per-channel RMSE and variance
explained on training and held-out clips, for the learned preset and for the
built-in one, both through the engine's full synthesis path.
"""

from __future__ import annotations

from .learning.data import Prepared, TrainingClip, load_clip, prepare
from .learning.evaluate import rmse_report
from .learning.fit import Learned, learn, split_holdout
from .learning.model import BOUNDS, PARAMS, REFERENCE_CLASS, synthesise

_prepare = prepare          # the name tests and benchmarks use to make example tracks

__all__ = ["BOUNDS", "PARAMS", "REFERENCE_CLASS", "Learned", "Prepared", "TrainingClip", "learn", "load_clip",
           "prepare", "rmse_report", "split_holdout", "synthesise"]
