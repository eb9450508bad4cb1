"""Shape-key naming conventions: how real characters name their mouth shapes.

Every character pipeline names its mouth shape keys its own way: Ready Player
Me and Oculus ``viseme_aa``, VRChat ``vrc.v_aa``, ARKit ``jawOpen`` and
``mouthClose``, VRoid ``Fcl_MTH_A``, Character Creator ``V_Open``, Daz
``eCTRLvAA`` ...  A *convention* is a JSON file in ``data/conventions`` that
says, for one of the engine's viseme sets, which of those keys show each
viseme::

    {
      "name": "oculus",
      "label": "Oculus / Ready Player Me visemes",
      "viseme_set": "oculus",
      "speech": true,                      # keys made for speech (preferred)
      "prefixes": ["", "mouth_"],          # optional, tried before each name
      "visemes": {
        "PP": ["viseme_PP"],               # alternatives, best first
        "ih": ["viseme_ih", "viseme_I"],
        "FF": [{"Fcl_MTH_I": 0.2, "Fcl_MTH_U": 0.1}],   # a weighted mix
        "sil": [{}]                        # {}: the basis shape shows it
      },
      "closure": {"viseme": "PP", "relax": "others",
                  "relative": {"mouthClose": "jawOpen"}}
    }

Names are compared without case or separators (``MouthClose``,
``mouth_close`` and ``mouthClose`` are one name), ``_L``/``_R`` stand for
``Left``/``Right``, and the prefixes exporters put in front of a name (a
mesh name and a dot, ``blendShape1.``, Character Creator's ``A37_``) are
looked through; those prefix patterns are data too (``data/naming.json``).
A viseme set's own viseme names and ``aliases`` make one more convention, so
a studio's own viseme set file is matched by its names without more work.

*Closure* is how the mesh shows lips meeting on /p b m/, applied to the
shape-key curves by :func:`apply_closure` with the engine's closure track
(1 while the lips must be closed):

* ``relax``: keys scaled by (1 - closure) so nothing holds the lips apart;
  ``"others"`` means every key the closure viseme does not drive (right for
  rigs whose basis shows closed lips: viseme rigs, five-vowel rigs);
* ``relative``: a key whose meaning is relative to another's, multiplied by
  that key's value.  ARKit's ``mouthClose`` closes the lips *of an open
  jaw*: lips meet when it equals ``jawOpen``, and above ``jawOpen`` they
  pass through each other, so it is driven as closure x ``jawOpen``.

A convention may also say which keys show the facial expression: an
``expression`` section maps FACS action units (``data/expression.json``) to
alternative mixes the same way, ``{"AU12": [{"mouthSmileLeft": 1,
"mouthSmileRight": 1}]}``.  :func:`expression_match` maps a mesh's keys by
whichever convention shows most of the units (a Ready Player Me avatar
speaks with its Oculus visemes and frowns with its ARKit blendshapes).

:func:`detect` picks the convention a mesh follows: the one that maps most of
its viseme set, then, among complete ones, one made for speech over ARKit's
facial-expression blendshapes (a Ready Player Me avatar carries both, and its
viseme keys are the ones built to be spoken with).
"""

from __future__ import annotations

import json
import os
import re
import unicodedata
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .datafile import read_object
from .errors import PresetError
from .visemes import VisemeSet

DATA = Path(__file__).parent / "data" / "conventions"
NAMING = Path(__file__).parent / "data" / "naming.json"
EXPRESSION = Path(__file__).parent / "data" / "expression.json"

#: Where a studio keeps its own convention files (``os.pathsep``-separated);
#: the Blender add-on adds its user folder.
ENV_DIRS = "EMOTIVE_LIPSYNC_CONVENTIONS"


