"""Emotion presets: every tunable number of weights and coarticulation.

A preset is a JSON file.  Built-in presets live in ``data/presets``;
``neutral`` holds every field and the others, like a user's preset, may hold
only what differs: a preset names its ``base`` (default ``neutral``) and its
fields replace the base's.  Loading checks every field and a malformed one
raises :class:`PresetError` naming it (``rules.influence.VC must be a number
between 0 and 3``).

Fields (see ``data/presets/neutral.json`` for values):

``weights.range_scale.<class>``  [s_min, s_p, s_max] multipliers on every
    viseme's (W_min, W_p, W_max) for phonemes of that class: how wide the
    mouth goes.  Classes: vowel, bilabial, labiodental, dental, alveolar,
    postalveolar, velar, liquid, glide, silence.
``weights.other_source``  what drives nasals, liquids and glides: "intensity",
    "pitch", "both" or "neutral" (the paper leaves it open).
``weights.pitch_range``  "auto" (from the clip), "male", "female" or [lo, hi] Hz.
``weights.intensity_floor_db``  frames this far below the loudest are silence.
``weights.follow_voice``  0 to 1: how much the voice's arousal (estimated from
    the audio, -1 calm to +1 excited, see ``arousal.py``) widens or narrows
    every viseme's weight range, on one scale across lines: at 1 a fully
    excited line's ranges are x1.35 and a fully calm one's x0.65 (the factor
    is ``follow_voice_range`` in ``data/arousal.json``).  The built-in
    presets use 0.5; 0 leaves the weights as equations 1-2 give them.
``rules.t_onset``, ``rules.t_offset``  seconds a viseme starts before its
    phoneme and lingers after it, before the influence factor.
``rules.apex``  where in the phoneme the viseme peaks, 0 (start) to 1 (end).
``rules.influence.{VV,VC,CV,CC}``  the factor c by context (previous->this).
``rules.deletion.phones``, ``rules.deletion.threshold``  phonemes dropped
    from the visual stream when shorter than the threshold (s).
``rules.diphthong_split``  share of a diphthong's span given to its first viseme.
``dominance.plateau``  share of a segment over which its dominance is flat
    (0 = the classic Cohen-Massaro peak at the centre).
``dominance.classes.<class>.{alpha,theta,phi,c}``  Cohen-Massaro parameters.
``closure.strength``  how much bilabial and labiodental closures suppress the
    other visemes (0-1); closures always reach their own target.
``smoothing``  Gaussian smoothing of the curves, seconds (0 = none).
``gain``  overall multiplier on every weight before clamping to [0, 1].
``gestures.<field>``  the face's life beside speech (:mod:`.gestures`):
    ``blink_rate`` (a minute), ``blink_duration`` (s), ``blink_at_pauses``
    (share of blinks moved to a pause), ``double_blink`` (chance),
    ``gaze_interval`` (mean s between saccades), ``gaze_range`` and
    ``gaze_down`` (degrees: spread and mean of the gaze below level),
    ``look_away`` (chance at a phrase start) and ``look_away_angle``
    (degrees), ``lid_follow`` (how far the lids follow the gaze down),
    ``head_range`` (degrees of head motion in speech),
    ``head_follow_voice`` (share of it that follows loudness), ``nod``
    (degrees on an accent), ``sway`` (degrees of slow sway), ``pause_calm``
    (head motion in pauses against speech) and ``brow_raise`` (0-1 on an
    accent).  Every preset has them all: ``neutral`` says each.
``expression.<unit>``  the emotion on the whole face: FACS action units
    (``AU12``, lip corner puller) and their strengths, 0 to 1, such as
    ``{"AU6": 0.5, "AU12": 0.6}`` for happy.  The units and how the
    expression moves over a line are in ``data/expression.json``
    (:mod:`.expression`); which shape keys show them, in the naming
    conventions.  Neutral has none.

In the engine a preset is a :class:`Preset`: read and checked once
(:func:`load`), then passed around typed; :meth:`Preset.to_dict` gives the
JSON document back, field for field.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from collections.abc import Callable

from . import visemes
from .datafile import read_object
from .errors import LipSyncError, PresetError
from .language.phonemes import CLASSES, PHONEMES

DATA = Path(__file__).parent / "data" / "presets"
EXPRESSION = Path(__file__).parent / "data" / "expression.json"
BUILTIN = ("neutral", "happy", "sad", "angry", "surprised", "afraid", "disgusted")
CONTEXTS = ("VV", "VC", "CV", "CC")


def builtin_names() -> list[str]:
    return [n for n in BUILTIN if (DATA / f"{n}.json").is_file()]


def expression_units() -> tuple[str, ...]:
    """The FACS action units a preset's ``expression`` may set."""
    return tuple(read_object(EXPRESSION)["units"])


