"""One lip-sync run: checks, the engine, the keys.

Operators and the command line turn their properties and arguments into the
plain values these functions take (:func:`options` fills in what they leave
out from the scene's Lip Sync settings); nothing here reads the UI.
"""

from __future__ import annotations

import dataclasses
import json
import time
from dataclasses import dataclass, field

import bpy

from ..engine import conventions, keys, pipeline, visemes
from ..engine.output import Result
from ..engine.errors import LipSyncError
from ..engine.settings import LineSettings
from . import compat, edits, emotion_markers, keying, rig, userdata
from . import gestures as gestures_bl
from .sources import Clip, LineInputs, scene_fps


@dataclass(frozen=True)
class Options:
    """How to lip-sync: the line's settings, as the engine takes them, and
    what only Blender has."""

    line: LineSettings                   # the emotion, coarticulation, frame rate, dictionary, language ...
    tolerance: float = 0.0               # key reduction: 0 keys every frame
    whole_character: bool = True         # also key the character's other meshes with those shape keys
    hand_edits: str = "keep"             # the animator's edits of the line's last run: keep or discard
    lock: tuple[int, int] | None = None  # frames Generate leaves as they are (first, last)


def options(scene, emotion: str | None = None, coarticulation: str | None = None, tolerance: float | None = None,
            dictionary: str | None = None, language: str | None = None, hand_edits: str | None = None,
            lock: str | None = None, gestures: bool | None = None, gesture_seed: int | None = None) -> Options:
    """How to lip-sync: each value given (an operator's property, a
    command-line argument), else the scene's Lip Sync settings; the frame
    rate is the scene's.

    ``emotion`` names a preset as :func:`.userdata.load_preset` reads it;
    without it the panel's preset, with its edited numbers, is used.
    ``tolerance`` 0 keys every frame; without it the panel's (when Reduce
    Keys is on).  Paths may start with ``//`` (relative to the .blend).
    ``hand_edits`` is ``keep`` or ``discard``; ``lock`` the frames to leave
    as they are, ``"FIRST-LAST"`` (``"none"``: no lock); without them the
    panel's Hand Edits settings.  ``gestures`` (blinks, gaze, head) and
    ``gesture_seed``: without them the panel's Gestures settings."""
    st = scene.emotive_lipsync
    preset = userdata.load_preset(emotion) if emotion else userdata.panel_preset(st)
    if tolerance is None:
        tolerance = st.tolerance if st.reduce_keys else 0.0
    elif not tolerance >= 0:
        raise LipSyncError(f"the key reduction tolerance must be 0 or more (0 keys every frame), got {tolerance}")
    dictionary = dictionary or st.dictionary
    line = LineSettings.of(preset, coarticulation=coarticulation or st.coarticulation, fps=scene_fps(scene),
                           dictionary=bpy.path.abspath(dictionary) if dictionary else None,
                           language=language or st.language.strip() or None, emotion_fade=st.emotion_fade,
                           gestures=st.gestures if gestures is None else bool(gestures),
                           gesture_seed=st.gesture_seed if gesture_seed is None else int(gesture_seed))
    mode = edits.check_mode(hand_edits or st.hand_edits.lower())
    locked = edits.parse_lock(lock) if lock is not None else \
        (edits.check_lock((st.lock_first, st.lock_last)) if st.lock_frames else None)
    return Options(line, tolerance, whole_character=st.whole_character, hand_edits=mode, lock=locked)