@dataclass
class Closure:
    """How lips meet on this kind of rig (module docstring)."""

    viseme: str | None = None
    relax: list[str] | str = field(default_factory=list)
    relative: dict[str, str] = field(default_factory=dict)

    def relaxed_keys(self, mapping: dict[str, dict[str, float]]) -> set[str]:
        if self.relax == "others":
            own = set(mapping.get(self.viseme, {})) if self.viseme else set()
            driven = {k for mix in mapping.values() for k in mix}
            return driven - own - set(self.relative)
        return set(self.relax)

    def to_dict(self) -> dict:
        return {"viseme": self.viseme, "relax": self.relax, "relative": dict(self.relative)}

    @classmethod
    def from_json(cls, text: str) -> Closure:
        """A rule saved with :meth:`to_dict` (an empty or unreadable one: no rule)."""
        try:
            doc = json.loads(text) if text else {}
        except ValueError:
            doc = {}
        if not isinstance(doc, dict):
            doc = {}
        relax = doc.get("relax", [])
        relative = doc.get("relative", {})
        return cls(doc.get("viseme"), relax if relax == "others" or isinstance(relax, list) else [],
                   relative if isinstance(relative, dict) else {})


@dataclass
class Convention:
    name: str
    label: str
    viseme_set: str
    visemes: dict[str, list[dict[str, float]]]   # viseme -> alternative mixes, best first
    speech: bool = True
    prefixes: list[str] = field(default_factory=lambda: [""])
    closure: Closure = field(default_factory=Closure)
    description: str = ""
    source: str = ""
    expression: dict[str, list[dict[str, float]]] = field(default_factory=dict)   # FACS unit -> mixes


@dataclass
class Match:
    """A convention applied to one mesh's shape keys."""

    convention: Convention
    mapping: dict[str, dict[str, float]]    # viseme -> {shape key on the mesh: weight}; {} = the basis
    coverage: float                         # share of the speaking visemes shown, weighted by mix
    keys: int                               # distinct shape keys driven
    closure: Closure = field(default_factory=Closure)   # in the mesh's names

    @property
    def complete(self) -> bool:
        return self.coverage >= 0.999

    def describe(self, vset: VisemeSet) -> str:
        shown = sum(1 for v in vset.visemes if v in self.mapping and v != vset.rest)
        speaking = sum(1 for v in vset.visemes if v != vset.rest)
        return f"{self.convention.label}: {shown} of {speaking} visemes on {self.keys} shape keys"


# --- names ----------------------------------------------------------------------

def canonical(name: str) -> str:
    """A shape-key name compared without case, width (MMD's full-width
    characters) or separators; a trailing ``_L``/``.R`` side letter reads as
    ``Left``/``Right``."""
    name = unicodedata.normalize("NFKC", name)
    name = re.sub(r"(?<=[a-z0-9])[\s._\-]+([LlRr])$",
                  lambda m: "left" if m.group(1) in "Ll" else "right", name)
    return re.sub(r"[\s._\-]+", "", name).lower()


def _naming() -> list[re.Pattern]:
    doc = json.loads(NAMING.read_text(encoding="utf-8"))
    return [re.compile(p) for p in doc["strip_prefixes"]]


class NameIndex:
    """Names that may be driven (a mesh's shape keys without its basis, a
    capture's tracks), findable by their canonical forms.

    A name written exactly (up to case and separators) is found first; then
    the same name behind an exporter's prefix (``Wolf3D_Head.viseme_aa``,
    ``A37_Mouth_Close``, the mesh's own name).  Every name given is indexed:
    the caller that holds a mesh's key blocks leaves out the basis
    (:func:`detect`).
    """

    def __init__(self, names: list[str], mesh_names: tuple[str, ...] = ()):
        names = list(names)
        self.exact: dict[str, str] = {}
        self.behind_prefix: dict[str, str] = {}
        patterns = _naming() + [re.compile(re.escape(m) + r"[\s._:|\-]+", re.IGNORECASE)
                                for m in mesh_names if m]
        for n in names:
            self.exact.setdefault(canonical(n), n)
        for n in names:
            rests, seen = [n], set()
            while rests:   # prefixes may stack: "Head.A37_Mouth_Close"
                rest = rests.pop()
                for pat in patterns:
                    m = pat.match(rest)
                    if m and 0 < m.end() < len(rest) and rest[m.end():] not in seen:
                        seen.add(rest[m.end():])
                        rests.append(rest[m.end():])
                        self.behind_prefix.setdefault(canonical(rest[m.end():]), n)

    def find(self, wanted: str) -> str | None:
        c = canonical(wanted)
        return self.exact.get(c) or self.behind_prefix.get(c)


