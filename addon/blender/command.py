"""``blender --command lipsync``: batch lip sync without opening the UI.

    blender -b scene.blend --command lipsync --all-strips --output out.blend
    blender -b scene.blend --command lipsync --mesh Bob --audio line1.wav --audio line2.wav --save
    blender -b scene.blend --command lipsync --manifest lines.csv --save

Each ``--audio`` file is placed after the previous one (from ``--frame``,
or the scene's start), with its transcript from ``--text``/``--transcript``
or the .txt beside it; with none, the words are recognised from the audio
(English), and the line's report says so.  Strips go to their own mesh by the rule that
*Generate for All Strips* uses.  A manifest (CSV or JSON lines, read by
:mod:`..engine.batch`) names many lines onto many meshes.  Every line runs
through the engine's batch runner in this process, the models loaded once.
The exit status is 0 when everything was
lip-synced, 1 when something was not (each problem is printed), 2 for a
usage error: an unknown option, or options that do not go together.
Presets are named as in the panel (see :mod:`.userdata`): a built-in name,
one of the user's saved presets, or a .json file.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys

import bpy

from ..engine import batch, visemes
from ..engine.errors import LipSyncError
from ..engine.language.text import read_text_file
from . import compat, edits, run, sources, userdata

COMMAND = "lipsync"


class UsageError(LipSyncError):
    """The command was called with options that do not go together (exit status 2)."""


def _tolerance(value: str) -> float:
    try:
        tol = float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{value!r} is not a number") from None
    if not tol >= 0:
        raise argparse.ArgumentTypeError(f"{value} is negative: give 0 (a key on every frame) or more")
    return tol


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog=f"blender -b FILE.blend --command {COMMAND}",
                                 description="Lip-sync sound strips or audio files onto meshes' shape keys.")
    what = ap.add_argument_group("what to lip-sync (default: every sound strip)")
    what.add_argument("--strip", action="append", default=[], metavar="NAME", help="a sound strip (repeatable)")
    what.add_argument("--all-strips", action="store_true", help="every sound strip of the scene")
    what.add_argument("--audio", action="append", default=[], metavar="FILE", help="an audio file (repeatable)")
    what.add_argument("--frame", type=int, help="frame the first --audio file starts on (default: scene start)")
    what.add_argument("--manifest", metavar="FILE",
                      help="CSV (with a header) or JSON lines naming per line a 'strip', or an 'audio' file "
                           "(placed at its 'frame', else after the previous one) and a 'mesh'; optional "
                           "'transcript', 'text', 'emotion', 'viseme_set', 'edits', 'lock'")
    ap.add_argument("--scene", help="scene name (default: the file's active scene)")
    ap.add_argument("--mesh", help="face mesh (required for --audio; for strips, used when a strip names none)")
    text = ap.add_mutually_exclusive_group()
    text.add_argument("--text", help="transcript for a single --strip/--audio")
    text.add_argument("--transcript", metavar="FILE", help="transcript file for a single --strip/--audio")
    ap.add_argument("--emotion", default=None, help="preset name or .json file (default: the scene's panel)")
    ap.add_argument("--viseme-set", help="viseme set of the mesh (name or .json file)")
    ap.add_argument("--coarticulation", choices=("dominance", "rules"))
    ap.add_argument("--tolerance", type=_tolerance, default=None, help="key reduction tolerance (0: every frame)")
    ap.add_argument("--dictionary", help="pronunciation dictionary file")
    ap.add_argument("--language", metavar="CODE",
                    help="language of the transcripts (de, deu, pt-BR, zh, ja ...; default: English); "
                         "a manifest's 'language' column says it per line")
    ap.add_argument("--edits", choices=("keep", "discard"), default=None,
                    help="your changes to the keys of a line's last run: laid on the new keys, moved with their "
                         "sound (keep), or dropped (discard); default: the scene's panel (keep)")
    ap.add_argument("--lock", metavar="FIRST-LAST",
                    help="frames whose keys are left exactly as they are (none: no lock; default: the panel's)")
    ap.add_argument("--no-gestures", action="store_true",
                    help="key no blinks, gaze or head motion (default: the scene's panel, on)")
    ap.add_argument("--gesture-seed", type=int, default=None, metavar="N",
                    help="another seed gives a line other blinks, glances and head motion (default: the panel's)")
    out = ap.add_mutually_exclusive_group()
    out.add_argument("--save", action="store_true", help="save the .blend in place")
    out.add_argument("--output", metavar="FILE.blend", help="save to this file")
    return ap


def _fixed_text(args) -> str | None:
    if args.text is not None:
        return args.text
    if args.transcript:
        body, notes = read_text_file(args.transcript)
        for note in notes:
            print(f"warning: {note}", file=sys.stderr)
        return body
    return None


def _set_viseme_set(obj, value: str) -> None:
    st = obj.emotive_lipsync
    if value in visemes.builtin_names():
        st.viseme_set = value
    else:
        visemes.load(value)  # a clear error now rather than per clip
        st.viseme_set, st.viseme_set_file = "FILE", value
    st.mapping.clear()


def _lines(args, scene, mesh) -> list[batch.Line]:
    """What to lip-sync, as batch lines: the manifest's, else one per
    ``--audio`` file, else one per strip."""
    if args.manifest:
        return [ln if ln.problem or ln.audio or "strip" in ln.extra else
                _with_problem(ln, "name a 'strip', or an 'audio' file and a 'mesh'")
                for ln in batch.read_manifest(bpy.path.abspath(args.manifest), formats=())]
    if args.audio:
        return [batch.Line(k, audio=path) for k, path in enumerate(args.audio, 1)]
    strips = [sources.strip_by_name(scene, n) for n in args.strip]
    if args.all_strips or not args.strip:
        strips = compat.sound_strips_in_order(scene)
        if not strips:
            raise LipSyncError(f"scene {scene.name!r} has no sound strips")
    return [batch.Line(k, extra={"strip": s.name}) for k, s in enumerate(strips, 1)]


def _with_problem(line: batch.Line, problem: str) -> batch.Line:
    line.problem = problem
    return line


def _key_line(scene, line: batch.Line, mesh, fixed, options: run.Options, args, state) -> run.Summary:
    """Lip-sync one line onto its mesh (raises LipSyncError)."""
    if line.problem:
        raise LipSyncError(line.problem)
    if line.alignment:
        raise LipSyncError("an 'alignment' column is not used in Blender: give 'transcript' or 'text'")
    if "mesh" in line.extra:
        mesh = bpy.data.objects.get(line.extra["mesh"])
        if mesh is None:
            raise LipSyncError(f"no object named {line.extra['mesh']!r}")
    strip = sources.strip_by_name(scene, line.extra["strip"]) if "strip" in line.extra else None
    frame = state["frame"]
    if strip is None and "frame" in line.extra:
        try:
            frame = int(line.extra["frame"])
        except ValueError:
            raise LipSyncError(f"frame {line.extra['frame']!r} is not a whole number") from None

    def place(clip):   # the next audio file starts after this one, keyed or not
        state["frame"] = frame + math.ceil(clip.audio.duration * sources.scene_fps(scene)) + 1

    given = fixed if fixed is not None else line.text
    inputs = sources.line_inputs(
        scene, strip=strip, audio=None if strip is not None else line.audio, frame=frame, fallback=mesh,
        no_target="give --mesh, set the strip's lipsync_target property, or name the strip after the mesh"
        if strip is not None else "give a 'mesh' column or --mesh",
        text=given, transcript_file=line.transcript if given is None else None, language=line.language or None,
        on_clip=place if strip is None else None)
    viseme_set = line.viseme_set or args.viseme_set
    if viseme_set and (line.viseme_set or inputs.target is not mesh or args.manifest):
        _set_viseme_set(inputs.target, viseme_set)
    if line.emotion:
        options = dataclasses.replace(options, line=options.line.replace(emotion=userdata.load_preset(line.emotion)))
    if "edits" in line.extra:
        options = dataclasses.replace(options, hand_edits=edits.check_mode(line.extra["edits"].lower()))
    if "lock" in line.extra:
        options = dataclasses.replace(options, lock=edits.parse_lock(line.extra["lock"]))
    return run.generate(scene, inputs, options)


def execute(argv: list[str]) -> int:
    try:
        args = parser().parse_args(argv)
    except SystemExit as exc:
        return int(exc.code or 0) and 2
    scene = bpy.data.scenes.get(args.scene) if args.scene else bpy.context.scene
    if scene is None:
        print(f"lipsync: no scene named {args.scene!r}", file=sys.stderr)
        return 2
    problems: list[str] = []
    done: list[run.Summary] = []
    try:
        given_text = args.text is not None or bool(args.transcript)
        if given_text and len(args.audio) + len(args.strip) != 1:
            raise UsageError("--text/--transcript need exactly one --strip or --audio; for several, put a "
                             ".txt beside each audio file")
        if args.manifest and (args.audio or args.strip or args.all_strips or given_text):
            raise UsageError("--manifest names every line itself: leave out --strip, --audio, --all-strips, "
                             "--text and --transcript")
        if args.audio and not args.mesh:
            raise UsageError("--audio needs --mesh: the face mesh to key")
        fixed = _fixed_text(args)
        options = run.options(scene, args.emotion, args.coarticulation, args.tolerance, args.dictionary,
                              args.language, hand_edits=args.edits, lock=args.lock,
                              gestures=False if args.no_gestures else None, gesture_seed=args.gesture_seed)
        mesh = None
        if args.mesh:
            mesh = bpy.data.objects.get(args.mesh)
            if mesh is None:
                raise LipSyncError(f"no object named {args.mesh!r}")
            if args.viseme_set:
                _set_viseme_set(mesh, args.viseme_set)
        jobs = _lines(args, scene, mesh)
    except UsageError as exc:
        print(f"lipsync: {exc} (see --help)", file=sys.stderr)
        return 2
    except LipSyncError as exc:
        print(f"lipsync: {exc}", file=sys.stderr)
        return 1

    # Every line, from a manifest or from the options, goes through the batch
    # runner in this process: the models are loaded once for all of them.
    batch.warm(options.line.dictionary)
    state = {"frame": args.frame if args.frame is not None else scene.frame_start}

    def key_line(line: batch.Line, _defaults) -> batch.Outcome:
        try:
            summary = _key_line(scene, line, mesh, fixed, options, args, state)
        except LipSyncError as exc:
            where = f"line {line.number}: " if args.manifest else ""
            problems.append(f"{where}{exc}")
            print(f"lipsync: {where}{exc}", file=sys.stderr)
            return batch.Outcome(line.number, line.label(), "failed", error=str(exc))
        done.append(summary)
        print(summary.message())
        return batch.Outcome(line.number, line.label(), "ok")

    for _ in batch.run_inline(jobs, options.line, key_line):
        pass

    if done and (args.save or args.output):
        if args.output:
            # A relative path is the current folder's: Blender 4.2 to 4.5 read it against the folder
            # the process started in, which a script may have left since.
            bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(bpy.path.abspath(args.output)), copy=False)
            print(f"lipsync: saved {bpy.data.filepath}")
        elif bpy.data.filepath:
            bpy.ops.wm.save_mainfile()
            print(f"lipsync: saved {bpy.data.filepath}")
        else:
            problems.append("--save: the scene has never been saved; use --output FILE.blend")
            print(f"lipsync: {problems[-1]}", file=sys.stderr)
    elif done:
        print("lipsync: nothing saved (add --save or --output FILE.blend)")
    print(f"lipsync: {len(done)} of {len(jobs)} lip-synced, {len(problems)} problems")
    return 0 if done and not problems else 1
