"""The lip-sync engine: plain Python and numpy, no Blender.

    from addon.engine import LineSettings, analyze
    result = analyze("line.wav", "Hello there!", LineSettings.of(emotion="happy", fps=24))
    result.curves      # (frames, visemes), weights in [0, 1]

The engine is built in layers, each importing only from the layers below
it: the basics (errors, data files, frame rates), then language and audio
decoding, then the data a studio extends and the voice's measures
(visemes, conventions, presets, prosody, arousal) with forced alignment,
then the animation (coarticulation, emotion over the line, the expression
layer, a line's settings, rendering, a bone rig's poses blended), then the
whole job (:mod:`.pipeline`, its :mod:`.output`, the :mod:`.keys` a target
gets from it) and :mod:`.learning`, and on top the programs
(:mod:`.batch`, :mod:`.cli`).  Which module sits in which layer is written
down once, in ``tests/test_structure.py``, which fails on an import cycle
or an upward import.
"""

from .errors import LipSyncError
from .output import Result
from .pipeline import analyze
from .settings import LineSettings

__all__ = ["analyze", "LineSettings", "Result", "LipSyncError"]
