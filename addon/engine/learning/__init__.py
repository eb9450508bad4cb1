"""Learning an emotion preset from example animation or captured motion.

Modules: :mod:`.data` (clips and their preparation), :mod:`.proxies` (what
a track means: shape key, articulatory proxy or viseme, and calibration),
:mod:`.model` (the dominance blend the fit adjusts, and the engine's
synthesis path), :mod:`.delay` (the capture's delay to the sound),
:mod:`.fit` (the fit and the preset it makes), :mod:`.evaluate` (scores of
predicted against measured tracks) and :mod:`.report` (the comparison with
the starting preset).
"""
