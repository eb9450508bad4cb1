"""Command line: ``python -m addon analyze AUDIO --text "..." --json out.json``."""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from . import presets, visemes
from .learning import capture
from .emotion_track import DEFAULT_FADE
from .errors import LipSyncError, SettingError
from .language.text import read_text_file
from .settings import LineSettings


def _style_options(p: argparse.ArgumentParser, per_line: bool) -> None:
    """How a line is animated: the options ``analyze`` and ``batch`` share.
    For ``batch`` (``per_line``) they are defaults for lines that say nothing."""
    unless = " for lines that name none" if per_line else ""
    p.add_argument("--viseme-set", default=None,
                   help=f"viseme set{unless}: built-in ({', '.join(visemes.builtin_names())}) or a .json file "
                        "(default: default, or the set a learned preset was trained with)")
    p.add_argument("--emotion", default="neutral",
                   help=f"emotion preset{unless}: built-in ({', '.join(presets.builtin_names())}) or a .json file "
                        "(default: neutral)")
    p.add_argument("--coarticulation", choices=("dominance", "rules"), default="dominance")
    p.add_argument("--emotion-fade", type=float, default=DEFAULT_FADE, metavar="SECONDS",
                   help=f"cross-fade of an inline emotion tag such as [angry] (default: {DEFAULT_FADE:g})")
    p.add_argument("--fps", default="30",
                   help=f"frames per second{unless}: 24, 25, 30, 60, 23.976, 29.97, 24000/1001 ... (default: 30)")
    p.add_argument("--dictionary", metavar="FILE", help="user pronunciation dictionary (CMU format)")
    p.add_argument("--no-gestures", action="store_true",
                   help="leave out the gestures beside speech: blinks, gaze, head and brow motion")
    p.add_argument("--gesture-seed", type=int, default=0, metavar="N",
                   help="another seed gives a line other blinks, glances and head motion (default: 0)")
    p.add_argument("--language", metavar="CODE", default="en",
                   help=f"language of the transcript{unless}: an ISO 639-1 or 639-3 code or a BCP-47 tag "
                        "(de, deu, pt-BR, zh, ja ...; default: en); 'list' shows them all")


def _check_options(args) -> None:
    """The checks argparse cannot make of the options that are not a line's
    settings; a :class:`LipSyncError` names the option."""
    if args.workers < 0:
        raise LipSyncError("--workers must be 0 (one per core) or more")
    timeout = getattr(args, "cluster_timeout", 60.0)
    if not 0 < timeout < float("inf"):
        raise LipSyncError(f"--cluster-timeout must be more than 0 seconds, not {timeout:g}")