# --- loading ----------------------------------------------------------------------

def builtin_names() -> list[str]:
    return sorted(p.stem for p in DATA.glob("*.json"))


def user_dirs() -> list[Path]:
    return [Path(d) for d in os.environ.get(ENV_DIRS, "").split(os.pathsep) if d]


def load(path: str | os.PathLike) -> Convention:
    path = Path(path)
    if not path.suffix and not path.exists():
        path = DATA / f"{path}.json"
    return from_dict(read_object(path), str(path))


#: In a folder of conventions, the file that names a character's gesture
#: channels (blinks, gaze, head: :func:`.gestures.check_table`), not a convention.
GESTURES_FILE = "gestures.json"


def load_all(extra_dirs: list[str | os.PathLike] = ()) -> list[Convention]:
    """The built-in conventions, then the user's (a user file with a
    built-in's name replaces it); :data:`GESTURES_FILE` is not one."""
    out: dict[str, Convention] = {}
    for folder in [DATA] + [Path(d) for d in extra_dirs] + user_dirs():
        if not Path(folder).is_dir():
            continue
        for p in sorted(Path(folder).glob("*.json")):
            if p.name == GESTURES_FILE:
                continue
            conv = load(p)
            out[conv.name] = conv
    return list(out.values())


def _mix(value, source: str, where: str) -> dict[str, float]:
    if isinstance(value, str):
        return {value: 1.0}
    if isinstance(value, dict) and all(isinstance(k, str) and isinstance(w, (int, float)) and w >= 0
                                       for k, w in value.items()):
        return {k: float(w) for k, w in value.items()}
    raise PresetError(source, where, "must be a shape-key name or an object of shape-key names to weights >= 0")


def from_dict(doc: dict, source: str = "convention") -> Convention:
    if not isinstance(doc, dict):
        raise PresetError(source, "(top level)", "must be a JSON object")
    for key, kind in (("name", str), ("viseme_set", str)):
        if not isinstance(doc.get(key), kind):
            raise PresetError(source, key, "is missing or not a string")
    from . import visemes as visemes_mod

    vset = visemes_mod.load(doc["viseme_set"])
    table = doc.get("visemes")
    mixes: dict[str, list[dict[str, float]]] = {}
    if table is None:
        # The viseme set's own mixes (the ARKit set drives ARKit blendshapes).
        if not vset.shape_keys:
            raise PresetError(source, "visemes", "is missing (and the viseme set has no shape-key mixes)")
        mixes = {v: [dict(m)] for v, m in vset.shape_keys.items()}
    elif not isinstance(table, dict):
        raise PresetError(source, "visemes", "must map visemes to lists of shape-key names or mixes")
    else:
        for v, alts in table.items():
            if v not in vset.visemes:
                raise PresetError(source, f"visemes.{v}", f"is not a viseme of the set {vset.name!r}")
            alts = alts if isinstance(alts, list) else [alts]
            mixes[v] = [_mix(a, source, f"visemes.{v}") for a in alts]
    cl = doc.get("closure", {})
    if not isinstance(cl, dict):
        raise PresetError(source, "closure", "must be an object")
    relax = cl.get("relax", [])
    if not (relax == "others" or (isinstance(relax, list) and all(isinstance(k, str) for k in relax))):
        raise PresetError(source, "closure.relax", "must be \"others\" or a list of shape-key names")
    relative = cl.get("relative", {})
    if not (isinstance(relative, dict) and all(isinstance(v, str) for v in relative.values())):
        raise PresetError(source, "closure.relative", "must map shape-key names to shape-key names")
    viseme = cl.get("viseme")
    if viseme is not None and viseme not in vset.visemes:
        raise PresetError(source, "closure.viseme", f"is not a viseme of the set {vset.name!r}")
    prefixes = doc.get("prefixes", [""])
    if not (isinstance(prefixes, list) and all(isinstance(p, str) for p in prefixes)):
        raise PresetError(source, "prefixes", "must be a list of strings")
    return Convention(doc["name"], doc.get("label", doc["name"]), vset.name, mixes, bool(doc.get("speech", True)),
                      prefixes or [""], Closure(viseme, relax, dict(relative)), doc.get("description", ""),
                      source, _expression_section(doc.get("expression", {}), source))