@dataclass
class Summary:
    mesh: str
    label: str
    seconds: float
    first_frame: int
    last_frame: int
    shape_keys: int
    keys: int
    replaced: int
    estimated_words: int
    words: int
    timings: dict = field(default_factory=dict)
    also: list[str] = field(default_factory=list)   # the character's other meshes keyed with it
    warnings: list[str] = field(default_factory=list)  # the engine's (words of the transcript left out ...)
    expression: list[str] = field(default_factory=list)     # action units keyed
    expression_keys: list[str] = field(default_factory=list)   # the shape keys they drove
    no_key: list[str] = field(default_factory=list)          # the preset's units the mesh has no key for
    kept: list[str] = field(default_factory=list)            # expression keys left to the user's animation
    edits: str = ""                 # what became of the animator's edits (see .edits.Report)
    unheard_words: int = 0          # transcript words the take does not hold (left unspoken)
    unscripted_seconds: float = 0.0  # speech the transcript leaves out, animated from recognition
    recognized: bool = False        # no transcript: every word was recognised
    driven: str = "shape keys"                               # what ``shape_keys`` counts
    blinks: int = 0                                          # blinks keyed (gestures)
    gestures: list[str] = field(default_factory=list)        # the shape keys and bones the gestures keyed
    gesture_missing: list[str] = field(default_factory=list)  # what the target has no channel for, in words
    gesture_kept: list[str] = field(default_factory=list)    # gesture channels left to the user's animation

    def message(self) -> str:
        est = f", {self.estimated_words} of {self.words} words placed by estimate" if self.estimated_words else ""
        if self.recognized:
            est += f", {self.words} words recognised (no transcript)"
        if self.unheard_words:
            est += f", {self.unheard_words} word{'s' if self.unheard_words != 1 else ''} not heard"
        if self.unscripted_seconds:
            est += f", {self.unscripted_seconds:.1f} s unscripted"
        again = " (replacing the previous lip sync)" if self.replaced else ""
        also = f" (and on {', '.join(self.also)})" if self.also else ""
        # The rest of the face, each part said only where there is something to say.
        face = "".join(f"; {text}" for shown, text in (
            (self.expression, f"expression {', '.join(self.expression)} on {len(self.expression_keys)} shape keys"),
            (self.no_key, f"no shape key shows {', '.join(self.no_key)} (left out)"),
            (self.kept, f"kept your animation on {', '.join(self.kept)} (not keyed)"),
            (self.gestures, f"gestures ({self.blinks} blink{'s' if self.blinks != 1 else ''}) on "
                            f"{', '.join(self.gestures)}"),
            (self.gesture_missing, f"no channel for {', '.join(self.gesture_missing)}"),
            (self.gesture_kept, f"kept your animation on {', '.join(self.gesture_kept)} (no gestures there)"),
            (self.edits, self.edits)) if shown)
        return (f"Lip sync {self.label!r} -> {self.mesh}: {self.keys} keys on {self.shape_keys} {self.driven}{also}, "
                f"frames {self.first_frame}-{self.last_frame}{again}{est}{face}, in {self.seconds:.1f} s"
                + "".join(f"; warning: {w}" for w in self.warnings))


def check_mesh(obj) -> list[str]:
    """The target's names, or a clear error: a mesh's shape keys (its Basis
    first), an armature's pose assets and properties (:func:`.rig.names`)."""
    if obj is None:
        raise LipSyncError("no face mesh: pick one in the Lip Sync panel, or make it the active object")
    if obj.type == "ARMATURE":
        names = rig.check(obj)
        check_editable(obj)
        return names
    if obj.type != "MESH":
        raise LipSyncError(f"{obj.name!r} is a {obj.type.lower()}, not a mesh or an armature: lip sync animates a "
                           "mesh's shape keys or an armature's pose assets and properties")
    key = obj.data.shape_keys
    if key is None or len(key.key_blocks) < 2:
        raise LipSyncError(f"mesh {obj.name!r} has no shape keys to animate: add a Basis key and the mouth "
                           "shapes (see sample_rigs/ for examples)")
    check_editable(obj)
    return [kb.name for kb in key.key_blocks]


def _linked_from(idb) -> str | None:
    """Why a datablock cannot be changed here: linked from a library, or a
    library override the user has not made editable; None if it can."""
    lib = getattr(idb, "library", None)
    if lib is not None:
        return f"linked from the library {lib.filepath!r}"
    ov = getattr(idb, "override_library", None)
    if ov is not None and getattr(ov, "is_system_override", False):
        return "a non-editable library override"
    return None


