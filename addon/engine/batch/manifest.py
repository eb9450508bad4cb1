"""Reading a manifest: a CSV file with a header or a JSON-lines file, one
:class:`.lines.Line` per line (a line that cannot be read carries its
``problem``), with its paths resolved and its outputs named."""

from __future__ import annotations

import csv
import io
import json
import os
from pathlib import Path
from collections.abc import Iterable, Iterator

from ..errors import LipSyncError
from .lines import COLUMNS, ROW_COLUMNS, Line

def _rows(path: Path) -> Iterator[tuple[int, dict]]:
    """(line number, row) of a CSV-with-header or JSON-lines manifest."""
    try:
        raw = path.read_text(encoding="utf-8-sig")
    except OSError as exc:
        raise LipSyncError(f"cannot read manifest {path}: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise LipSyncError(f"manifest {path} is not UTF-8 text") from None
    first = next((ln for ln in raw.splitlines() if ln.strip()), "")
    if not first:
        raise LipSyncError(f"manifest {path} is empty")
    if first.lstrip().startswith("{"):
        for k, ln in enumerate(raw.splitlines(), 1):
            if not ln.strip() or ln.lstrip().startswith("#"):
                continue
            try:
                row = json.loads(ln)
            except json.JSONDecodeError as exc:
                yield k, {"__problem__": f"not valid JSON ({exc.msg}, column {exc.colno})"}
                continue
            yield k, row if isinstance(row, dict) else {"__problem__": "a JSON line must be an object"}
        return
    reader = csv.DictReader(io.StringIO(raw))
    header = [h.strip().lower() for h in (reader.fieldnames or [])]
    if not {"audio", "strip", "mesh"} & set(header):
        raise LipSyncError(f"manifest {path}: the CSV header must name an 'audio' column "
                           f"(found: {', '.join(header) or 'nothing'})")
    unknown = [h for h in header if h and h not in COLUMNS]
    if unknown:
        raise LipSyncError(f"manifest {path}: unknown column{'s' if len(unknown) > 1 else ''} "
                           f"{', '.join(repr(h) for h in unknown)}; the columns are {', '.join(COLUMNS)}")
    reader.fieldnames = header
    for row in reader:
        if not any((v or "").strip() for v in row.values() if isinstance(v, str)):
            continue
        if None in row:
            yield reader.line_num, {"__problem__": f"{len(header) + len(row[None])} fields where the "
                                                   f"header has {len(header)}"}
            continue
        yield reader.line_num, row


def _resolve(base: Path, value) -> str | None:
    if value is None or str(value).strip() == "":
        return None
    p = Path(str(value).strip()).expanduser()
    return str(p if p.is_absolute() else base / p)


def _named_or_file(base: Path, value) -> str | None:
    """A preset or viseme set: a built-in name as is, a .json file resolved."""
    if value is None or str(value).strip() == "":
        return None
    value = str(value).strip()
    return _resolve(base, value) if value.endswith(".json") else value


def output_paths(line: Line, base: Path, formats: Iterable[str], out_dir: str | None,
                 output: str | None) -> dict[str, str]:
    """Where a line's results go: ``output`` (its extension replaced per
    format), else under ``out_dir`` mirroring the audio's place below the
    manifest's folder (audio elsewhere, ``../x.wav`` included, goes straight
    into ``out_dir`` by its name), else beside the audio."""
    if output:
        stem = Path(_resolve(base, output))
        stem = stem.with_suffix("") if stem.suffix.lower() in (".json", ".csv") else stem
    else:
        audio = Path(line.audio)
        if out_dir:
            # Compared once '..' is folded in, so that no output lands above out_dir.
            try:
                rel = Path(os.path.normpath(audio.with_suffix(""))).relative_to(os.path.normpath(base))
            except ValueError:
                rel = Path(audio.stem)
            stem = Path(out_dir) / rel
        else:
            stem = audio.with_suffix("")
    return {f: str(stem) + "." + f for f in formats}


def _line(number: int, row: dict, base: Path, formats, out_dir) -> Line:
    if "__problem__" in row:
        return Line(number, problem=row["__problem__"])
    row = {str(k).strip().lower(): ("" if v is None else str(v)) for k, v in row.items()}
    unknown = [k for k in row if k not in COLUMNS]
    if unknown:
        return Line(number, problem=f"unknown field{'s' if len(unknown) > 1 else ''} "
                                    f"{', '.join(repr(k) for k in unknown)}; the fields are {', '.join(COLUMNS)}")
    line = Line(number,
                audio=_resolve(base, row.get("audio")),
                transcript=_resolve(base, row.get("transcript")),
                text=row.get("text") or None,
                alignment=_resolve(base, row.get("alignment")),
                emotion=_named_or_file(base, row.get("emotion")),
                viseme_set=_named_or_file(base, row.get("viseme_set")),
                fps=(row.get("fps") or "").strip() or None,
                language=(row.get("language") or "").strip() or None,
                extra={k: row[k].strip() for k in ("mesh", "strip", "frame", "edits", "lock")
                       if row.get(k, "").strip()},
                row={k: row[k] for k in ROW_COLUMNS if row.get(k, "").strip()})
    given = [k for k in ("transcript", "text", "alignment") if getattr(line, k)]
    if line.audio is None and "strip" not in line.extra:
        line.problem = "no audio file named"
    elif len(given) > 1 and not (given == ["transcript", "alignment"] or given == ["text", "alignment"]):
        line.problem = "give one of transcript or text, not both"
    elif line.language is not None and _language_problem(line.language):
        line.problem = _language_problem(line.language)
    elif line.audio is not None:
        line.outputs = output_paths(line, base, formats, out_dir, row.get("output", "").strip() or None)
    return line


def _language_problem(code: str) -> str | None:
    from ..language import resolve_language

    try:
        resolve_language(code)
    except LipSyncError as exc:
        return str(exc)
    return None


def read_manifest(path: str | os.PathLike, formats: Iterable[str] = ("json",),
                  out_dir: str | None = None) -> list[Line]:
    """Every line of the manifest.  Raises :class:`LipSyncError` only when
    the file as a whole cannot be read; a bad line comes back with its
    ``problem`` set, and two lines writing the same file are both kept, the
    second with a problem."""
    path = Path(path)
    base = path.resolve().parent
    formats = tuple(formats)
    lines = [_line(n, row, base, formats, out_dir) for n, row in _rows(path)]
    if not lines:
        raise LipSyncError(f"manifest {path} names no lines")
    owner: dict[str, int] = {}
    for ln in lines:
        for out in ln.outputs.values():
            key = os.path.normcase(os.path.abspath(out))
            if key in owner and ln.problem is None:
                ln.problem = f"output {out} is also written by line {owner[key]}; give this line an 'output'"
            owner.setdefault(key, ln.number)
    return lines