def _num(source, field, value, lo, hi):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise PresetError(source, field, f"must be a number between {lo:g} and {hi:g}, got {value!r}")
    if not (lo <= value <= hi):
        raise PresetError(source, field, f"must be a number between {lo:g} and {hi:g}, got {value!r}")
    return float(value)


def validate(p: dict, source: str = "preset") -> dict:
    """Check a complete preset; returns it with numbers as floats."""
    def section(d, key, path):
        if key not in d:
            raise PresetError(source, path, "is missing")
        if not isinstance(d[key], dict):
            raise PresetError(source, path, "must be an object")
        return d[key]

    def no_extra(d, allowed, path):
        for k in d:
            if k not in allowed:
                raise PresetError(source, f"{path}.{k}" if path else k,
                                  f"is not a preset field (expected one of: {', '.join(allowed)})")

    no_extra(p, ("name", "description", "base", "weights", "rules", "dominance", "closure", "smoothing", "gain",
                 "learned", "expression", "gestures"), "")
    _validate_gestures(p, source)
    if "expression" in p:
        _validate_expression(p, source)
    if "learned" in p:
        _validate_learned(p["learned"], source)
    w = section(p, "weights", "weights")
    no_extra(w, ("range_scale", "other_source", "pitch_range", "intensity_floor_db", "follow_voice"), "weights")
    rs = section(w, "range_scale", "weights.range_scale")
    no_extra(rs, CLASSES, "weights.range_scale")
    for cls in CLASSES:
        f = f"weights.range_scale.{cls}"
        v = rs.get(cls)
        if not (isinstance(v, list) and len(v) == 3):
            raise PresetError(source, f, "must be three numbers [s_min, s_p, s_max]")
        rs[cls] = [_num(source, f"{f}[{k}]", x, 0.0, 3.0) for k, x in enumerate(v)]
    if w.get("other_source") not in ("intensity", "pitch", "both", "neutral"):
        raise PresetError(source, "weights.other_source",
                          f"must be intensity, pitch, both or neutral, got {w.get('other_source')!r}")
    pr = w.get("pitch_range")
    if isinstance(pr, list):
        if len(pr) != 2:
            raise PresetError(source, "weights.pitch_range", "must be [low, high] in Hz")
        lo = _num(source, "weights.pitch_range[0]", pr[0], 30, 1000)
        hi = _num(source, "weights.pitch_range[1]", pr[1], 30, 1000)
        if hi <= lo:
            raise PresetError(source, "weights.pitch_range", "must have low < high")
        w["pitch_range"] = [lo, hi]
    elif pr not in ("auto", "male", "female"):
        raise PresetError(source, "weights.pitch_range", f"must be auto, male, female or [low, high], got {pr!r}")
    w["intensity_floor_db"] = _num(source, "weights.intensity_floor_db", w.get("intensity_floor_db"), 10, 120)
    w["follow_voice"] = _num(source, "weights.follow_voice", w.get("follow_voice", 0.0), 0.0, 1.0)

    r = section(p, "rules", "rules")
    no_extra(r, ("t_onset", "t_offset", "apex", "influence", "deletion", "diphthong_split"), "rules")
    r["t_onset"] = _num(source, "rules.t_onset", r.get("t_onset"), 0.0, 1.0)
    r["t_offset"] = _num(source, "rules.t_offset", r.get("t_offset"), 0.0, 1.0)
    r["apex"] = _num(source, "rules.apex", r.get("apex"), 0.0, 1.0)
    r["diphthong_split"] = _num(source, "rules.diphthong_split", r.get("diphthong_split"), 0.1, 0.9)
    inf = section(r, "influence", "rules.influence")
    no_extra(inf, CONTEXTS, "rules.influence")
    for c in CONTEXTS:
        inf[c] = _num(source, f"rules.influence.{c}", inf.get(c), 0.0, 3.0)
    de = section(r, "deletion", "rules.deletion")
    no_extra(de, ("phones", "threshold"), "rules.deletion")
    if not isinstance(de.get("phones"), list) or any(not isinstance(ph, str) or ph not in PHONEMES
                                                     for ph in de["phones"]):
        raise PresetError(source, "rules.deletion.phones",
                          f"must be a list of ARPAbet phonemes, got {de.get('phones')!r}")
    de["threshold"] = _num(source, "rules.deletion.threshold", de.get("threshold"), 0.0, 0.5)

    d = section(p, "dominance", "dominance")
    no_extra(d, ("plateau", "classes"), "dominance")
    d["plateau"] = _num(source, "dominance.plateau", d.get("plateau"), 0.0, 1.0)
    cl = section(d, "classes", "dominance.classes")
    no_extra(cl, CLASSES, "dominance.classes")
    for cls in CLASSES:
        e = section(cl, cls, f"dominance.classes.{cls}")
        no_extra(e, ("alpha", "theta", "phi", "c"), f"dominance.classes.{cls}")
        e["alpha"] = _num(source, f"dominance.classes.{cls}.alpha", e.get("alpha"), 1e-3, 1e3)
        e["theta"] = _num(source, f"dominance.classes.{cls}.theta", e.get("theta"), 1e-2, 1e3)
        e["phi"] = _num(source, f"dominance.classes.{cls}.phi", e.get("phi"), 1e-2, 1e3)
        e["c"] = _num(source, f"dominance.classes.{cls}.c", e.get("c"), 0.2, 3.0)
    cz = section(p, "closure", "closure")
    no_extra(cz, ("strength",), "closure")
    cz["strength"] = _num(source, "closure.strength", cz.get("strength"), 0.0, 1.0)
    p["smoothing"] = _num(source, "smoothing", p.get("smoothing"), 0.0, 0.2)
    p["gain"] = _num(source, "gain", p.get("gain"), 0.0, 3.0)
    if not isinstance(p.get("name", ""), str):
        raise PresetError(source, "name", "must be text")
    if not isinstance(p.get("description", ""), str):
        raise PresetError(source, "description", "must be text")
    return p