def check_editable(obj) -> None:
    """A clear error if the target's animation cannot be written here: the
    object, its mesh, its shape keys or their action linked from a library
    (the keys would be lost on reload, or refused).  An editable library
    override of the object and its mesh works.  An armature's keys are on
    the object (its pose, its properties), so its armature data may stay
    linked."""
    rig = obj.type == "ARMATURE"
    key = None if rig else obj.data.shape_keys
    owner = obj if rig else key
    action = owner.animation_data.action if owner is not None and owner.animation_data is not None else None
    for what, idb in ((f"object {obj.name!r}", obj), ("", None) if rig else (f"mesh data {obj.data.name!r}", obj.data),
                      (f"shape keys {key.name!r}" if key is not None else "", key),
                      (f"action {action.name!r}" if action is not None else "", action)):
        why = _linked_from(idb) if idb is not None else None
        if why:
            fix = (f"assign a local action to the {'armature' if rig else 'shape keys'}" if idb is action else
                   "make a library override of it and its mesh (Object > Library Override > Make, "
                   "then make the mesh editable) or make it local (Object > Relations > Make Local)")
            raise LipSyncError(f"{obj.name!r} cannot be animated: its {what} is {why}; {fix}. Nothing was changed")


def _rig_of(obj):
    """What holds a character's meshes together: the armature deforming the
    mesh, else its parent (None for a lone mesh)."""
    for mod in obj.modifiers:
        if mod.type == "ARMATURE" and mod.object is not None:
            return mod.object
    return obj.parent


def companions(obj, shape_keys) -> list:
    """The character's other meshes that carry some of ``shape_keys``:
    teeth, tongue, beard or eyelashes with the face's viseme keys (Ready
    Player Me, Character Creator and MakeHuman characters have them), which
    must move with the face.  They share the face's armature or parent;
    meshes sharing the face's own shape keys, and linked ones, are left out."""
    rig = _rig_of(obj)
    if rig is None:
        return []
    wanted = set(shape_keys)
    out = []
    for other in rig.children_recursive:
        if other is obj or other.type != "MESH" or other.library is not None or other.data.library is not None:
            continue
        key = other.data.shape_keys
        if key is None or key == obj.data.shape_keys or _rig_of(other) is not rig:
            continue
        if wanted & {kb.name for kb in key.key_blocks[1:]}:
            out.append(other)
    return sorted(out, key=lambda o: o.name)


def all_conventions() -> list[conventions.Convention]:
    """The built-in naming conventions and the user's own."""
    folder = userdata.conventions_folder()
    return conventions.load_all([folder] if folder else [])


def detect(obj, viseme_set: str | None = None, convention: str | None = None) -> conventions.Match:
    """The naming convention ``obj``'s shape keys follow, mapped onto them.

    ``viseme_set`` (a built-in name or a file) limits the choice to that
    set's conventions; ``"AUTO"`` allows any; None: the mesh's own setting.
    ``convention`` forces one by name.  Nothing on the mesh is changed.
    """
    names = check_mesh(obj)
    st = obj.emotive_lipsync
    if viseme_set is None:
        source = st.viseme_set_source()
    else:
        source = None if viseme_set == "AUTO" else viseme_set
    sets = {n: visemes.load(n) for n in visemes.builtin_names()}
    if source is not None and source not in sets:
        own = visemes.load(source)                 # a studio's own set: matched by its own names
        sets[own.name] = own
        candidates = [conventions.from_viseme_set(own)]
        chosen = own.name
    else:
        candidates = all_conventions()
        chosen = source
    if convention:
        known = [c.name for c in candidates]
        candidates = [c for c in candidates if c.name == convention]
        if not candidates:
            raise LipSyncError(f"{convention!r} is not a naming convention: {', '.join(known)}")
        chosen = None
    prefixes = (obj.name, obj.data.name)
    if obj.type == "ARMATURE":   # a pose bone's property is named "bone:property"
        prefixes += tuple(pb.name for pb in (obj.pose.bones if obj.pose is not None else []) if pb.keys())
    found = conventions.detect(names, candidates, sets, prefixes, chosen)
    if found is None:
        what = driven_words(obj)
        if convention:
            raise LipSyncError(f"none of the {what} of {obj.name!r} follow the convention {convention!r}")
        if chosen:
            raise LipSyncError(f"none of the {what} of {obj.name!r} match the viseme set {chosen!r}: map them "
                               "in the Lip Sync panel, or set Viseme Set to Automatic")
        raise LipSyncError(f"none of the {what} of {obj.name!r} follow a naming convention this add-on knows "
                           f"({', '.join(c.label for c in candidates)}): map them in the Lip Sync panel's "
                           "Visemes and Shape Keys list, or add a convention file")
    return found


