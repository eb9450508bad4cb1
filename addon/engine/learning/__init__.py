"""Learning an emotion preset from example animation or captured motion.

Modules: :mod:`.data` (clips and their preparation), :mod:`.proxies` (what
a track means: shape key, articulatory proxy or viseme, and calibration),
:mod:`.model` (the dominance blend the fit adjusts, and the engine's
synthesis path), :mod:`.delay` (the capture's delay to the sound),
:mod:`.fit` (the fit and the preset it makes), :mod:`.parts` and
:mod:`.select` (which parts of the fit the held-out clips support),
:mod:`.evaluate` (scores of predicted against measured tracks),
:mod:`.report` (the comparison with the starting preset) and
:mod:`.progress` (how far it has got).
"""
