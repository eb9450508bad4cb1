"""Viseme sets: data files mapping ARPAbet phonemes to visemes.

A set is a JSON file::

    {
      "name": "default",
      "description": "...",
      "visemes": {"MBP": {"range": [0.9, 1.0, 1.0]}, ...},   # W_min, W_p, W_max
      "phonemes": {"P": "MBP", "OW": ["OHH", "UUU"], "SIL": null, ...},
      "shape_keys": {"PP": {"mouthClose": 1.0}},             # optional
      "aliases": {"MBP": ["M_B_P"]}                           # optional
    }

Every ARPAbet phoneme must be mapped; a list splits the phoneme (a
diphthong) into visemes that share its span in order; ``SIL`` maps to a rest
viseme or ``null``.  ``shape_keys`` gives each viseme a default mix of shape
keys (the ARKit set drives several blendshapes per viseme); without it a
viseme drives the shape key of its own name.  ``aliases`` are other shape-key
names the Blender add-on recognises when it maps a mesh automatically.

Built-in sets live in ``data/visemes``; a user's own set is any file of this
form, passed by path.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .datafile import read_object
from .errors import PresetError
from .language.phonemes import PHONEMES, SILENCE

DATA = Path(__file__).parent / "data" / "visemes"


@dataclass
class VisemeSet:
    name: str
    description: str
    visemes: list[str]                           # column order
    ranges: np.ndarray                           # (n_visemes, 3)
    phonemes: dict[str, list[str]]               # phone -> visemes (SIL may map to [])
    shape_keys: dict[str, dict[str, float]] = field(default_factory=dict)
    aliases: dict[str, list[str]] = field(default_factory=dict)

    def index(self, viseme: str) -> int:
        return self.visemes.index(viseme)

    @property
    def rest(self) -> str | None:
        v = self.phonemes.get(SILENCE) or []
        return v[0] if v else None

    def of(self, phone: str) -> list[str]:
        return self.phonemes[phone]

    def mix(self, viseme: str) -> dict[str, float]:
        """Default shape keys this viseme drives, with their weights."""
        return self.shape_keys.get(viseme, {viseme: 1.0})


def with_targets(vset: VisemeSet, targets: dict[str, dict[str, float]]) -> VisemeSet:
    """The set with each viseme's shape-key mix replaced (a learned preset's
    poses); visemes without a learned pose drive nothing."""
    unknown = sorted(set(targets) - set(vset.visemes))
    if unknown:
        raise PresetError(vset.name, "learned.targets", f"names visemes not in the set: {', '.join(unknown)}")
    mixes = {v: dict(targets.get(v, {})) for v in vset.visemes}
    return VisemeSet(vset.name, vset.description, list(vset.visemes), vset.ranges.copy(), dict(vset.phonemes),
                     mixes, dict(vset.aliases))


def builtin_names() -> list[str]:
    return sorted(p.stem for p in DATA.glob("*.json"))


def load(name_or_path: str | os.PathLike) -> VisemeSet:
    """Load a built-in set by name or a user's set from a file."""
    path = Path(name_or_path)
    if not path.suffix and not path.exists():
        path = DATA / f"{name_or_path}.json"
        if not path.is_file():
            raise PresetError(str(name_or_path), "name",
                              f"is not a viseme set; built-in sets: {', '.join(builtin_names())}")
    return from_dict(read_object(path), str(path))


def from_dict(doc: dict, source: str = "viseme set") -> VisemeSet:
    def need(key, kind):
        if key not in doc:
            raise PresetError(source, key, "is missing")
        if not isinstance(doc[key], kind):
            raise PresetError(source, key, f"must be a {kind.__name__}")
        return doc[key]

    if not isinstance(doc, dict):
        raise PresetError(source, "(top level)", "must be a JSON object")
    name = need("name", str)
    vis = need("visemes", dict)
    if not vis:
        raise PresetError(source, "visemes", "is empty")
    names = list(vis)
    ranges = np.zeros((len(names), 3))
    for k, v in enumerate(names):
        r = vis[v].get("range") if isinstance(vis[v], dict) else None
        if not (isinstance(r, list) and len(r) == 3 and all(isinstance(x, (int, float)) for x in r)):
            raise PresetError(source, f"visemes.{v}.range", "must be three numbers [W_min, W_p, W_max]")
        if not (0 <= r[0] <= r[1] <= r[2] <= 1):
            raise PresetError(source, f"visemes.{v}.range", f"must satisfy 0 <= W_min <= W_p <= W_max <= 1, got {r}")
        ranges[k] = r
    table = need("phonemes", dict)
    phonemes: dict[str, list[str]] = {}
    for p, target in table.items():
        if p not in PHONEMES and p != SILENCE:
            raise PresetError(source, f"phonemes.{p}", "is not an ARPAbet phoneme")
        targets = [] if target is None else ([target] if isinstance(target, str) else target)
        if not isinstance(targets, list) or any(t not in vis for t in targets):
            raise PresetError(source, f"phonemes.{p}", f"names a viseme that is not in 'visemes': {target!r}")
        if not targets and p != SILENCE:
            raise PresetError(source, f"phonemes.{p}", "must name at least one viseme")
        phonemes[p] = list(targets)
    missing = sorted(PHONEMES - set(phonemes))
    if missing:
        raise PresetError(source, "phonemes", f"does not map {', '.join(missing)}")
    phonemes.setdefault(SILENCE, [])
    shape_keys = doc.get("shape_keys", {})
    for v, mix in shape_keys.items():
        if v not in vis:
            raise PresetError(source, f"shape_keys.{v}", "is not a viseme of this set")
        if not isinstance(mix, dict) or any(not isinstance(w, (int, float)) for w in mix.values()):
            raise PresetError(source, f"shape_keys.{v}", "must map shape-key names to numbers")
    aliases = doc.get("aliases", {})
    return VisemeSet(name, doc.get("description", ""), names, ranges, phonemes,
                     {k: dict(v) for k, v in shape_keys.items()}, {k: list(v) for k, v in aliases.items()})