def _line_settings(args, **more) -> LineSettings:
    """The settings :func:`_style_options` read, built and checked once; a
    bad value's error names its option (``--emotion-fade: ...``)."""
    try:
        return LineSettings.of(args.emotion, viseme_set=args.viseme_set, coarticulation=args.coarticulation,
                               fps=args.fps, dictionary=args.dictionary, language=args.language,
                               emotion_fade=args.emotion_fade, gestures=not args.no_gestures,
                               gesture_seed=args.gesture_seed, **more)
    except SettingError as exc:
        raise LipSyncError(f"--{exc.option.replace('_', '-')}: {exc}") from None


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="python -m addon",
                                 description="Emotive lip sync: audio + transcript -> viseme curves.")
    sub = ap.add_subparsers(dest="command", required=True)
    a = sub.add_parser("analyze", help="align a line of dialogue and write its viseme curves")
    a.add_argument("audio", help="audio file, any rate and channels: WAV, FLAC, AIFF, Ogg Vorbis or Opus, MP3, "
                                 "M4A/AAC, or a video (MP4, MOV, MKV)")
    src = a.add_mutually_exclusive_group()
    src.add_argument("--transcript", metavar="FILE",
                     help="text file with what is said (UTF-8; UTF-16 with a BOM, else Windows-1252)")
    src.add_argument("--text", help="what is said, inline")
    a.add_argument("--alignment", metavar="FILE",
                   help="use this alignment instead of aligning: .TextGrid, Rhubarb .json/.tsv, Papagayo .pgo")
    _style_options(a, per_line=False)
    a.add_argument("--workers", type=int, default=0, help="alignment processes (0: one per core)")
    a.add_argument("--json", metavar="OUT", help="write the result as JSON")
    a.add_argument("--csv", metavar="OUT", help="write the frame table as CSV")
    a.add_argument("--quiet", action="store_true", help="print nothing but errors and warnings")
    sub.add_parser("list", help="list built-in viseme sets and emotion presets")
    ar = sub.add_parser("arousal", help="estimate how calm (-1) or excited (+1) each recording sounds",
                        description="Arousal from the audio alone: one line per file, PATH<TAB>AROUSAL.")
    ar.add_argument("audio", nargs="+", help="audio files")
    ar.add_argument("--json", action="store_true",
                    help="print one JSON object per file instead: value, features and the track over time")
    _batch_parser(sub)
    le = sub.add_parser("learn", help="learn an emotion preset from example animation",
                        description="Learn a preset from clips: each AUDIO file with its face-capture CSV "
                                    "(AUDIO's name with .csv) and its transcript (.txt) or alignment "
                                    "(.TextGrid) beside it.")
    le.add_argument("audio", nargs="+", help="the clips' audio files (at least two)")
    le.add_argument("--out", required=True, metavar="PRESET.json",
                    help="preset to write; the training report goes beside it as PRESET.report.json")
    le.add_argument("--name", help="preset name (default: the file's name)")
    le.add_argument("--emotion", default="neutral", help="built-in preset to start from (default: neutral)")
    le.add_argument("--viseme-set", default="arkit", help="viseme set to learn poses for (default: arkit)")
    le.add_argument("--holdout", type=float, default=0.2,
                    help="share of clips held out when there are more than 8 (default: 0.2); with 8 or fewer "
                         "each clip is held out in turn")
    le.add_argument("--track-map", metavar="MAP",
                    help="the CSVs hold generic tracks, not ARKit blendshapes: " + capture.TRACK_MAP_HELP)
    le.add_argument("--keep-learned", action="store_true",
                    help="take every learned part, even those the held-out check keeps from the starting preset")
    le.add_argument("--variance", type=float, default=0.99, help="share of variance the PCA keeps (0.99)")
    le.add_argument("--capture-fps", type=float, default=60.0, help="frame rate of CSV timecodes (60)")
    le.add_argument("--fps", type=float, default=30.0, help="frame rate the model is fitted at (30)")
    le.add_argument("--dictionary", metavar="FILE", help="user pronunciation dictionary (CMU format)")
    return ap


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.command == "list":
        print("viseme sets:", ", ".join(visemes.builtin_names()))
        print("emotions:   ", ", ".join(presets.builtin_names()))
        from .language import supported_languages

        print("languages:  ", supported_languages())
        return 0
    if args.command == "learn":
        return _learn(args)
    if args.command == "batch":
        return _batch(args)
    if args.command == "arousal":
        from .arousal_cli import run as run_arousal

        return run_arousal(args.audio, args.json)
    from .alignment import AlignSettings
    from .pipeline import analyze

    if not (args.json or args.csv):
        print("error: give --json OUT and/or --csv OUT", file=sys.stderr)
        return 2
    try:
        from .batch import check_audio_path
        from .output import check_output_path

        _check_options(args)
        check_audio_path(args.audio)

        inputs = (args.audio, args.transcript, args.alignment)
        for flag, out in (("--json", args.json), ("--csv", args.csv)):
            if out:
                check_output_path(out, f"{flag} output", inputs)
        if args.json and args.csv and os.path.abspath(args.json) == os.path.abspath(args.csv):
            raise LipSyncError(f"--json and --csv name the same file: {args.json}")
        text, warnings = None, []
        if args.transcript:
            text, warnings = read_text_file(args.transcript)
            if not text.strip():
                raise LipSyncError(f"the transcript is empty: {args.transcript} holds no text")
            for w in warnings:
                print(f"warning: {w}", file=sys.stderr)
        elif args.text is not None:
            text = args.text
        elif not args.alignment:
            # The transcript beside the audio (line.txt for line.wav), else the words are recognised.
            side = os.path.splitext(args.audio)[0] + ".txt"
            if os.path.isfile(side):
                args.transcript = side
                text, warnings = read_text_file(side)
                if not text.strip():
                    raise LipSyncError(f"the transcript is empty: {side} holds no text")
                if not args.quiet:
                    print(f"transcript: {side}")
                for w in warnings:
                    print(f"warning: {w}", file=sys.stderr)
        t0 = time.perf_counter()
        settings = _line_settings(args, align=AlignSettings(workers=args.workers))
        result = analyze(args.audio, text, settings, alignment=args.alignment, transcript_path=args.transcript)
        result.notes[:0] = warnings
        for w in result.warnings:
            print(f"warning: {w}", file=sys.stderr)
        result.warnings[:0] = warnings
        for out, write in ((args.json, result.write_json), (args.csv, result.write_csv)):
            if out:
                try:
                    write(out)
                except OSError as exc:
                    raise LipSyncError(f"cannot write {out}: {exc.strerror or exc}") from None
    except LipSyncError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    if not args.quiet:
        al = result.alignment
        print(f"{len(al.words)} words, {len(al.phones)} phonemes ({al.n_estimated} estimated), "
              f"{len(result.times)} frames at {result.fps:.3f} fps, "
              f"{result.duration:.2f} s of audio in {time.perf_counter() - t0:.2f} s")
        for note in result.notes:
            if note not in result.warnings:
                print("note:", note)
        from .output import beyond_script

        beyond = beyond_script(al)
        if beyond:
            print(beyond)
    return 0


