"""Command line: ``python -m addon analyze AUDIO --text "..." --json out.json``."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from . import presets, visemes
from .errors import LipSyncError


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="python -m addon",
                                 description="Emotive lip sync: audio + transcript -> viseme curves.")
    sub = ap.add_subparsers(dest="command", required=True)
    a = sub.add_parser("analyze", help="align a line of dialogue and write its viseme curves")
    a.add_argument("audio", help="WAV, FLAC, MP3 or AIFF file, any rate, mono or stereo")
    src = a.add_mutually_exclusive_group()
    src.add_argument("--transcript", metavar="FILE", help="UTF-8 text file with what is said")
    src.add_argument("--text", help="what is said, inline")
    a.add_argument("--alignment", metavar="FILE",
                   help="use this alignment instead of aligning: .TextGrid, Rhubarb .json/.tsv, Papagayo .pgo")
    a.add_argument("--viseme-set", default="default",
                   help=f"built-in ({', '.join(visemes.builtin_names())}) or a .json file (default: default)")
    a.add_argument("--emotion", default="neutral",
                   help=f"built-in preset ({', '.join(presets.builtin_names())}) or a .json file (default: neutral)")
    a.add_argument("--coarticulation", choices=("dominance", "rules"), default="dominance")
    a.add_argument("--fps", default="30", help="frames per second: 24, 25, 30, 60, 23.976, 29.97, 24000/1001 ...")
    a.add_argument("--dictionary", metavar="FILE", help="user pronunciation dictionary (CMU format)")
    a.add_argument("--workers", type=int, default=0, help="alignment processes (0: one per core)")
    a.add_argument("--json", metavar="OUT", help="write the result as JSON")
    a.add_argument("--csv", metavar="OUT", help="write the frame table as CSV")
    a.add_argument("--quiet", action="store_true", help="print nothing but errors")
    sub.add_parser("list", help="list built-in viseme sets and emotion presets")
    return ap


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.command == "list":
        print("viseme sets:", ", ".join(visemes.builtin_names()))
        print("emotions:   ", ", ".join(presets.builtin_names()))
        return 0
    from .align import AlignSettings
    from .pipeline import analyze

    if not (args.json or args.csv):
        print("error: give --json OUT and/or --csv OUT", file=sys.stderr)
        return 2
    try:
        text = None
        if args.transcript:
            p = Path(args.transcript)
            if not p.is_file():
                raise LipSyncError(f"transcript file not found: {p}")
            text = p.read_text(encoding="utf-8-sig")
        elif args.text is not None:
            text = args.text
        if text is None and not args.alignment:
            raise LipSyncError("give the transcript with --transcript FILE or --text \"...\" "
                               "(or an alignment with --alignment FILE)")
        t0 = time.perf_counter()
        result = analyze(args.audio, text, alignment=args.alignment, viseme_set=args.viseme_set,
                         emotion=args.emotion, coarticulation_model=args.coarticulation, fps=args.fps,
                         dictionary=args.dictionary, settings=AlignSettings(workers=args.workers))
        if args.json:
            result.write_json(args.json)
        if args.csv:
            result.write_csv(args.csv)
    except LipSyncError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    if not args.quiet:
        al = result.alignment
        print(f"{len(al.words)} words, {len(al.phones)} phonemes ({al.n_estimated} estimated), "
              f"{len(result.times)} frames at {result.fps:.3f} fps, "
              f"{result.duration:.2f} s of audio in {time.perf_counter() - t0:.2f} s")
        for note in result.notes:
            print("note:", note)
    return 0