def driven_words(obj) -> str:
    """What a target's mapping names, in words: shape keys, or pose assets and properties."""
    return "pose assets and properties" if obj.type == "ARMATURE" else "shape keys"


def apply(obj, found: conventions.Match) -> None:
    """Store a detected mapping, its convention and its closure rule on the mesh."""
    st = obj.emotive_lipsync
    st.set_mapping(found.mapping)
    st.convention = found.convention.label
    st.mapped_set = found.convention.viseme_set
    st.closure_rule = json.dumps(found.closure.to_dict())


def mesh_viseme_set(obj) -> visemes.VisemeSet:
    """The viseme set the mesh's mapping is made for."""
    st = obj.emotive_lipsync
    source = st.viseme_set_source()
    return visemes.load(source if source is not None else (st.mapped_set or "default"))


def mesh_mapping(obj) -> tuple[visemes.VisemeSet, dict[str, dict[str, float]], conventions.Closure]:
    """The mesh's viseme set, mapping and closure rule; detected and stored
    when the user has not mapped anything."""
    names = check_mesh(obj)
    st = obj.emotive_lipsync
    mp = st.mapping_dict()
    if not mp:
        apply(obj, detect(obj))
        mp = st.mapping_dict()
    missing = sorted({k for mix in mp.values() for k in mix} - set(names))
    if missing:
        what = "armature {!r} has no pose asset or property" if obj.type == "ARMATURE" else \
            "mesh {!r} has no shape key"
        raise LipSyncError(f"{what.format(obj.name)} named {', '.join(map(repr, missing))}: "
                           "fix the mapping in the Lip Sync panel or press Auto-Map")
    return mesh_viseme_set(obj), mp, conventions.Closure.from_json(st.closure_rule)


@dataclass
class Plan:
    """One run's inputs as plain values, read from Blender on the main thread.

    The engine's part (:func:`analyze`) needs nothing else, so it may run in
    a background thread; the keys are written by :func:`key`.
    """

    scene: str
    mesh: str
    clip: Clip
    text: str | None                 # None: the words are recognised from the audio
    options: Options                 # the line's own: its viseme set is the mesh's (None: the learned preset's)
    mapping: dict[str, dict[str, float]]
    closure: conventions.Closure
    started: float = field(default_factory=time.perf_counter)
    also: list[str] = field(default_factory=list)   # companion meshes to key too
    emotions: list = field(default_factory=list)     # (s, preset) from emotion: timeline markers
    find_preset: object = None                       # resolves inline emotion tags
    #: The mesh's keys for the expression's action units (empty: the mesh has none).
    expression: conventions.ExpressionMatch = field(default_factory=lambda: conventions.ExpressionMatch({}))


@dataclass
class Analysis:
    result: Result
    seconds: float


def plan(scene, line: LineInputs, options: Options) -> Plan:
    """Read a run's inputs from Blender (an empty mapping is filled in first,
    see :func:`mesh_mapping`).  The line's settings are ``options``' with
    the mesh's viseme set and the line's own language, if it has one."""
    obj, clip = line.target, line.clip
    learned = options.line.emotion.learned is not None
    if learned:
        set_source = None
        closure = conventions.Closure()
    else:
        vset, mp, closure = mesh_mapping(obj)
        set_source = obj.emotive_lipsync.viseme_set_source() or vset.name
    own = {"language": line.language} if line.language else {}
    options = dataclasses.replace(options, line=options.line.replace(viseme_set=set_source, **own))
    if learned:
        # A learned preset carries its own poses, in the training mesh's
        # shape-key names.
        names = set(check_mesh(obj))
        poses = options.line.visemes.shape_keys
        mp = {v: {k: w for k, w in mix.items() if k in names} for v, mix in poses.items()}
        mp = {v: mix for v, mix in mp.items() if mix}
        if not mp:
            wanted = sorted({k for mix in poses.values() for k in mix})
            raise LipSyncError(f"the learned preset {options.line.emotion.name!r} drives shape keys "
                               f"{', '.join(wanted[:6])}{' ...' if len(wanted) > 6 else ''}; mesh {obj.name!r} "
                               "has none of them")
    if obj.type == "ARMATURE":   # the expression layer drives shape keys only
        face = conventions.ExpressionMatch({})
    else:
        face = conventions.expression_match(check_mesh(obj), all_conventions(), (obj.name, obj.data.name),
                                            prefer=obj.emotive_lipsync.convention)
    driven = {k for mix in mp.values() for k in mix} | set(closure.relative) | \
        {k for mix in face.mapping.values() for k in mix}
    if options.line.gestures and obj.type == "MESH":
        driven |= set(gestures_bl.channels(obj).shape_keys.values())
    also = [o.name for o in companions(obj, driven)] if options.whole_character and obj.type == "MESH" else []
    find = userdata.finder()
    marks = emotion_markers.changes(scene, clip.first_frame, clip.audio.duration, scene_fps(scene), find)
    return Plan(scene.name, obj.name, clip, line.text, options, mp, closure, also=also, emotions=marks,
                find_preset=find, expression=face)


