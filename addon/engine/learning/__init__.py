"""Learning an emotion preset from example animation or captured motion.

Modules: :mod:`.data` (clips and their preparation), :mod:`.model` (the
dominance blend the fit adjusts, and the engine's synthesis path),
:mod:`.fit` (the fit and the preset it makes), :mod:`.evaluate` (how close
predicted tracks come to measured ones).
"""