@dataclass
class Weights:
    """``weights``: how pitch and intensity become viseme weights."""

    range_scale: dict[str, tuple[float, float, float]]   # phone class -> (s_min, s_p, s_max)
    other_source: str
    pitch_range: str | tuple[float, float]               # auto, male, female or (low, high) Hz
    intensity_floor_db: float
    follow_voice: float = 0.0


@dataclass
class Deletion:
    phones: tuple[str, ...]
    threshold: float


@dataclass
class Rules:
    """``rules``: the rule-based coarticulation model's numbers."""

    t_onset: float
    t_offset: float
    apex: float
    influence: dict[str, float]          # context (VV, VC, CV, CC) -> factor
    deletion: Deletion
    diphthong_split: float


@dataclass
class DominanceShape:
    """Cohen-Massaro parameters of one phone class."""

    alpha: float
    theta: float
    phi: float
    c: float


@dataclass
class Dominance:
    plateau: float
    classes: dict[str, DominanceShape]


#: The fields of ``gestures``: (lowest, highest) allowed.
GESTURE_RANGES = {
    "blink_rate": (0.0, 60.0), "blink_duration": (0.08, 0.5), "blink_at_pauses": (0.0, 1.0),
    "double_blink": (0.0, 0.5), "gaze_interval": (0.3, 10.0), "gaze_range": (0.0, 15.0),
    "gaze_down": (-10.0, 15.0), "look_away": (0.0, 1.0), "look_away_angle": (0.0, 15.0),
    "lid_follow": (0.0, 1.0), "head_range": (0.0, 10.0), "head_follow_voice": (0.0, 1.0), "nod": (0.0, 10.0),
    "sway": (0.0, 5.0), "pause_calm": (0.0, 1.0), "brow_raise": (0.0, 1.0),
}