def _learn(args) -> int:
    from . import learning

    progress = learning.Console()      # a bar on a terminal, else a line per step
    try:
        if not (0.0 < args.holdout < 1.0):
            raise LipSyncError("--holdout must be between 0 and 1")
        if not (0.5 <= args.variance <= 1.0):
            raise LipSyncError("--variance must be between 0.5 and 1")
        track_map = capture.load_track_map(args.track_map) if args.track_map else None
        clips = []
        for k, path in enumerate(args.audio):
            progress("align", k / len(args.audio))
            clips.append(learning.load_clip(path, capture_fps=args.capture_fps, dictionary=args.dictionary,
                                         track_map=track_map))
        name = args.name or Path(args.out).stem
        result = learning.learn(clips, emotion=args.emotion, viseme_set=args.viseme_set, name=name,
                             holdout=args.holdout, variance=args.variance, fps=args.fps, progress=progress,
                             keep_learned=args.keep_learned)
        preset_path, report_path = result.save(args.out)
    except LipSyncError as exc:
        progress.close()
        print(f"error: {exc}", file=sys.stderr)
        return 1
    progress.close()
    r = result.report
    print(learning.summary_text(r))
    print(f"wrote {preset_path} and {report_path}")
    return 0


def _batch_parser(sub) -> None:
    b = sub.add_parser("batch", help="lip-sync every line of a manifest (CSV or JSON lines)",
                       description="Lip-sync every line of a manifest: a CSV file with a header or a JSON-lines "
                                   "file whose lines name audio, and transcript (file), text (inline) or "
                                   "alignment (file); optionally emotion, viseme_set, fps, language and output "
                                   "(any other column is an error). Relative "
                                   "paths are read from the manifest's folder. A line is skipped when its "
                                   "outputs record that they were made from the same files, manifest row, "
                                   "options and engine (see --force).")
    b.add_argument("manifest", help="the manifest: .csv with a header, or JSON lines")
    b.add_argument("--out", metavar="DIR", help="write outputs under DIR (default: beside each audio file)")
    b.add_argument("--json", action="store_true", help="write JSON results (the default when no format is given)")
    b.add_argument("--csv", action="store_true", help="write CSV frame tables")
    b.add_argument("--workers", type=int, default=0, help="worker processes (default: one per core)")
    b.add_argument("--scheduler", metavar="ADDRESS", help="run on a Dask cluster, e.g. tcp://10.0.0.5:8786")
    b.add_argument("--cluster-timeout", type=float, default=60.0, metavar="SECONDS",
                   help="with --scheduler: give up when the cluster has not taken the lines (scheduler reached, "
                        "a worker joined, the engine loaded) within SECONDS, or has had no worker that long "
                        "(default: 60)")
    b.add_argument("--force", action="store_true", help="redo every line, up to date or not")
    b.add_argument("--report", metavar="FILE", help="write a JSON report of every line")
    _style_options(b, per_line=True)
    b.add_argument("--quiet", action="store_true", help="print nothing but failures")


def _batch(args) -> int:
    from . import batch

    formats = tuple(f for f in ("json", "csv") if getattr(args, f)) or ("json",)
    try:
        _check_options(args)
        defaults = _line_settings(args)
        report = batch.run(args.manifest, defaults, formats=formats, out_dir=args.out, workers=args.workers,
                           force=args.force, scheduler=args.scheduler, cluster_timeout=args.cluster_timeout)
    except LipSyncError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("error: interrupted; finished lines are kept, run again to do the rest", file=sys.stderr)
        return 130
    if args.report:
        try:
            report.write(args.report)
        except OSError as exc:
            print(f"error: cannot write the report {args.report}: {batch.one_line_error(exc)}", file=sys.stderr)
            return 1
    for msg in report.failure_lines():
        print(f"failed: {msg}", file=sys.stderr)
    if not args.quiet:
        for o in report.outcomes:
            if o.beyond:
                print(f"line {o.number} ({o.label}): {o.beyond}")
    if not args.quiet:
        print(report.summary())
    return 0 if report.ok else 1
