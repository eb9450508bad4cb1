"""One line, in whichever process runs it: the models loaded once
(:func:`warm`), the line lip-synced (:func:`analyze_line`, :func:`work`
never raises) and its outputs written whole (:func:`write_outputs`)."""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable

from ..errors import LipSyncError
from ..settings import LineSettings
from .lines import Line, Outcome, check_audio_path, line_settings, line_text, transcript_file
from .records import CSV_RECORD_SUFFIX, produced_by

_WARM = False


def warm(dictionary: str | None = None) -> None:
    """Load what every line needs, once per process: the engine's modules,
    parselmouth, the CMU dictionary and a pocketsphinx decoder with the
    acoustic model, which the lines' passes then reuse (alignment.decoding)."""
    global _WARM
    if _WARM:
        return
    from .. import pipeline, presets, prosody  # noqa: F401  (imports are the point)
    from ..language import pronounce
    from ..alignment import AlignSettings
    from ..alignment.decoding import _decoder

    pronounce.cmudict()
    presets.builtin_names()
    try:
        _decoder([["HH", "AH"]], 0, AlignSettings())
    except Exception:  # noqa: BLE001 - a broken model shows up as each line's own error
        pass
    if dictionary:
        try:
            pronounce.Lexicon.with_user_file(dictionary)
        except LipSyncError:
            pass
    _WARM = True


def one_core() -> None:
    """Keep numpy's BLAS to one thread in a process that lip-syncs one line
    at a time beside others (a batch's worker processes, a Dask worker).  The
    engine's matrices are small; given a thread per core, BLAS gains nothing
    on them, and its threads spin on after each product, taking the core of
    the worker beside it.  (threadpoolctl comes with the batch's packages;
    without it, nothing is changed.)"""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return
    threadpool_limits(1, user_api="blas")


def one_line_error(exc: BaseException) -> str:
    """An exception as one line a user can read (no traceback)."""
    if isinstance(exc, LipSyncError):
        msg = str(exc)
    elif isinstance(exc, OSError) and exc.strerror:
        msg = f"{exc.strerror}: {exc.filename}" if exc.filename else exc.strerror
    elif isinstance(exc, MemoryError):
        msg = "out of memory"
    else:
        msg = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
    return " ".join(msg.split()) or type(exc).__name__


def analyze_line(line: Line, defaults: LineSettings):
    """Lip-sync one line in this process (``defaults``: the run's settings,
    which the line's own columns override); returns the pipeline's Result."""
    from ..pipeline import analyze

    warm(defaults.dictionary)
    if line.problem:
        raise LipSyncError(line.problem)
    if line.audio:
        check_audio_path(line.audio)
    text = line_text(line)
    return analyze(line.audio, text, line_settings(line, defaults), alignment=line.alignment,
                   transcript_path=transcript_file(line))


def work(line: Line, defaults: LineSettings) -> Outcome:
    """:func:`analyze_line` that never raises: the Outcome carries the
    Result and the record of what it was made from (taken before the work,
    unless the line brings it), or the reason it failed."""
    t0 = time.perf_counter()
    record = line.record
    if record is None and line.outputs:
        try:
            record = produced_by(line, defaults)
        except Exception:  # noqa: BLE001 - whatever cannot be read fails the line below, with its own message
            record = None
    try:
        result = analyze_line(line, defaults)
    except Exception as exc:  # noqa: BLE001 - one bad line must not stop the others
        return Outcome(line.number, line.label(), "failed", error=one_line_error(exc),
                       seconds=time.perf_counter() - t0)
    from ..output import beyond_script

    return Outcome(line.number, line.label(), "ok", seconds=time.perf_counter() - t0, result=result,
                   record=record, beyond=beyond_script(result.alignment))


def _replace(path: str, write: Callable[[str], None]) -> None:
    """``write`` to a temporary file, then put it in place of ``path``."""
    tmp = f"{path}.part{os.getpid()}"
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _write_text(text: str) -> Callable[[str], None]:
    def write(path: str) -> None:
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(text)
    return write


def write_outputs(line: Line, result, record: dict | None = None) -> list[str]:
    """Write a line's JSON/CSV through a temporary file each, so an output
    that exists is always complete, with ``record`` (what it was made from):
    first in the JSON as ``produced_by``, beside a CSV in a file named with
    :data:`CSV_RECORD_SUFFIX` (written after the CSV, or removed when there
    is no record, so that a record never describes a CSV it did not make)."""
    written = []
    for fmt, path in line.outputs.items():
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        if fmt == "json":
            doc = result.to_dict()
            if record is not None:
                doc = {"produced_by": record, **{k: v for k, v in doc.items() if k != "produced_by"}}
            _replace(path, _write_text(json.dumps(doc, separators=(",", ":"))))
        else:
            side = path + CSV_RECORD_SUFFIX
            if record is None and os.path.exists(side):
                os.unlink(side)
            _replace(path, result.write_csv)
            if record is not None:
                _replace(side, _write_text(json.dumps(record, indent=1) + "\n"))
        written.append(path)
    return written