@dataclass(frozen=True)
class Gestures:
    """``gestures``: blinks, gaze, head and brows beside speech (the module
    docstring says what each field means)."""

    blink_rate: float = 18.0
    blink_duration: float = 0.2
    blink_at_pauses: float = 0.95
    double_blink: float = 0.08
    gaze_interval: float = 2.2
    gaze_range: float = 5.0
    gaze_down: float = 0.0
    look_away: float = 0.5
    look_away_angle: float = 9.0
    lid_follow: float = 0.5
    head_range: float = 2.5
    head_follow_voice: float = 0.9
    nod: float = 2.5
    sway: float = 0.8
    pause_calm: float = 0.2
    brow_raise: float = 0.3


@dataclass
class Learned:
    """What a preset trained from animation adds: its viseme set and the
    poses learned for it, in the training mesh's shape keys."""

    viseme_set: str
    targets: dict[str, dict[str, float]]
    report: str | None = None


@dataclass
class Preset:
    """An emotion preset, checked (see the module docstring for each field)."""

    name: str
    weights: Weights
    rules: Rules
    dominance: Dominance
    closure_strength: float
    smoothing: float
    gain: float
    description: str = ""
    learned: Learned | None = None
    expression: dict[str, float] = field(default_factory=dict)   # FACS unit -> strength, 0-1
    gestures: Gestures = field(default_factory=Gestures)

    @classmethod
    def from_dict(cls, doc: dict, source: str = "preset") -> Preset:
        """A complete preset document (no ``base``), checked: a malformed
        field raises :class:`PresetError` naming it."""
        d = validate(copy.deepcopy(doc), source)
        w, r, dm = d["weights"], d["rules"], d["dominance"]
        pr = w["pitch_range"]
        le = d.get("learned")
        return cls(
            name=d.get("name", ""),
            description=d.get("description", ""),
            weights=Weights({c: tuple(v) for c, v in w["range_scale"].items()}, w["other_source"],
                            tuple(pr) if isinstance(pr, list) else pr, w["intensity_floor_db"], w["follow_voice"]),
            rules=Rules(r["t_onset"], r["t_offset"], r["apex"], dict(r["influence"]),
                        Deletion(tuple(r["deletion"]["phones"]), r["deletion"]["threshold"]), r["diphthong_split"]),
            dominance=Dominance(dm["plateau"], {c: DominanceShape(**v) for c, v in dm["classes"].items()}),
            closure_strength=d["closure"]["strength"], smoothing=d["smoothing"], gain=d["gain"],
            learned=Learned(le["viseme_set"], {v: dict(m) for v, m in le["targets"].items()}, le.get("report"))
            if le is not None else None,
            expression=dict(d.get("expression", {})),
            gestures=Gestures(**d.get("gestures", {})))

    def to_dict(self) -> dict:
        """The preset as its JSON document."""
        w, r, dm = self.weights, self.rules, self.dominance
        doc = {"name": self.name}
        if self.description:
            doc["description"] = self.description
        doc.update({
            "weights": {"range_scale": {c: list(v) for c, v in w.range_scale.items()},
                        "other_source": w.other_source,
                        "pitch_range": list(w.pitch_range) if isinstance(w.pitch_range, tuple) else w.pitch_range,
                        "intensity_floor_db": w.intensity_floor_db, "follow_voice": w.follow_voice},
            "rules": {"t_onset": r.t_onset, "t_offset": r.t_offset, "apex": r.apex, "influence": dict(r.influence),
                      "deletion": {"phones": list(r.deletion.phones), "threshold": r.deletion.threshold},
                      "diphthong_split": r.diphthong_split},
            "dominance": {"plateau": dm.plateau,
                          "classes": {c: {"alpha": v.alpha, "theta": v.theta, "phi": v.phi, "c": v.c}
                                      for c, v in dm.classes.items()}},
            "closure": {"strength": self.closure_strength},
            "smoothing": self.smoothing,
            "gain": self.gain,
        })
        if self.expression:
            doc["expression"] = dict(self.expression)
        doc["gestures"] = dataclasses.asdict(self.gestures)
        if self.learned is not None:
            doc["learned"] = {"viseme_set": self.learned.viseme_set,
                              "targets": {v: dict(m) for v, m in self.learned.targets.items()}}
            if self.learned.report is not None:
                doc["learned"]["report"] = self.learned.report
        return doc

    def key(self) -> str:
        """A text that is equal for two presets exactly when all their numbers are."""
        return json.dumps(self.to_dict(), sort_keys=True)