def _expression_section(table, source: str) -> dict[str, list[dict[str, float]]]:
    if not isinstance(table, dict):
        raise PresetError(source, "expression", "must map FACS action units (AU12 ...) to lists of shape-key mixes")
    units = read_object(EXPRESSION)["units"]
    out = {}
    for unit, alts in table.items():
        if unit not in units:
            raise PresetError(source, f"expression.{unit}",
                              f"is not an action unit this add-on knows (expected one of: {', '.join(units)})")
        alts = alts if isinstance(alts, list) else [alts]
        out[unit] = [_mix(a, source, f"expression.{unit}") for a in alts]
        if any(not mix for mix in out[unit]):
            raise PresetError(source, f"expression.{unit}", "must name at least one shape key in each mix")
    return out


def from_viseme_set(vset: VisemeSet) -> Convention:
    """A set's own names (and its ``aliases``) as a convention: how a
    studio's own viseme set file is matched."""
    mixes = {v: ([dict(vset.shape_keys[v])] if vset.shape_keys.get(v) else [])
             + [{n: 1.0} for n in [v] + list(vset.aliases.get(v, []))] for v in vset.visemes}
    return Convention(f"{vset.name} names", f"{vset.name} viseme names", vset.name, mixes, True,
                      ["", "viseme_", "vis_", "v_", "mouth_", "mth_", "lipsync_"], Closure())


# --- matching -----------------------------------------------------------------------

def match(conv: Convention, vset: VisemeSet, index: NameIndex) -> Match:
    """Map ``conv``'s visemes onto the mesh's keys.  A mix keeps the keys the
    mesh has; of several alternatives the one that keeps most of its weight
    wins."""
    mapping: dict[str, dict[str, float]] = {}
    shown = 0.0
    speaking = [v for v in vset.visemes if v != vset.rest]
    for v in vset.visemes:
        best, best_share = None, 0.0
        for alt in conv.visemes.get(v, []):
            if not alt:            # the basis shows it
                if best is None:
                    best, best_share = {}, 1.0
                continue
            found: dict[str, float] = {}
            kept = 0.0
            for key, w in alt.items():
                actual = next((a for a in (index.find(p + key) for p in conv.prefixes) if a), None)
                if actual is not None:
                    found[actual] = w
                    kept += w
            share = kept / max(sum(alt.values()), 1e-9)
            if found and share > best_share + 1e-9:
                best, best_share = found, share
        if best is not None:
            mapping[v] = best
            if v in speaking:
                shown += best_share
    keys = {k for mix in mapping.values() for k in mix}
    if not keys:
        return Match(conv, {}, 0.0, 0)
    return Match(conv, mapping, shown / max(1, len(speaking)), len(keys), resolve_closure(conv, index))


def resolve_closure(conv: Convention, index: NameIndex) -> Closure:
    """``conv``'s closure rule in the mesh's own shape-key names."""
    def find(key):
        return next((a for a in (index.find(p + key) for p in conv.prefixes) if a), None)

    cl = conv.closure
    relax = cl.relax if cl.relax == "others" else [a for a in map(find, cl.relax) if a]
    relative = {find(k): find(r) for k, r in cl.relative.items() if find(k) and find(r)}
    return Closure(cl.viseme, relax, relative)


