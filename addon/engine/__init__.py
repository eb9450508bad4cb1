"""The lip-sync engine: plain Python and numpy, no Blender.

    from addon.engine import analyze
    result = analyze("line.wav", "Hello there!", emotion="happy", fps=24)
    result.curves      # (frames, visemes), weights in [0, 1]

The engine's layers, from the bottom (a module imports only from layers
below its own; ``tests/test_structure.py`` checks it):

1. :mod:`.errors`, :mod:`.datafile`, :mod:`.framerate`, :mod:`.smoothing`;
2. :mod:`.language` (script -> words -> phones, IPA), :mod:`.audio` and
   :mod:`.wavstream` (decoding), :mod:`.pauses` (timing settings, rest);
3. the data a studio extends: :mod:`.visemes`, :mod:`.conventions`,
   :mod:`.presets`; the voice: :mod:`.prosody`, :mod:`.weights`,
   :mod:`.arousal`; :mod:`.alignment` (forced alignment) and
   :mod:`.importers` (TextGrid, Rhubarb, Papagayo alignments);
4. the animation: :mod:`.coarticulation`, :mod:`.emotion_track`, :mod:`.expression`, :mod:`.render`,
   :mod:`.mapping`, :mod:`.key_reduction`, :mod:`.pose_blend` (a bone rig's poses blended);
5. :mod:`.output` (the result and its files), :mod:`.pipeline` (the whole
   job), :mod:`.learning` (presets learned from captured motion);
6. the programs: :mod:`.batch`, :mod:`.cli`, :mod:`.arousal_cli`.
"""

from .errors import LipSyncError
from .output import Result
from .pipeline import analyze

__all__ = ["analyze", "Result", "LipSyncError"]