def as_preset(preset: Preset | dict | str | os.PathLike, source: str = "preset") -> Preset:
    """``preset`` as a :class:`Preset`: a built-in preset's name or a preset
    file is loaded (:func:`load`), a preset document (a dict, which may name
    a ``base``) is resolved and checked.  The one place the engine turns a
    preset, however given, into a :class:`Preset`."""
    if isinstance(preset, Preset):
        return preset
    if isinstance(preset, (str, os.PathLike)):
        return load(preset)
    return Preset.from_dict(resolve(dict(preset), source), source)


def viseme_set_for(preset: Preset, viseme_set: str | None = None) -> visemes.VisemeSet:
    """The viseme set to use: ``viseme_set`` (default: ``default``), unless
    the preset was learned from animation, whose set and poses it carries."""
    learned = preset.learned
    if learned is None:
        return visemes.load(viseme_set or "default")
    base = visemes.load(learned.viseme_set)
    if viseme_set is not None and visemes.load(viseme_set).name != base.name:
        raise LipSyncError(f"preset {preset.name!r} was learned with the {base.name!r} viseme set; "
                           f"it cannot drive {viseme_set!r}")
    return visemes.with_targets(base, learned.targets)


def _validate_expression(p: dict, source: str) -> None:
    """``expression``: FACS action unit -> strength, 0 to 1."""
    ex = p["expression"]
    if not isinstance(ex, dict):
        raise PresetError(source, "expression", "must map FACS action units (AU12 ...) to strengths 0-1")
    units = expression_units()
    for unit in ex:
        if unit not in units:
            raise PresetError(source, f"expression.{unit}",
                              f"is not an action unit this add-on knows (expected one of: {', '.join(units)})")
        ex[unit] = _num(source, f"expression.{unit}", ex[unit], 0.0, 1.0)
    kept = {u: ex[u] for u in ex if ex[u] > 0}   # 0 takes a unit out (of the base's expression too)
    if kept:
        p["expression"] = kept
    else:
        del p["expression"]


def _validate_gestures(p: dict, source: str) -> None:
    """``gestures``: each field a number in its range (:data:`GESTURE_RANGES`);
    those left out take :class:`Gestures`' values."""
    g = p.get("gestures", {})
    if not isinstance(g, dict):
        raise PresetError(source, "gestures", "must be an object of numbers (blink_rate, head_range ...)")
    for k in g:
        if k not in GESTURE_RANGES:
            raise PresetError(source, f"gestures.{k}",
                              f"is not a preset field (expected one of: {', '.join(GESTURE_RANGES)})")
    if "gestures" in p:
        p["gestures"] = {k: _num(source, f"gestures.{k}", v, *GESTURE_RANGES[k]) for k, v in g.items()}


def _validate_learned(le, source: str) -> None:
    """``learned``: what a preset trained from example animation adds: the
    viseme set it was trained with and each viseme's learned pose, as a mix
    of the training mesh's shape keys (or capture channels)."""
    if not isinstance(le, dict):
        raise PresetError(source, "learned", "must be an object")
    for k in le:
        if k not in ("viseme_set", "targets", "report"):
            raise PresetError(source, f"learned.{k}", "is not a preset field (expected one of: viseme_set, "
                                                      "targets, report)")
    if not isinstance(le.get("viseme_set"), str):
        raise PresetError(source, "learned.viseme_set", "must name the viseme set the preset was trained with")
    targets = le.get("targets")
    if not isinstance(targets, dict) or not targets:
        raise PresetError(source, "learned.targets", "must map visemes to {shape key: weight}")
    for v, mix in targets.items():
        if not isinstance(mix, dict):
            raise PresetError(source, f"learned.targets.{v}", "must map shape-key names to numbers")
        for k, w in mix.items():
            mix[k] = _num(source, f"learned.targets.{v}.{k}", w, -3.0, 3.0)
    if "report" in le and not isinstance(le["report"], str):
        raise PresetError(source, "learned.report", "must be the training report's file name")


