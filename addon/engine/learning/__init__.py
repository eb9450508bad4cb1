"""Learning an emotion preset from example animation or captured motion.

Modules: :mod:`.data` (clips and their preparation), :mod:`.proxies` (what
a track means: shape key, articulatory proxy or viseme, and calibration),
:mod:`.model` (the dominance blend the fit adjusts, and the engine's
synthesis path), :mod:`.delay` (the capture's delay to the sound),
:mod:`.fit` (the fit and the preset it makes), :mod:`.parts` and
:mod:`.select` (which parts of the fit the held-out clips support),
:mod:`.evaluate` (scores of predicted against measured tracks),
:mod:`.report` (the comparison with the starting preset) and
:mod:`.progress` (how far it has got).  The names below are what the
command line, the Blender add-on and the benchmarks use.
"""

from .data import Prepared, TrainingClip, load_clip, prepare
from .evaluate import rmse_report
from .fit import Learned, learn, split_holdout
from .model import BOUNDS, PARAMS, REFERENCE_CLASS, synthesise
from .progress import PHASES, Console
from .report import summary_text, table

__all__ = ["BOUNDS", "Console", "PARAMS", "PHASES", "REFERENCE_CLASS", "Learned", "Prepared", "TrainingClip",
           "learn", "load_clip", "prepare", "rmse_report", "split_holdout", "summary_text", "synthesise", "table"]
