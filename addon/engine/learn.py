"""Learn an emotion preset from example animation or captured motion (the
second paper, 5.2-5.3): the names the command line, the Blender add-on and
the tests use.  The method is described in :mod:`.learning.fit`; data
preparation in :mod:`.learning.data`, the fitted model in
:mod:`.learning.model`, track kinds and calibration in
:mod:`.learning.proxies`, the capture delay in :mod:`.learning.delay`,
the report in :mod:`.learning.report` and progress in
:mod:`.learning.progress`.
"""

from __future__ import annotations

from .learning.data import Prepared, TrainingClip, load_clip, prepare
from .learning.evaluate import rmse_report
from .learning.fit import Learned, learn, split_holdout
from .learning.model import BOUNDS, PARAMS, REFERENCE_CLASS, synthesise
from .learning.progress import PHASES, Console
from .learning.report import summary_text, table

_prepare = prepare          # the name tests and benchmarks use to make example tracks

__all__ = ["BOUNDS", "Console", "PARAMS", "PHASES", "REFERENCE_CLASS", "Learned", "Prepared", "TrainingClip",
           "learn", "load_clip", "prepare", "rmse_report", "split_holdout", "summary_text", "synthesise", "table"]
