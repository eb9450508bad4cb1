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
* :func:`up_to_date` says whether a line's outputs are newer than its inputs;
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
import io
import json
import os
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable, Iterable, Iterator

from .emotion_track import DEFAULT_FADE
from .errors import LipSyncError

#: Manifest columns this module reads; Blender's command also reads the last three.
COLUMNS = ("audio", "transcript", "text", "alignment", "emotion", "viseme_set", "fps", "output",
           "mesh", "strip", "frame")
FORMATS = ("json", "csv")


@dataclass
class Defaults:
    """What a line does not say for itself."""

    emotion: str = "neutral"
    viseme_set: str | None = None
    fps: str = "30"
    coarticulation: str = "dominance"
    dictionary: str | None = None
    emotion_fade: float = DEFAULT_FADE


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
    outputs: dict[str, str] = field(default_factory=dict)   # format -> path
    extra: dict[str, str] = field(default_factory=dict)     # mesh, strip, frame (Blender)
    problem: str | None = None          # why the line cannot be run

    def label(self) -> str:
        return self.audio or self.extra.get("strip") or self.extra.get("mesh") or "-"

    def inputs(self) -> list[str]:
        """The files the outputs depend on."""
        out = [p for p in (self.audio, self.transcript, self.alignment) if p]
        out += [p for p in (self.emotion, self.viseme_set) if p and p.endswith(".json")]
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
    manifest's folder, else beside the audio."""
    if output:
        stem = Path(_resolve(base, output))
        stem = stem.with_suffix("") if stem.suffix.lower() in (".json", ".csv") else stem
    else:
        audio = Path(line.audio)
        if out_dir:
            try:
                rel = audio.with_suffix("").relative_to(base)
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
    line = Line(number,
                audio=_resolve(base, row.get("audio")),
                transcript=_resolve(base, row.get("transcript")),
                text=row.get("text") or None,
                alignment=_resolve(base, row.get("alignment")),
                emotion=_named_or_file(base, row.get("emotion")),
                viseme_set=_named_or_file(base, row.get("viseme_set")),
                fps=(row.get("fps") or "").strip() or None,
                extra={k: row[k].strip() for k in ("mesh", "strip", "frame") if row.get(k, "").strip()})
    given = [k for k in ("transcript", "text", "alignment") if getattr(line, k)]
    if line.audio is None and "strip" not in line.extra:
        line.problem = "no audio file named"
    elif len(given) > 1 and not (given == ["transcript", "alignment"] or given == ["text", "alignment"]):
        line.problem = "give one of transcript or text, not both"
    elif line.audio is not None:
        line.outputs = output_paths(line, base, formats, out_dir, row.get("output", "").strip() or None)
    return line


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


def up_to_date(line: Line) -> bool:
    """True when every output exists and is newer than every input file."""
    if not line.outputs:
        return False
    try:
        newest_in = max((os.path.getmtime(p) for p in line.inputs()), default=0.0)
        return all(os.path.getmtime(o) >= newest_in for o in line.outputs.values())
    except OSError:
        return False


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
    from . import align, pipeline, presets, pronounce, prosody  # noqa: F401  (imports are the point)

    pronounce.cmudict()
    presets.builtin_names()
    try:
        align._decoder([["HH", "AH"]], 0, align.AlignSettings())
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


def line_text(line: Line) -> str | None:
    """The words of a line (None when only an alignment is given)."""
    if line.text is not None:
        return line.text
    from .text import read_text_file

    if line.transcript:
        return read_text_file(line.transcript)[0]
    if line.alignment:
        return None
    if line.audio:
        side = Path(line.audio).with_suffix(".txt")
        if side.is_file():
            return read_text_file(side)[0]
    raise LipSyncError("no transcript: give a 'transcript', 'text' or 'alignment' column "
                       "(or put a .txt beside the audio)")


def analyze_line(line: Line, defaults: Defaults):
    """Lip-sync one line in this process; returns the pipeline's Result."""
    from .align import AlignSettings
    from .pipeline import analyze

    warm(defaults.dictionary)
    if line.problem:
        raise LipSyncError(line.problem)
    text = line_text(line)
    return analyze(line.audio, text, alignment=line.alignment,
                   viseme_set=line.viseme_set or defaults.viseme_set,
                   emotion=line.emotion or defaults.emotion, coarticulation_model=defaults.coarticulation,
                   fps=line.fps or defaults.fps, dictionary=defaults.dictionary,
                   emotion_fade=defaults.emotion_fade,
                   settings=AlignSettings(workers=1))   # lines run in parallel, each on one core


def work(line: Line, defaults: Defaults) -> Outcome:
    """:func:`analyze_line` that never raises: the Outcome carries the
    Result, or the reason it failed."""
    t0 = time.perf_counter()
    try:
        result = analyze_line(line, defaults)
    except Exception as exc:  # one bad line must not stop the others
        return Outcome(line.number, line.label(), "failed", error=one_line_error(exc),
                       seconds=time.perf_counter() - t0)
    return Outcome(line.number, line.label(), "ok", seconds=time.perf_counter() - t0, result=result)


def write_outputs(line: Line, result) -> list[str]:
    """Write a line's JSON/CSV through a temporary file each, so an output
    that exists is always complete."""
    written = []
    for fmt, path in line.outputs.items():
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        tmp = f"{path}.part{os.getpid()}"
        try:
            (result.write_json if fmt == "json" else result.write_csv)(tmp)
            os.replace(tmp, path)
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
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
                f"{self.count('failed')} failed, in {self.seconds:.1f} s{rate}")

    def failure_lines(self) -> list[str]:
        return [f"line {o.number} ({o.label}): {o.error}" for o in self.failures()]

    def to_dict(self) -> dict:
        lines = []
        for o in sorted(self.outcomes, key=lambda o: o.number):
            d = asdict(o) if o.result is None else {k: v for k, v in asdict(o).items() if k != "result"}
            d.pop("result", None)
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
    todo = []
    for ln in lines:
        if ln.problem:
            report.outcomes.append(Outcome(ln.number, ln.label(), "failed", error=ln.problem))
        elif not force and up_to_date(ln):
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
                    out.outputs = write_outputs(by_number[out.number], out.result)
                except OSError as exc:
                    out.status, out.error = "failed", f"cannot write the output: {one_line_error(exc)}"
            out.result = None
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
