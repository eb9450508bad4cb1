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

import json
import os
import sys
import time
from dataclasses import dataclass, field, fields
from collections.abc import Callable, Iterable, Iterator

from ..settings import LineSettings
from .lines import COLUMNS, FORMATS, ROW_COLUMNS, SETTING_COLUMNS, Line, Outcome, check_audio_path, line_settings, \
    line_text, transcript_file
from .manifest import output_paths, read_manifest
from .records import CSV_RECORD_SUFFIX, RECORD_SCHEMA, Digests, engine_version, freshness, produced_by, \
    read_record, up_to_date, why_stale
from .work import analyze_line, one_core, one_line_error, warm, work, write_outputs

__all__ = ["COLUMNS", "CSV_RECORD_SUFFIX", "FORMATS", "RECORD_SCHEMA", "ROW_COLUMNS", "SETTING_COLUMNS", "Digests",
           "Line", "Outcome", "Report", "analyze_line", "check_audio_path", "engine_version", "freshness",
           "line_settings", "line_text", "one_line_error", "output_paths", "produced_by", "read_manifest",
           "read_record", "run", "run_dask", "run_inline", "run_local", "transcript_file", "up_to_date", "warm",
           "why_stale", "work", "write_outputs"]

# ---------------------------------------------------------------------------
# where the lines run

def run_inline(lines: list[Line], defaults: LineSettings,
               fn: Callable[[Line, LineSettings], Outcome] = work) -> Iterator[Outcome]:
    """Every line in this process, in order (Blender runs its lines so)."""
    for line in lines:
        yield fn(line, defaults)


def _pool_init(dictionary):
    one_core()
    warm(dictionary)


def run_local(lines: list[Line], defaults: LineSettings, workers: int = 0) -> Iterator[Outcome]:
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


def run_dask(lines: list[Line], defaults: LineSettings, scheduler, timeout: float = 60.0) -> Iterator[Outcome]:
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


def run(manifest: str | os.PathLike, defaults: LineSettings | None = None, *, formats=("json",),
        out_dir: str | None = None, workers: int = 0, force: bool = False, scheduler=None,
        cluster_timeout: float = 60.0, progress: bool | None = None,
        on_outcome: Callable[[Outcome], None] | None = None) -> Report:
    """Lip-sync every line of ``manifest`` and write the outputs, each line
    with ``defaults`` (default: ``LineSettings.of()``) where it names no
    setting of its own (:func:`line_settings`).

    Up-to-date lines are skipped unless ``force``; ``scheduler`` (an address
    or a ``distributed.Client``) runs the lines on a Dask cluster (which
    must take them within ``cluster_timeout`` seconds), else ``workers``
    processes here (1: this process).  ``on_outcome`` is called
    with each line's outcome as it arrives."""
    defaults = defaults or LineSettings.of()
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