def analyze(plan: Plan, progress=None) -> Analysis:
    """The engine's part of a run.  It touches no Blender data, so it may run
    in a background thread."""
    t0 = time.perf_counter()
    result = pipeline.analyze(plan.clip.audio, plan.text, plan.options.line, progress=progress,
                              emotion_changes=plan.emotions, emotion_lookup=plan.find_preset)
    return Analysis(result, time.perf_counter() - t0)


def key(obj, plan: Plan, analysis: Analysis) -> Summary:
    """Write an analysed run's keys on ``obj``'s mapped shape keys (main thread)."""
    t0 = time.perf_counter()
    result, clip = analysis.result, plan.clip
    if obj.type == "ARMATURE":
        return _key_rig(obj, plan, analysis, t0)
    face = plan.expression.mapping
    animated = keying.user_animated(obj, sorted({k for mix in face.values() for k in mix}))
    line = keys.mesh_keys(result, plan.mapping, plan.closure, face, animated)
    found = gestures_bl.channels(obj)
    lids_and_looks = set(found.shape_keys.values())
    brows = {k for u in ("AU1", "AU2") for k in face.get(u, {})}
    own = set(keying.user_animated(obj, sorted(lids_and_looks | brows)))
    if result.gestures is not None:
        turning = gestures_bl.animated(obj, found)
        line = keys.with_gestures(line, result.gestures, found, face, sorted(own) + turning,
                                  head_elsewhere=gestures_bl.lone_head(obj))
        if gestures_bl.OBJECT_TURN in turning:
            line.gesture_kept.append(f"{obj.name}'s rotation")
    # Gesture keys an earlier run wrote here and this one does not (gestures
    # off, a channel now the user's own) go, as the expression's do.
    line.dropped += sorted(lids_and_looks - set(line.names) - own - set(line.dropped))
    names, values = line.names, line.table()
    gone = sorted(set(names) - set(check_mesh(obj)))
    if gone:
        raise LipSyncError(f"mesh {obj.name!r} no longer has shape key {', '.join(map(repr, gone))}; "
                           "nothing was keyed")
    report = edits.Report()
    counts = _write(obj, names, values, plan, result, report, line.dropped)
    turned = gestures_bl.write(obj, line, result.gestures, clip.first_frame, plan.options.tolerance, clip.label)
    also = []
    only_face = set(line.driven_only_by(keys.EXPRESSION)) | set(line.driven_only_by(keys.GESTURE))
    for name in plan.also:
        other = bpy.data.objects.get(name)
        have = set(check_mesh(other)) if other is not None and other.type == "MESH" and \
            other.data.shape_keys is not None else set()
        if have:   # the companion's own animation on an expression key wins there too
            have -= set(keying.user_animated(other, sorted(have & only_face)))
        cols = [j for j, k in enumerate(names) if k in have]
        if cols:   # a companion deleted or changed meanwhile is simply left alone
            _write(other, [names[j] for j in cols], values[:, cols], plan, result, report)
            also.append(name)
    scene = bpy.data.scenes.get(plan.scene)
    if clip.strip and scene is not None and result.arousal is not None:
        strip = next((s for s in compat.sound_strips(scene) if s.name == clip.strip), None)
        if strip is not None:
            strip[emotion_markers.STRIP_AROUSAL] = round(float(result.arousal.value), 3)
    t1 = time.perf_counter()
    words = result.alignment.words
    return Summary(mesh=obj.name, label=clip.label, seconds=t1 - plan.started, first_frame=counts["first_frame"],
                   last_frame=counts["last_frame"], shape_keys=len(names), keys=counts["keys"],
                   replaced=counts["replaced"], timings={"engine": analysis.seconds, "keying": t1 - t0}, also=also,
                   warnings=list(result.warnings), expression=line.units, expression_keys=line.expression_keys,
                   no_key=line.no_key, kept=line.kept, edits=report.message(), **_gestures(line, result, turned),
                   **_heard(words, result))