def merge(base: dict, over: dict) -> dict:
    """Fields of ``over`` replace those of ``base``, recursively for objects."""
    out = copy.deepcopy(base)
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out




def resolve(doc: dict, source: str, _depth: int = 0) -> dict:
    """Apply a preset's ``base`` chain and validate the result."""
    if _depth > 8:
        raise PresetError(source, "base", "chain is too long (a preset names itself as its base?)")
    base_name = doc.get("base", "neutral" if doc.get("name") != "neutral" or "weights" not in doc else None)
    if base_name is None or (doc.get("name") == "neutral" and source.endswith("neutral.json")):
        full = copy.deepcopy(doc)
    else:
        if not isinstance(base_name, str) or not base_name.strip():
            raise PresetError(source, "base", "must be the name of another preset")
        beside = Path(source).parent / base_name
        if not Path(base_name).is_absolute() and Path(source).is_file() and beside.is_file():
            base_name = str(beside)  # a base file named relative to the preset's own folder
        try:
            base_path = _locate(base_name, source)
        except PresetError as exc:
            raise PresetError(source, "base", f"names {base_name!r}, which {exc.problem}") from None
        base = resolve(read_object(base_path), str(base_path), _depth + 1)
        full = merge(base, {k: v for k, v in doc.items() if k != "base"})
    full.pop("base", None)
    return validate(full, source)


def _locate(name_or_path: str | os.PathLike, source: str = "preset") -> Path:
    path = Path(name_or_path)
    if path.suffix == ".json" or path.exists():
        if not path.is_file():
            raise PresetError(str(path), "(file)", "does not exist")
        return path
    path = DATA / f"{name_or_path}.json"
    if not path.is_file():
        raise PresetError(str(name_or_path), "name",
                          f"is not a preset; built-in presets: {', '.join(builtin_names())}")
    return path


def read(name_or_path: str | os.PathLike) -> dict:
    """The JSON document of a built-in preset by name (``angry``) or of a
    preset file by path, with its ``base`` applied, checked."""
    path = _locate(name_or_path)
    return resolve(read_object(path), str(path))


def load(name_or_path: str | os.PathLike) -> Preset:
    """A built-in preset by name (``angry``) or a preset file by path."""
    path = _locate(name_or_path)
    return Preset.from_dict(resolve(read_object(path), str(path)), str(path))


def finder(folder: str | os.PathLike | None = None) -> Callable[[str], Preset]:
    """A lookup for preset names in inline tags: :func:`load`, with a
    relative ``.json`` path read from ``folder`` (the transcript's own
    folder, so ``[presets/grumpy.json]`` means the same file wherever the
    command runs)."""
    def find(name: str) -> Preset:
        if folder and name.lower().endswith(".json") and not os.path.isabs(name):
            return load(os.path.join(folder, name))
        return load(name)
    return find


def save(preset: Preset | dict, path: str | os.PathLike) -> None:
    """Write ``preset`` (checked first) as a JSON preset file."""
    doc = preset.to_dict() if isinstance(preset, Preset) else preset
    validate(copy.deepcopy(doc), str(path))
    Path(path).write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")


def to_flat(preset: Preset | dict, prefix: str = "") -> dict[str, Any]:
    """Preset as {"rules.influence.VC": 0.6, ...}: what a UI lists field by field."""
    if isinstance(preset, Preset):
        preset = preset.to_dict()
    out: dict[str, Any] = {}
    for k, v in preset.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(to_flat(v, key + "."))
        else:
            out[key] = v
    return out


def from_flat(flat: dict[str, Any]) -> dict:
    out: dict = {}
    for key, v in flat.items():
        cur = out
        parts = key.split(".")
        for p in parts[:-1]:
            cur = cur.setdefault(p, {})
        cur[parts[-1]] = v
    return out
