"""Many lines of dialogue in one run: a manifest, a pool of warm workers,
resumable outputs and a failure report.

A manifest is a CSV file with a header or a JSON-lines file; each line names
``audio`` and its words as ``transcript`` (a file), ``text`` (inline) or
``alignment`` (a file to import), optionally ``emotion``, ``viseme_set``,
``fps`` and ``output``; ``mesh``, ``strip`` and ``frame`` are for Blender's
batch command and ignored here.  Relative paths are read from the
manifest's folder.

The pieces, each usable alone:

* :func:`read_manifest` turns the file into :class:`Line` values (a line
  that cannot be read becomes a :class:`Line` carrying its ``problem``);
* :func:`produced_by` records what a line's outputs are made from (kept in
  the JSON as ``produced_by``, beside a CSV), and :func:`freshness` says
  whether the outputs there were made from the same, or why not;
* :func:`warm` loads the models and dictionaries once per process, and
  :func:`analyze_line` lip-syncs one line in that process;
* :func:`run_local` (a process pool), :func:`run_dask` (a Dask cluster) and
  :func:`run_inline` (this process: Blender) yield one :class:`Outcome` per
  line as lines finish;
* :func:`run` ties them together with the progress bar, writes the outputs
  (once per line, atomically, by this process) and returns a :class:`Report`.

Nothing here imports Blender, and tqdm and Dask are imported only when a
progress bar or a cluster is asked for, so the Blender extension, which
bundles neither, can use the manifest reader and :func:`run_inline`.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import os
import re
import sys
import time
from dataclasses import dataclass, field, fields, is_dataclass
from functools import lru_cache
from pathlib import Path
from typing import Callable, Iterable, Iterator

from .emotion_track import DEFAULT_FADE
from .errors import AudioError, LipSyncError

#: Manifest columns this module reads; Blender's command also reads the last three.
COLUMNS = ("audio", "transcript", "text", "alignment", "emotion", "viseme_set", "fps", "output", "language",
           "mesh", "strip", "frame")
FORMATS = ("json", "csv")
#: The columns that shape a line's outputs, kept in the record of what made them.
ROW_COLUMNS = COLUMNS[:9]
#: The layout of that record ("produced_by"); a new layout makes every output stale.
RECORD_SCHEMA = 1
#: A CSV output's record is kept beside it, in a file named so (a JSON output holds its own).
CSV_RECORD_SUFFIX = ".produced_by"


@dataclass
class Defaults:
    """What a line does not say for itself."""

    emotion: str = "neutral"
    viseme_set: str | None = None
    fps: str = "30"
    coarticulation: str = "dominance"
    dictionary: str | None = None
    emotion_fade: float = DEFAULT_FADE
    language: str = "en"


@dataclass
class Line:
    """One manifest line, its paths resolved."""

    number: int                        # line number in the manifest file (1 = first line)
    audio: str | None = None
    transcript: str | None = None
    text: str | None = None
    alignment: str | None = None
    emotion: str | None = None
    viseme_set: str | None = None
    fps: str | None = None
    language: str | None = None
    outputs: dict[str, str] = field(default_factory=dict)   # format -> path
    extra: dict[str, str] = field(default_factory=dict)     # mesh, strip, frame (Blender)
    problem: str | None = None          # why the line cannot be run
    row: dict[str, str] = field(default_factory=dict)       # its ROW_COLUMNS as written in the manifest
    record: dict | None = None          # what its outputs will be made from (see produced_by)

    def label(self) -> str:
        return self.audio or self.extra.get("strip") or self.extra.get("mesh") or "-"

    def inputs(self) -> dict[str, str]:
        """The line's own files, by role: its audio, transcript (the .txt
        beside the audio when it names no words) and alignment."""
        out = {k: getattr(self, k) for k in ("audio", "transcript", "alignment") if getattr(self, k)}
        if self.audio and not (self.transcript or self.text is not None or self.alignment):
            out["transcript"] = str(Path(self.audio).with_suffix(".txt"))
        return out


@dataclass
class Outcome:
    """What became of one line."""

    number: int
    label: str
    status: str                         # "ok", "skipped" or "failed"
    outputs: list[str] = field(default_factory=list)
    error: str | None = None
    seconds: float = 0.0
    result: object = None               # the pipeline.Result while it is being written
    record: dict | None = None          # what the result was made from, while it is being written
    reason: str | None = None           # why a line whose outputs existed was done again
    beyond: str = ""                    # how far the take strayed from its script (output.beyond_script)


# ---------------------------------------------------------------------------
# the manifest

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
                extra={k: row[k].strip() for k in ("mesh", "strip", "frame") if row.get(k, "").strip()},
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
    from .language import resolve_language

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


# ---------------------------------------------------------------------------
# what made an output

@lru_cache(maxsize=1)
def engine_version() -> str:
    """The extension's version, from ``blender_manifest.toml`` (in the
    extension's folder, or one above it in a checkout), or from the
    ``VERSION`` file of an engine shipped on its own (to a Dask cluster)."""
    shipped = Path(__file__).resolve().parent / "VERSION"
    if shipped.is_file():
        return shipped.read_text(encoding="utf-8").strip()
    here = Path(__file__).resolve().parent.parent
    for folder in (here, here.parent):
        try:
            text = (folder / "blender_manifest.toml").read_text(encoding="utf-8")
        except OSError:
            continue
        m = re.search(r'(?m)^version\s*=\s*"([^"]+)"', text)
        if m:
            return m.group(1)
    return "unknown"


@lru_cache(maxsize=1)
def _engine_data() -> str:
    """A hash of the engine's data files (timing, built-in presets and
    viseme sets, the arousal model ...), which can change between releases."""
    data = Path(__file__).resolve().parent / "data"
    h = hashlib.sha256()
    for p in sorted(data.rglob("*")):
        if p.is_file():
            h.update(p.relative_to(data).as_posix().encode() + b"\0" + p.read_bytes() + b"\0")
    return h.hexdigest()


def _plain(x):
    """``x`` as JSON-ready values (a viseme set's arrays, its dataclass)."""
    if is_dataclass(x):
        return {f.name: _plain(getattr(x, f.name)) for f in fields(x)}
    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if hasattr(x, "tolist"):
        return x.tolist()
    return x


def _digest(x) -> str:
    return hashlib.sha256(json.dumps(_plain(x), sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def _file_sha(path: str) -> str:
    with open(path, "rb") as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()


#: An input changed less than this before its record was made is hashed again
#: (a file can change twice within one tick of a coarse file-system clock).
_SAME_TICK_NS = 2 * 10**9


def _input_identity(path: str, before: dict | None, recorded_ns: int) -> dict:
    """A file's path, size, time and content hash; the hash is taken from
    ``before`` (its entry in the last record, made at ``recorded_ns``) when
    path, size and time are unchanged and the file was older than that record."""
    st = os.stat(path)
    ident = {"path": os.path.abspath(path), "size": st.st_size, "mtime_ns": st.st_mtime_ns}
    if (isinstance(before, dict) and all(before.get(k) == v for k, v in ident.items())
            and isinstance(before.get("sha256"), str) and recorded_ns - st.st_mtime_ns > _SAME_TICK_NS):
        ident["sha256"] = before["sha256"]
    else:
        ident["sha256"] = _file_sha(path)
    return ident


class Digests:
    """The hashes of presets, viseme sets and other files named by many
    lines, each taken once (per run)."""

    def __init__(self):
        self._seen: dict[tuple, str] = {}

    def _once(self, key: tuple, make) -> str:
        if key not in self._seen:
            self._seen[key] = make()
        return self._seen[key]

    def preset(self, name: str, folder: str | None = None) -> str:
        """The digest of preset ``name`` as a tag in a transcript in ``folder`` reads it."""
        from . import presets

        return self._once(("preset", folder, name), lambda: _digest(presets.finder(folder)(name)))

    def viseme_set(self, name: str) -> str:
        from . import visemes

        return self._once(("viseme_set", name), lambda: _digest(visemes.load(name)))

    def file(self, path: str) -> str:
        return self._once(("file", os.path.abspath(path)), lambda: _file_sha(path))


def produced_by(line: Line, defaults: Defaults, before: dict | None = None,
                digests: Digests | None = None) -> dict:
    """The record of what a line's outputs are made from, and its
    ``fingerprint`` (a hash of all that): the engine (version, data files,
    this record's layout), the manifest row, the command's options the row
    does not override, the preset, viseme set, emotion-tag presets,
    dictionary and arousal model used (by content, built-in ones included),
    and the line's own files (by content; ``before``, the last record,
    spares hashing a file whose size and time are unchanged).  Raises when
    something cannot be read; the line's own run then says what."""
    from .emotion_track import split_tags

    digests = digests or Digests()
    now = time.time_ns()
    engine = {"version": engine_version(), "record": RECORD_SCHEMA, "data": _engine_data()}
    settings = {"emotion": None if line.emotion else defaults.emotion,
                "viseme_set": None if line.viseme_set else defaults.viseme_set,
                "fps": None if line.fps else str(defaults.fps),
                "coarticulation": defaults.coarticulation, "emotion_fade": float(defaults.emotion_fade)}
    if (line.language or defaults.language or "en") != "en":     # English lines keep the records they had
        settings["language"] = None if line.language else defaults.language
    files = {"preset": digests.preset(line.emotion or defaults.emotion),
             "viseme_set": digests.viseme_set(line.viseme_set or defaults.viseme_set or "default")}
    text = line_text(line)
    if text:
        source = transcript_file(line)
        folder = os.path.dirname(os.path.abspath(source)) if source else None
        for tag in split_tags(text, known=lambda n: bool(digests.preset(n, folder)))[1]:
            files[f"preset {tag.preset}"] = digests.preset(tag.preset, folder)
    if defaults.dictionary:
        files["dictionary"] = digests.file(defaults.dictionary)
    model = os.environ.get("LIPSYNC_AROUSAL_MODEL")
    if model:
        files["arousal_model"] = digests.file(model)
    before = before if isinstance(before, dict) else {}
    old = before.get("inputs") if isinstance(before.get("inputs"), dict) else {}
    stamp = before.get("recorded_ns") if isinstance(before.get("recorded_ns"), int) else 0
    inputs = {role: _input_identity(path, old.get(role), stamp) for role, path in line.inputs().items()}
    fingerprint = _digest({"engine": engine, "row": line.row, "settings": settings, "files": files,
                           "inputs": {k: v["sha256"] for k, v in inputs.items()}})
    return {"fingerprint": fingerprint, "engine": engine, "row": line.row, "settings": settings, "files": files,
            "inputs": inputs, "recorded_ns": now}


_RECORD_HEAD = re.compile(r'\A\s*\{\s*"produced_by"\s*:\s*')


def read_record(fmt: str, path: str) -> dict | None:
    """The record kept with an output (None: none, or unreadable).  A JSON
    output holds it first, so only the file's head is read."""
    try:
        if fmt != "json":
            with open(path + CSV_RECORD_SUFFIX, encoding="utf-8") as fh:
                rec = json.load(fh)
            return rec if isinstance(rec, dict) else None
        with open(path, "rb") as fh:
            head = fh.read(1 << 16).decode("utf-8", "ignore")
            m = _RECORD_HEAD.match(head)
            if m:
                try:
                    rec = json.JSONDecoder().raw_decode(head, m.end())[0]
                    return rec if isinstance(rec, dict) else None
                except ValueError:
                    pass   # longer than the head: read it all
            fh.seek(0)
            doc = json.loads(fh.read().decode("utf-8"))
        rec = doc.get("produced_by") if isinstance(doc, dict) else None
        return rec if isinstance(rec, dict) else None
    except (OSError, ValueError):
        return None


def why_stale(before: dict | None, now: dict) -> str:
    """What differs between the record an output carries and the current one."""
    if not before or "fingerprint" not in before:
        return "no record of what made it"
    if before.get("engine") != now["engine"]:
        return "engine changed"
    old = before.get("inputs") or {}
    if {k: (v or {}).get("sha256") for k, v in old.items()} != {k: v["sha256"] for k, v in now["inputs"].items()}:
        return "input file changed"
    if before.get("row") != now["row"]:
        return "manifest row changed"
    if before.get("settings") != now["settings"]:
        return "settings changed"
    was, files = before.get("files") or {}, now["files"]
    for key, label in (("dictionary", "dictionary changed"), ("arousal_model", "arousal model changed")):
        if was.get(key) != files.get(key):
            return label
    return "preset or viseme set changed"


def freshness(line: Line, defaults: Defaults, digests: Digests | None = None) -> tuple[bool, str | None]:
    """(whether every output of ``line`` exists and was made from what
    would make it now, why not).  Sets ``line.record`` to the current
    record when it could be made; a line with an output missing is not up
    to date and has no reason."""
    if not line.outputs or not all(os.path.isfile(p) for p in line.outputs.values()):
        return False, None
    records = [read_record(fmt, path) for fmt, path in line.outputs.items()]
    try:
        line.record = produced_by(line, defaults, next((r for r in records if r), None), digests)
    except Exception:  # the line's own run reports what cannot be read
        line.record = None
        return False, None
    stale = [r for r in records if not r or r.get("fingerprint") != line.record["fingerprint"]]
    return (False, why_stale(stale[0], line.record)) if stale else (True, None)


def up_to_date(line: Line, defaults: Defaults | None = None) -> bool:
    """True when every output exists and was made from the same files and
    settings (see :func:`produced_by`)."""
    return freshness(line, defaults or Defaults())[0]


# ---------------------------------------------------------------------------
# one line, in a worker

_WARM = False


def warm(dictionary: str | None = None) -> None:
    """Load what every line needs, once per process: the engine's modules,
    parselmouth, the CMU dictionary and pocketsphinx's acoustic model (its
    files then come from the page cache for each line's small decoder)."""
    global _WARM
    if _WARM:
        return
    from . import pipeline, presets, prosody  # noqa: F401  (imports are the point)
    from .language import pronounce
    from .alignment import AlignSettings
    from .alignment.decoding import _decoder

    pronounce.cmudict()
    presets.builtin_names()
    try:
        _decoder([["HH", "AH"]], 0, AlignSettings())
    except Exception:  # a broken model shows up as each line's own error
        pass
    if dictionary:
        try:
            pronounce.Lexicon.with_user_file(dictionary)
        except LipSyncError:
            pass
    _WARM = True


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


def check_audio_path(path: str | os.PathLike) -> None:
    """Raise :class:`AudioError` when ``path`` is missing or a folder: said
    first, before the want of a transcript, which the audio's absence may
    cause (the transcript beside it is looked for by the audio's name)."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise AudioError(f"audio file not found: {path}")
    if os.path.isdir(path):
        raise AudioError(f"audio path is a folder, not a file: {path}")


def line_text(line: Line) -> str | None:
    """The words of a line (None when only an alignment is given, or when
    there is no transcript at all: the words are then recognised)."""
    if line.text is not None:
        return line.text
    from .language.text import read_text_file

    if line.transcript:
        return read_text_file(line.transcript)[0]
    if line.alignment:
        return None
    if line.audio:
        side = Path(line.audio).with_suffix(".txt")
        if side.is_file():
            return read_text_file(side)[0]
    return None


def transcript_file(line: Line) -> str | None:
    """The file a line's words are read from (its 'transcript', or the .txt
    beside its audio), whose folder preset files named in its tags are
    read from; None for inline text or an alignment alone."""
    if line.text is not None:
        return None
    if line.transcript:
        return line.transcript
    if line.audio and not line.alignment:
        side = Path(line.audio).with_suffix(".txt")
        if side.is_file():
            return str(side)
    return None


def analyze_line(line: Line, defaults: Defaults):
    """Lip-sync one line in this process; returns the pipeline's Result."""
    from .alignment import AlignSettings
    from .pipeline import analyze

    warm(defaults.dictionary)
    if line.problem:
        raise LipSyncError(line.problem)
    if line.audio:
        check_audio_path(line.audio)
    text = line_text(line)
    return analyze(line.audio, text, alignment=line.alignment,
                   viseme_set=line.viseme_set or defaults.viseme_set,
                   emotion=line.emotion or defaults.emotion, coarticulation_model=defaults.coarticulation,
                   fps=line.fps or defaults.fps, dictionary=defaults.dictionary,
                   emotion_fade=defaults.emotion_fade, transcript_path=transcript_file(line),
                   language=line.language or defaults.language,
                   settings=AlignSettings(workers=1))   # lines run in parallel, each on one core


def work(line: Line, defaults: Defaults) -> Outcome:
    """:func:`analyze_line` that never raises: the Outcome carries the
    Result and the record of what it was made from (taken before the work,
    unless the line brings it), or the reason it failed."""
    t0 = time.perf_counter()
    record = line.record
    if record is None and line.outputs:
        try:
            record = produced_by(line, defaults)
        except Exception:  # whatever cannot be read fails the line below, with its own message
            record = None
    try:
        result = analyze_line(line, defaults)
    except Exception as exc:  # one bad line must not stop the others
        return Outcome(line.number, line.label(), "failed", error=one_line_error(exc),
                       seconds=time.perf_counter() - t0)
    from .output import beyond_script

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


# ---------------------------------------------------------------------------
# where the lines run

def run_inline(lines: list[Line], defaults: Defaults,
               fn: Callable[[Line, Defaults], Outcome] = work) -> Iterator[Outcome]:
    """Every line in this process, in order (Blender runs its lines so)."""
    for line in lines:
        yield fn(line, defaults)


def _pool_init(dictionary):
    warm(dictionary)


def run_local(lines: list[Line], defaults: Defaults, workers: int = 0) -> Iterator[Outcome]:
    """The lines on a pool of ``workers`` processes (0: one per core), each
    loading the models once; outcomes come in the order lines finish.  A
    worker that dies (a crash in a native library) is replaced and its lines
    tried once more; a line that kills a second worker fails."""
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    n = max(1, min(workers or os.cpu_count() or 1, len(lines)))
    methods = multiprocessing.get_all_start_methods()
    ctx = multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")
    attempts = {ln.number: 0 for ln in lines}
    todo = list(lines)
    while todo:
        pool = ProcessPoolExecutor(n, mp_context=ctx, initializer=_pool_init, initargs=(defaults.dictionary,))
        futures = {pool.submit(work, ln, defaults): ln for ln in todo}
        todo = []
        try:
            pending = set(futures)
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for fut in done:
                    ln = futures[fut]
                    try:
                        yield fut.result()
                    except BrokenProcessPool:
                        attempts[ln.number] += 1
                        if attempts[ln.number] >= 2:
                            yield Outcome(ln.number, ln.label(), "failed",
                                          error="the worker process died while lip-syncing this line")
                        else:
                            todo.append(ln)
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
        todo.sort(key=lambda ln: ln.number)


def run_dask(lines: list[Line], defaults: Defaults, scheduler, timeout: float = 60.0) -> Iterator[Outcome]:
    """The lines on a Dask distributed cluster (``scheduler``: its address,
    or a ``distributed.Client``) whose machines need the engine's packages
    but not this one: see :mod:`.cluster`.  Outcomes come as lines finish;
    LipSyncError, within ``timeout`` seconds, when the cluster cannot run
    the lines."""
    from .cluster import run_dask as _run_dask

    return _run_dask(lines, defaults, scheduler, timeout)


# ---------------------------------------------------------------------------
# the whole batch

@dataclass
class Report:
    """The batch's result, line by line."""

    manifest: str
    outcomes: list[Outcome] = field(default_factory=list)
    seconds: float = 0.0

    def count(self, status: str) -> int:
        return sum(1 for o in self.outcomes if o.status == status)

    @property
    def ok(self) -> bool:
        return self.count("failed") == 0

    def failures(self) -> list[Outcome]:
        return sorted((o for o in self.outcomes if o.status == "failed"), key=lambda o: o.number)

    def summary(self) -> str:
        done = self.count("ok")
        rate = f", {done / self.seconds:.1f} lines/s" if done and self.seconds > 0 else ""
        return (f"{len(self.outcomes)} lines: {done} done, {self.count('skipped')} up to date, "
                f"{self.count('failed')} failed, in {self.seconds:.1f} s{rate}{self.redone()}")

    def redone(self) -> str:
        """Why lines whose outputs existed were done again: '; 3 redone:
        settings changed' (empty when none were)."""
        why: dict[str, int] = {}
        for o in self.outcomes:
            if o.status == "ok" and o.reason:
                why[o.reason] = why.get(o.reason, 0) + 1
        if not why:
            return ""
        n = sum(why.values())
        if len(why) == 1:
            return f"; {n} redone: {next(iter(why))}"
        return f"; {n} redone: " + ", ".join(f"{k} {r}" for r, k in sorted(why.items(), key=lambda x: -x[1]))

    def failure_lines(self) -> list[str]:
        return [f"line {o.number} ({o.label}): {o.error}" for o in self.failures()]

    def to_dict(self) -> dict:
        lines = []
        for o in sorted(self.outcomes, key=lambda o: o.number):
            d = {f.name: getattr(o, f.name) for f in fields(o) if f.name not in ("result", "record")}
            d["line"] = d.pop("number")
            d["file"] = d.pop("label")
            d["seconds"] = round(d["seconds"], 4)
            lines.append(d)
        return {"manifest": self.manifest, "total": len(self.outcomes), "succeeded": self.count("ok"),
                "skipped": self.count("skipped"), "failed": self.count("failed"),
                "seconds": round(self.seconds, 3), "lines": lines}

    def write(self, path: str | os.PathLike) -> None:
        with open(path, "w", encoding="utf-8") as fh:
            json.dump(self.to_dict(), fh, indent=1)


def _progress_bar(total: int, initial: int, enabled: bool | None):
    """A tqdm bar on stderr (lines done, rate, ETA); None when stderr is not
    a terminal (or ``enabled`` is False)."""
    if enabled is None:
        enabled = sys.stderr.isatty()
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, unit="line", dynamic_ncols=True, file=sys.stderr,
                smoothing=0.05)


def run(manifest: str | os.PathLike, defaults: Defaults | None = None, *, formats=("json",),
        out_dir: str | None = None, workers: int = 0, force: bool = False, scheduler=None,
        cluster_timeout: float = 60.0, progress: bool | None = None,
        on_outcome: Callable[[Outcome], None] | None = None) -> Report:
    """Lip-sync every line of ``manifest`` and write the outputs.

    Up-to-date lines are skipped unless ``force``; ``scheduler`` (an address
    or a ``distributed.Client``) runs the lines on a Dask cluster (which
    must take them within ``cluster_timeout`` seconds), else ``workers``
    processes here (1: this process).  ``on_outcome`` is called
    with each line's outcome as it arrives."""
    defaults = defaults or Defaults()
    t0 = time.perf_counter()
    lines = read_manifest(manifest, formats, out_dir)
    report = Report(str(manifest))
    todo, reasons, digests = [], {}, Digests()
    for ln in lines:
        if ln.problem:
            report.outcomes.append(Outcome(ln.number, ln.label(), "failed", error=ln.problem))
            continue
        fresh, reasons[ln.number] = (False, None) if force else freshness(ln, defaults, digests)
        if fresh:
            report.outcomes.append(Outcome(ln.number, ln.label(), "skipped", outputs=list(ln.outputs.values())))
        else:
            todo.append(ln)
    if on_outcome is not None:
        for out in report.outcomes:
            on_outcome(out)
    by_number = {ln.number: ln for ln in todo}
    bar = _progress_bar(len(lines), len(lines) - len(todo), progress)
    try:
        if not todo:
            stream: Iterable[Outcome] = ()
        elif scheduler is not None:
            stream = run_dask(todo, defaults, scheduler, cluster_timeout)
        elif workers == 1 or len(todo) == 1:
            stream = run_inline(todo, defaults)
        else:
            stream = run_local(todo, defaults, workers)
        for out in stream:
            if out.status == "ok":
                try:
                    out.outputs = write_outputs(by_number[out.number], out.result, out.record)
                except OSError as exc:
                    out.status, out.error = "failed", f"cannot write the output: {one_line_error(exc)}"
            out.result = out.record = None
            out.reason = reasons.get(out.number)
            report.outcomes.append(out)
            if bar is not None:
                bar.update(1)
                bar.set_postfix(failed=report.count("failed"), refresh=False)
            if on_outcome is not None:
                on_outcome(out)
    finally:
        if bar is not None:
            bar.close()
    report.outcomes.sort(key=lambda o: o.number)
    report.seconds = time.perf_counter() - t0
    return report
