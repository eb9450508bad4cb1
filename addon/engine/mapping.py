"""From viseme curves to shape-key curves.

A *mapping* says which shape keys each viseme drives and how strongly:
``{"PP": {"mouthClose": 1.0, "mouthPressLeft": 0.4}, "aa": {"viseme_aa": 1.0}}``.
:func:`auto_map` fills one in by matching a mesh's shape-key names against
the naming conventions riggers use (the viseme set's own names and aliases,
Oculus ``viseme_aa``, VRChat ``vrc.v_aa``, ARKit ``jawOpen`` ...), and
:func:`shape_key_curves` mixes the viseme curves into one curve per shape key.
"""

from __future__ import annotations

import re

import numpy as np

from .visemes import VisemeSet

#: Prefixes rigs put in front of a viseme's own name.
PREFIXES = ("", "viseme_", "vis_", "v_", "vrc.v_", "mouth_", "mth_", "lipsync_")


def canonical(name: str) -> str:
    """Shape-key names compared without case, spaces, dots, dashes or underscores."""
    return re.sub(r"[\s._\-]+", "", name).lower()


def candidates(vset: VisemeSet, viseme: str) -> list[dict[str, float]]:
    """Mixes to look for, best first: the set's own mix, then single keys."""
    out = []
    if viseme in vset.shape_keys:
        out.append(dict(vset.shape_keys[viseme]))
    for name in [viseme] + list(vset.aliases.get(viseme, [])):
        for prefix in PREFIXES:
            out.append({prefix + name: 1.0})
    return out


def auto_map(vset: VisemeSet, shape_keys: list[str]) -> dict[str, dict[str, float]]:
    """Viseme -> {shape key: weight} for the visemes this mesh can show.

    A mix (the ARKit set) keeps the blendshapes the mesh has; a viseme
    none of whose candidates exists is left out, so the caller can list it
    as unmapped.  The basis key (the first one) is never driven.
    """
    names = list(shape_keys[1:]) if shape_keys else []
    by_canon: dict[str, str] = {}
    for n in names:
        by_canon.setdefault(canonical(n), n)
    out: dict[str, dict[str, float]] = {}
    for v in vset.visemes:
        for mix in candidates(vset, v):
            found = {by_canon[canonical(k)]: float(w) for k, w in mix.items()
                     if canonical(k) in by_canon and w > 0}
            if found:
                out[v] = found
                break
    return out


def unmapped(vset: VisemeSet, mapping: dict[str, dict[str, float]]) -> list[str]:
    """Visemes that drive nothing.  The rest viseme is allowed to (a relaxed
    mouth is what the basis shape shows)."""
    return [v for v in vset.visemes if not mapping.get(v) and v != vset.rest]


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


def coverage(vset: VisemeSet, mapping: dict[str, dict[str, float]]) -> float:
    """Share of the set's visemes (the rest viseme aside) that drive a key."""
    speaking = [v for v in vset.visemes if v != vset.rest]
    return sum(1 for v in speaking if mapping.get(v)) / max(1, len(speaking))


def best_set(sets: list[VisemeSet], shape_keys: list[str], prefer: str | None = None
             ) -> tuple[VisemeSet, dict[str, dict[str, float]]] | None:
    """The set whose visemes this mesh covers best, and its mapping.

    Ties go to ``prefer`` (the mesh's current set), then to a set matched
    through its own names rather than through a mix (so a mesh with Oculus
    ``viseme_aa`` keys gets the Oculus set, not the ARKit set that also
    recognises those names).
    """
    scored = []
    for order, vs in enumerate(sets):
        mp = auto_map(vs, shape_keys)
        if not mp:
            continue
        via_mix = any(v in vs.shape_keys and len(vs.shape_keys[v]) > 0 and set(mix) <= set(vs.shape_keys[v])
                      for v, mix in mp.items())
        own_terms = via_mix or not vs.shape_keys  # matched the way the set is meant to be used
        scored.append(((coverage(vs, mp), vs.name == prefer, own_terms, -order), vs, mp))
    if not scored:
        return None
    _score, vs, mp = max(scored, key=lambda s: s[0])
    return vs, mp