def detect(shape_keys: list[str], conventions: list[Convention], viseme_sets: dict[str, VisemeSet],
           mesh_names: tuple[str, ...] = (), viseme_set: str | None = None) -> Match | None:
    """The convention the mesh follows (module docstring), or None.

    ``shape_keys``: the mesh's key blocks in order, so the first is the basis
    (Blender's reference key), which is never driven.  ``viseme_set``
    limits the choice to conventions of that set (the user picked it);
    ``viseme_sets`` holds every set the conventions name.
    """
    index = NameIndex(shape_keys[1:], mesh_names)
    best, best_score = None, None
    for order, conv in enumerate(conventions):
        if viseme_set is not None and conv.viseme_set != viseme_set:
            continue
        m = match(conv, viseme_sets[conv.viseme_set], index)
        if not m.keys:
            continue
        score = (m.complete, conv.speech, round(m.coverage, 6), m.keys, -order)
        if best_score is None or score > best_score:
            best, best_score = m, score
    return best


@dataclass
class ExpressionMatch:
    """The expression's action units on one mesh's shape keys."""

    mapping: dict[str, dict[str, float]]    # unit -> {shape key on the mesh: weight}
    convention: str = ""                    # the convention whose section mapped them
    missing: list[str] = field(default_factory=list)   # units the conventions name that no key shows


def _match_mixes(alternatives: list[dict[str, float]], prefixes: list[str], index: NameIndex
                 ) -> tuple[dict[str, float], float]:
    """Of ``alternatives``, the mix that keeps most of its weight on the
    mesh's keys, and that share (0 when none of its keys exist)."""
    best, best_share = {}, 0.0
    for alt in alternatives:
        found, kept = {}, 0.0
        for key, w in alt.items():
            actual = next((a for a in (index.find(p + key) for p in prefixes) if a), None)
            if actual is not None:
                found[actual] = w
                kept += w
        share = kept / max(sum(alt.values()), 1e-9)
        if found and share > best_share + 1e-9:
            best, best_share = found, share
    return best, best_share


def expression_match(shape_keys: list[str], conventions: list[Convention], mesh_names: tuple[str, ...] = (),
                     prefer: str | None = None) -> ExpressionMatch:
    """The mesh's keys for each action unit, by the convention whose
    ``expression`` section shows the most units (``prefer``, the convention
    the mesh speaks with, wins a tie).  A mesh with no expression keys (an
    Oculus-only or mouth-only export) gets an empty mapping."""
    index = NameIndex(shape_keys, mesh_names)
    units = list(read_object(EXPRESSION)["units"])
    best, best_score = ExpressionMatch({}), None
    for order, conv in enumerate(conventions):
        if not conv.expression:
            continue
        mapping, shown = {}, 0.0
        for unit, alts in conv.expression.items():
            mix, share = _match_mixes(alts, conv.prefixes, index)
            if mix:
                mapping[unit] = mix
                shown += share
        if not mapping:
            continue
        score = (round(shown, 6), conv.name == prefer or conv.label == prefer, -order)
        if best_score is None or score > best_score:
            best, best_score = ExpressionMatch(mapping, conv.name), score
    best.missing = [u for u in units if u not in best.mapping]
    return best


def unmapped(vset: VisemeSet, mapping: dict[str, dict[str, float]]) -> list[str]:
    """Speaking visemes with no entry (an empty entry means the basis shows it)."""
    return [v for v in vset.visemes if v not in mapping and v != vset.rest]


# --- closure ---------------------------------------------------------------------------

def apply_closure(keys: list[str], values: np.ndarray, closure_track: np.ndarray, closure: Closure,
                  mapping: dict[str, dict[str, float]]) -> tuple[list[str], np.ndarray]:
    """Shape-key curves (frames, keys) with the rig's way of closing the
    lips applied; a ``relative`` key missing from ``keys`` but driven by the
    closure is added.  Values stay in [0, 1]."""
    values = np.array(values, dtype=float, copy=True)
    keys = list(keys)
    c = np.clip(np.asarray(closure_track, dtype=float), 0.0, 1.0)[:, None] if len(values) else np.zeros((0, 1))
    col = {k: i for i, k in enumerate(keys)}
    relax = [col[k] for k in sorted(closure.relaxed_keys(mapping)) if k in col]
    if relax:
        values[:, relax] *= 1.0 - c
    for k, ref in closure.relative.items():
        if k in col and ref in col:
            values[:, col[k]] = np.minimum(values[:, col[k]], 1.0) * values[:, col[ref]]
    return keys, np.clip(values, 0.0, 1.0)
