"""From viseme curves to shape-key curves.

A *mapping* says which shape keys each viseme drives and how strongly:
``{"PP": {"mouthClose": 1.0, "mouthPressLeft": 0.4}, "aa": {"viseme_aa": 1.0}}``.
:func:`auto_map` fills one in from a viseme set's own names (real
characters' naming conventions are :mod:`.conventions`), and
:func:`shape_key_curves` mixes the viseme curves into one curve per shape key.
"""

from __future__ import annotations

import numpy as np

from . import conventions
from .visemes import VisemeSet


def auto_map(vset: VisemeSet, names: list[str]) -> dict[str, dict[str, float]]:
    """Viseme -> {name: weight} by the set's own names, aliases and mixes,
    onto ``names``: capture channels, or a mesh's shape keys without its
    basis (every name given may be driven, whatever its place).  A mix keeps
    the names there are; a viseme none of whose candidates exists is left
    out, so the caller can list it as unmapped.  Real characters' naming
    conventions: :mod:`.conventions`."""
    conv = conventions.from_viseme_set(vset)
    return conventions.match(conv, vset, conventions.NameIndex(names)).mapping


def unmapped(vset: VisemeSet, mapping: dict[str, dict[str, float]]) -> list[str]:
    """Visemes that drive nothing.  The rest viseme is allowed to (a relaxed
    mouth is what the basis shape shows), and so is a viseme mapped to an
    empty mix: the convention says the basis shows it."""
    return conventions.unmapped(vset, mapping)


def shape_key_curves(curves: np.ndarray, visemes: list[str], mapping: dict[str, dict[str, float]]
                     ) -> tuple[list[str], np.ndarray]:
    """(frames, visemes) -> shape-key names and (frames, keys) values in [0, 1].

    A shape key driven by several visemes takes the weighted sum of their
    curves, clipped to 1.
    """
    keys: list[str] = []
    for v in visemes:
        for k in mapping.get(v, {}):
            if k not in keys:
                keys.append(k)
    mix = np.zeros((len(visemes), len(keys)))
    for i, v in enumerate(visemes):
        for k, w in mapping.get(v, {}).items():
            mix[i, keys.index(k)] = w
    out = np.clip(np.asarray(curves, dtype=float) @ mix, 0.0, 1.0) if keys else np.zeros((len(curves), 0))
    return keys, out