def _gestures(line: keys.LineKeys, result: Result, turned: list[str]) -> dict:
    """The Summary's account of the gestures."""
    if result.gestures is None:
        return {}
    return {"blinks": line.blinks, "gestures": line.gesture_keys + turned, "gesture_missing": line.gesture_missing,
            "gesture_kept": line.gesture_kept}


def _write(obj, names: list[str], values, plan: Plan, result: Result, report: edits.Report,
           forget: list[str] = ()) -> dict:
    """Key one target's channels as :mod:`.keying` does, with the
    animator's edits of the line's last run (:func:`.edits.key_line`)."""
    opts = plan.options
    counts, outcome = edits.key_line(obj, names, values, plan.clip.first_frame, tolerance=opts.tolerance,
                                     label=plan.clip.label, line=edits.line_id(plan.clip),
                                     alignment=result.alignment, fps=opts.line.fps, mode=opts.hand_edits,
                                     lock=opts.lock, forget_keys=forget)
    report.outcomes.append(outcome)
    return counts


def _heard(words, result: Result) -> dict:
    """The Summary's account of the words: how many, placed by estimate, not
    heard, recognised without a transcript, and the unscripted seconds."""
    return {"words": len(words), "estimated_words": sum(1 for w in words if w.estimated),
            "unheard_words": sum(1 for w in words if not w.spoken),
            "unscripted_seconds": sum(b - a for a, b, _ in result.alignment.unscripted),
            "recognized": bool(words) and all(w.recognized for w in words)}


def _key_rig(obj, plan: Plan, analysis: Analysis, t0: float) -> Summary:
    """:func:`key` on an armature: the mapped poses blended onto its bones,
    its mapped properties keyed as shape keys are."""
    result, clip = analysis.result, plan.clip
    line = keys.rig_keys(result, plan.mapping, plan.closure)
    gone = sorted(set(line.names) - set(check_mesh(obj)))
    if gone:
        raise LipSyncError(f"armature {obj.name!r} no longer has pose asset or property "
                           f"{', '.join(map(repr, gone))}; nothing was keyed")
    paths, curves = rig.channels(obj, line.names, line.table(), line.closing, line.closure)
    report = edits.Report()
    counts = _write(obj, [f"{index}:{path}" for path, index in paths], curves, plan, result, report)
    if result.gestures is not None:
        found = gestures_bl.channels(obj)
        found.shape_keys.clear()   # an armature's own gestures are its bones
        line = keys.with_gestures(line, result.gestures, found, animated=gestures_bl.animated(obj, found))
    turned = gestures_bl.write(obj, line, result.gestures, clip.first_frame, plan.options.tolerance, clip.label)
    t1 = time.perf_counter()
    words = result.alignment.words
    return Summary(mesh=obj.name, label=clip.label, seconds=t1 - plan.started, first_frame=counts["first_frame"],
                   last_frame=counts["last_frame"], shape_keys=len(line.channels), keys=counts["keys"],
                   replaced=counts["replaced"], timings={"engine": analysis.seconds, "keying": t1 - t0},
                   warnings=list(result.warnings), edits=report.message(),
                   driven=f"poses and properties ({len(paths)} bone and property channels)",
                   **_gestures(line, result, turned), **_heard(words, result))


def generate(scene, line: LineInputs, options: Options, progress=None) -> Summary:
    """Analyse the line's clip and key its target's mapped shape keys from the clip's frame."""
    p = plan(scene, line, options)
    return key(line.target, p, analyze(p, progress))
