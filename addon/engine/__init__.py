"""The lip-sync engine: plain Python and numpy, no Blender.

    from addon.engine import analyze
    result = analyze("line.wav", "Hello there!", emotion="happy", fps=24)
    result.curves      # (frames, visemes), weights in [0, 1]

Modules: :mod:`.text` (script -> words), :mod:`.pronounce` (words -> ARPAbet),
:mod:`.align` (pocketsphinx forced alignment), :mod:`.importers` (TextGrid,
Rhubarb, Papagayo), :mod:`.prosody` and :mod:`.weights` (equations 1-2),
:mod:`.visemes` and :mod:`.presets` (data files), :mod:`.coarticulation`
(rule and dominance models), :mod:`.pipeline` (all of it).
"""

from .errors import LipSyncError
from .pipeline import Result, analyze

__all__ = ["analyze", "Result", "LipSyncError"]
