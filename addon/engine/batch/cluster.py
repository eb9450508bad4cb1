"""Batch lines on a Dask distributed cluster whose machines have the packages
the engine uses but not the engine itself.

The scheduler and the workers need Python and numpy, praat-parselmouth,
pocketsphinx, dask and distributed at this machine's versions; they need
neither this repository nor a path setting.  This machine ships the engine:

* its files, zipped (about 170 kB), are the result of one task that every
  line's task takes as its argument, so each worker fetches them once from
  another worker, and the scheduler keeps them to compute them again if
  every worker that had them is lost;
* a worker unpacks them in its own scratch folder as a package named after
  their hash (two versions of the engine can share a worker) and imports it;
* the function the tasks run is made inside :func:`_task_functions`, so it is
  pickled by value: the scheduler, which unpickles the task graph, and the
  workers run it without importing this package; it finds the unpacked
  engine and calls :func:`worker_line` there;
* a line goes out as plain data (its fields), and comes back as the bytes of
  its JSON/CSV outputs, which this machine writes.

Before any line is sent, the scheduler's and workers' versions are compared
with this machine's, and every worker loads the engine and its models; a
worker that cannot, no worker at all, or a scheduler that does not answer
stops the batch with one :class:`LipSyncError` line within ``timeout``
seconds, before anything is written.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import sys
import threading
import time
import uuid
import zipfile
from dataclasses import asdict
from functools import lru_cache
from pathlib import Path
from collections.abc import Iterator

from ..errors import LipSyncError
from ..settings import LineSettings
from .lines import Line, Outcome
from .records import engine_version
from .work import one_core, one_line_error, warm, work

#: Distributions whose versions must match this machine's: the engine's (the
#: results must equal ``analyze``'s here) and Dask's (the task graph is pickled).
PACKAGES = ("numpy", "praat-parselmouth", "pocketsphinx", "dask", "distributed", "cloudpickle")
#: What the scheduler must match: it unpickles the task functions, but runs none.
SCHEDULER_PACKAGES = ("dask", "distributed", "cloudpickle")
#: What the engine imports from them (by module name).
MODULES = ("numpy", "parselmouth", "pocketsphinx")
DEFAULT_TIMEOUT = 60.0
VERSIONS_HINT = "; the cluster needs this machine's Python and package versions (see docs/cluster.md)"
_FROZEN_TIME = (2020, 1, 1, 0, 0, 0)   # zip entries' date: the same files give the same bytes


# ---------------------------------------------------------------------------
# versions

def environment() -> dict[str, str | None]:
    """Python's major.minor and the version of each of :data:`PACKAGES`
    installed here (None when missing)."""
    from importlib.metadata import PackageNotFoundError, version

    env: dict[str, str | None] = {"python": "{}.{}".format(*sys.version_info[:2])}
    for name in PACKAGES:
        try:
            env[name] = version(name)
        except PackageNotFoundError:
            env[name] = None
    return env


def differences(ours: dict, theirs: dict, names) -> str | None:
    """``theirs`` against ``ours`` as one phrase ("has pocketsphinx 5.0.0 where
    this machine has pocketsphinx 5.1.1"), or None when they agree on every
    name."""
    names = [n for n in names if theirs.get(n) != ours.get(n)]
    if not names:
        return None
    has = ", ".join(f"{n} {theirs.get(n) or '(missing)'}" for n in names)
    return f"has {has} where this machine has " + ", ".join(f"{n} {ours.get(n)}" for n in names)


def _package_versions(versions: dict) -> dict:
    """A ``distributed.versions.get_versions`` entry in :func:`environment`'s shape."""
    packages = dict((versions or {}).get("packages") or {})
    python = packages.get("python") or (versions or {}).get("host", {}).get("python") or ""
    packages["python"] = ".".join(str(python).split(".")[:2]) or None
    return packages


# ---------------------------------------------------------------------------
# the engine, shipped

@lru_cache(maxsize=1)
def bundle() -> tuple[str, bytes]:
    """(package name, zip) of the engine's files: its modules and data.  The
    name carries the files' hash, so a worker never mixes two versions."""
    root = Path(__file__).resolve().parent.parent     # the engine package
    files = sorted(p for p in root.rglob("*")
                   if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".pyc")
    digest = hashlib.sha256()
    contents = []
    for p in files:
        rel = p.relative_to(root).as_posix()
        data = p.read_bytes()
        digest.update(rel.encode() + b"\0" + len(data).to_bytes(8, "little") + data)
        contents.append((rel, data))
    name = "emotive_lipsync_engine_" + digest.hexdigest()[:16]
    contents.append(("VERSION", engine_version().encode("utf-8")))   # the release's, for the outputs' records
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        for rel, data in contents:
            zf.writestr(zipfile.ZipInfo(f"{name}/{rel}", _FROZEN_TIME), data, zipfile.ZIP_DEFLATED)
    return name, buf.getvalue()


def _task_functions():
    """The two functions the cluster runs, made here so that they are pickled
    by value and need nothing of this package to be unpickled: ``probe`` loads
    the engine on a worker; ``run_line`` lip-syncs one line with it."""

    def load(name, files):
        """The engine's package ``name``: unpacked (once per worker) from
        ``files`` into the worker's scratch folder and imported."""
        import importlib
        import os
        import shutil
        import sys
        import tempfile
        import zipfile
        from io import BytesIO

        if name not in sys.modules:
            try:
                from distributed import get_worker

                root = get_worker().local_directory
            except (ImportError, ValueError):
                root = tempfile.gettempdir()
            root = os.path.join(root, "emotive-lipsync")
            if not os.path.isdir(os.path.join(root, name)):
                os.makedirs(root, exist_ok=True)
                tmp = tempfile.mkdtemp(dir=root)
                try:
                    zipfile.ZipFile(BytesIO(files)).extractall(tmp)
                    try:
                        os.rename(os.path.join(tmp, name), os.path.join(root, name))
                    except OSError:
                        if not os.path.isdir(os.path.join(root, name)):
                            raise
                        # another thread of this worker unpacked it first
                finally:
                    shutil.rmtree(tmp, ignore_errors=True)
            if root not in sys.path:
                sys.path.append(root)
            importlib.invalidate_caches()
        return importlib.import_module(name + ".batch.cluster")

    def problem(exc):
        msg = " ".join(str(exc).split())
        if not (msg and isinstance(exc, ImportError)):
            msg = f"{type(exc).__name__}: {msg}" if msg else type(exc).__name__
        return {"problem": f"cannot load the lip-sync engine: {msg}"}

    def here():
        from distributed import get_worker

        return get_worker().address

    def probe(name, files, expected, dictionary):
        try:
            return {"problem": load(name, files).worker_check(expected, dictionary)}
        except Exception as exc:  # noqa: BLE001 - a worker that cannot load the engine is reported, not raised
            return problem(exc)

    def run_line(line, name, files, expected, defaults):
        try:
            out = load(name, files).worker_line(line, defaults, expected)
        except Exception as exc:  # noqa: BLE001 - a worker that cannot load the engine is reported, not raised
            out = problem(exc)
        if out.get("problem"):
            out["worker"] = here()
        return out

    return probe, run_line


# ---------------------------------------------------------------------------
# on a worker (in the unpacked copy of this module)

_checked: dict[tuple, str | None] = {}
_check_lock = threading.Lock()


def worker_check(expected: dict, dictionary: str | None) -> str | None:
    """Once per worker process: why this worker cannot run lines like the
    client's (other versions, a module that does not import), or None after
    loading the models."""
    key = (tuple(sorted(expected.items())), dictionary)
    with _check_lock:
        if key not in _checked:
            _checked[key] = _check(expected, dictionary)
        return _checked[key]


def _check(expected: dict, dictionary: str | None) -> str | None:
    import importlib

    diff = differences(expected, environment(), ["python", *PACKAGES])
    if diff:
        return diff + VERSIONS_HINT
    try:
        for module in MODULES:
            importlib.import_module(module)
        one_core()
        warm(dictionary)
    except ImportError as exc:   # what the worker's environment lacks
        return f"cannot load the lip-sync engine: {exc}"
    except Exception as exc:  # noqa: BLE001 - any other failure to load, said in one line
        return f"cannot load the lip-sync engine: {one_line_error(exc)}"
    return None


def worker_line(line: dict, defaults: dict, expected: dict) -> dict:
    """Lip-sync one line (its :class:`~.lines.Line` fields) here, with the
    run's settings (:meth:`.settings.LineSettings.to_dict`); returns plain
    data: status, error, seconds and each output's bytes, or ``problem``
    when this worker cannot run lines at all."""
    import tempfile

    why = worker_check(expected, defaults.get("dictionary"))
    if why:
        return {"problem": why}
    ln = Line(**line)
    out = work(ln, LineSettings.from_dict(defaults))
    rendered = {}
    if out.status == "ok":
        if "json" in ln.outputs:
            rendered["json"] = json.dumps(out.result.to_dict(), separators=(",", ":")).encode("utf-8")
        if "csv" in ln.outputs:
            with tempfile.TemporaryDirectory(prefix="lipsync-") as tmp:
                path = os.path.join(tmp, "out.csv")
                out.result.write_csv(path)
                rendered["csv"] = Path(path).read_bytes()
    return {"status": out.status, "error": out.error, "seconds": out.seconds, "outputs": rendered,
            "record": out.record, "beyond": out.beyond}


# ---------------------------------------------------------------------------
# on this machine

class Rendered:
    """A line's outputs as a worker made them, standing in for the Result
    when this machine writes them (:func:`.work.write_outputs`)."""

    def __init__(self, outputs: dict[str, bytes]):
        self.outputs = outputs

    def to_dict(self) -> dict:
        return json.loads(self.outputs["json"])

    def write_json(self, path) -> None:
        Path(path).write_bytes(self.outputs["json"])

    def write_csv(self, path) -> None:
        Path(path).write_bytes(self.outputs["csv"])


class _Quiet:
    """Silences distributed's and tornado's logging and Python warnings while
    this process owns the client: what goes wrong is said once, by the batch."""

    PREFIXES = ("distributed", "tornado", "asyncio", "bokeh")

    def __enter__(self):
        import logging
        import warnings

        self._warnings = warnings.catch_warnings()
        self._warnings.__enter__()
        warnings.simplefilter("ignore")
        names = [n for n in list(logging.root.manager.loggerDict) if n.split(".")[0] in self.PREFIXES]
        self._levels = {}
        for name in set(names) | set(self.PREFIXES):
            logger = logging.getLogger(name)
            self._levels[name] = logger.level
            logger.setLevel(logging.CRITICAL + 1)
        return self

    def __exit__(self, *exc):
        import logging

        for name, level in self._levels.items():
            logging.getLogger(name).setLevel(level)
        self._warnings.__exit__(*exc)


def _within(seconds: float, what: str, fn, *args, **kwargs):
    """``fn(*args, **kwargs)`` in a daemon thread, raising LipSyncError(``what``)
    when it has not returned after ``seconds`` (the thread cannot keep this
    process from exiting)."""
    box: dict = {}

    def call():
        try:
            box["value"] = fn(*args, **kwargs)
        except BaseException as exc:  # noqa: BLE001 - handed to the caller's thread
            box["error"] = exc

    t = threading.Thread(target=call, daemon=True)
    t.start()
    t.join(max(0.0, seconds))
    if t.is_alive():
        raise LipSyncError(what)
    if "error" in box:
        raise box["error"]
    return box["value"]


def _one_line(exc: BaseException) -> str:
    return one_line_error(exc)


def run_dask(lines, defaults, scheduler, timeout: float = DEFAULT_TIMEOUT) -> Iterator:
    """The lines on a Dask distributed cluster (``scheduler``: its address,
    or a ``distributed.Client``); yields one :class:`~.lines.Outcome` per
    line as lines finish, each ``ok`` one carrying a :class:`Rendered`.

    The input files must be at the same paths on the workers (a shared file
    system).  Dask reruns the lines of a worker that is lost (up to its
    ``distributed.scheduler.allowed-failures``).  Raises LipSyncError, in one
    line and within ``timeout`` seconds, when the cluster cannot run the
    lines: the scheduler does not answer, no worker joins, versions differ,
    or a worker cannot load the engine (one that joins later stops the batch
    when its first line comes back; the lines finished so far are kept)."""
    try:
        from distributed import Client
    except ImportError:
        raise LipSyncError("--scheduler needs Dask distributed: pip install distributed") from None

    own = not isinstance(scheduler, Client)
    quiet = _Quiet() if own else None
    client = None
    if quiet is not None:
        quiet.__enter__()
    try:
        deadline = time.monotonic() + timeout
        if own:
            try:
                client = Client(scheduler, timeout=timeout, set_as_default=False)
            except Exception as exc:  # noqa: BLE001 - any failure to connect, said in one line
                raise LipSyncError(f"cannot reach the Dask scheduler at {scheduler}: {_one_line(exc)}") from None
        else:
            client = scheduler
        address = client.scheduler.address
        try:
            yield from _run(client, address, lines, defaults, deadline, timeout)
        except LipSyncError:
            raise
        except Exception as exc:  # noqa: BLE001 - what the cluster did, said in one line
            raise LipSyncError(f"the Dask cluster at {address} failed: {_one_line(exc)}") from None
    finally:
        if own and client is not None:
            try:
                client.close(timeout=min(10.0, timeout))
            except Exception:  # noqa: BLE001 - closing a client whose scheduler is gone
                pass
        if quiet is not None:
            quiet.__exit__(None, None, None)


def _run(client, address, lines, defaults, deadline, timeout) -> Iterator:
    from distributed import as_completed

    def left() -> float:
        return max(0.0, deadline - time.monotonic())

    def versions() -> dict:
        return _within(left(), f"the Dask scheduler at {address} did not report its and its workers' versions "
                               f"within {timeout:g} s", client.get_versions, packages=list(PACKAGES))

    here = environment()
    diff = differences(here, _package_versions(versions().get("scheduler")), ["python", *SCHEDULER_PACKAGES])
    if diff:
        raise LipSyncError(f"the Dask scheduler at {address} {diff}{VERSIONS_HINT}")
    try:
        client.wait_for_workers(1, timeout=left())
    except Exception:  # noqa: BLE001 - distributed's timeouts come in several types
        raise LipSyncError(f"no Dask worker joined the scheduler at {address} within {timeout:g} s") from None
    for worker, info in sorted((versions().get("workers") or {}).items()):
        if isinstance(info, dict) and "packages" in info:
            diff = differences(here, _package_versions(info), ["python", *PACKAGES])
            if diff:
                raise LipSyncError(f"the Dask worker {worker} {diff}{VERSIONS_HINT}")

    name, zipped = bundle()
    probe, run_line = _task_functions()
    token = uuid.uuid4().hex[:12]
    # A task that returns the zip, rather than scattered data: the scheduler
    # keeps it and recomputes it if every worker holding it is lost.
    files = client.submit(bytes, zipped, key=f"lipsync-engine-{token}", pure=False, priority=1000)
    probes = {}
    for worker in sorted(client.scheduler_info(n_workers=-1)["workers"]):
        probes[client.submit(probe, name, files, here, defaults.dictionary, workers=[worker],
                             allow_other_workers=False, pure=False, priority=1000,
                             key=f"lipsync-probe-{token}-{worker}")] = worker

    pending_probes = _wait_for_probes(probes, address, left, timeout)

    futures = client.map(run_line, [asdict(ln) for ln in lines], name=name, files=files, expected=here,
                         defaults=defaults.to_dict(), key=[f"lipsync-line-{token}-{ln.number}" for ln in lines],
                         pure=False)
    by_key = {fut.key: ln for fut, ln in zip(futures, lines)}
    finished = as_completed(futures, loop=client.loop, with_results=True, raise_errors=False)
    del futures
    watch = _Watch(client, address, timeout)
    while not finished.is_empty():
        for fut in [f for f in pending_probes if f.done()]:
            _probe_answer(fut, pending_probes.pop(fut), len(by_key))
        if not finished.has_ready():
            watch.idle(len(by_key))
            time.sleep(0.02)
            continue
        fut, res = next(finished)
        ln = by_key.pop(fut.key)
        watch.progress()
        # A line's answer is the dict run_line returned, even when the worker that
        # held it has gone since (the future then no longer reads "finished").
        if not isinstance(res, dict):   # KilledWorker (the line took down every worker it ran on), cancelled
            exc = res[1] if isinstance(res, tuple) else res
            if client.status != "running":
                raise LipSyncError(f"lost the Dask scheduler at {address}; {_not_done(len(by_key) + 1)}")
            yield Outcome(ln.number, ln.label(), "failed", error=f"lost on the cluster: {_one_line(exc)}")
        elif res.get("problem"):
            raise LipSyncError(f"the Dask worker {res.get('worker')} {res['problem']}; {_not_done(len(by_key) + 1)}")
        else:
            yield Outcome(ln.number, ln.label(), res["status"], error=res["error"], seconds=res["seconds"],
                          result=Rendered(res["outputs"]) if res["status"] == "ok" else None,
                          record=res.get("record"), beyond=res.get("beyond", ""))
        del fut, res


def _not_done(n: int) -> str:
    return f"{n} line{'s' if n != 1 else ''} not done (the finished ones are kept; run again to do the rest)"


def _probe_answer(fut, worker: str, todo: int = 0) -> bool:
    """Whether a worker's probe passed (False: it did not run, e.g. the
    worker left); raises LipSyncError when the worker cannot run lines."""
    rest = f"; {_not_done(todo)}" if todo else ""
    if fut.status == "error":
        raise LipSyncError(f"the Dask worker {worker} cannot run this machine's tasks: "
                           f"{_one_line(fut.exception())}{rest}")
    if fut.status != "finished":
        return False
    why = fut.result().get("problem")
    if why:
        raise LipSyncError(f"the Dask worker {worker} {why}{rest}")
    return True


def _wait_for_probes(probes: dict, address: str, left, timeout: float) -> dict:
    """Wait for every worker's probe, or until the deadline if at least one
    passed; returns the probes still running (busy workers), to be checked
    as the lines run."""
    pending, passed = dict(probes), 0
    while pending:
        for fut in [f for f in pending if f.done()]:
            passed += _probe_answer(fut, pending.pop(fut))
        if pending and left() <= 0:
            if passed:
                break
            raise LipSyncError(f"no Dask worker of {address} loaded the lip-sync engine within {timeout:g} s")
        time.sleep(0.02)
    if not passed:
        raise LipSyncError(f"no Dask worker of {address} could load the lip-sync engine")
    return pending


class _Watch:
    """Stops a run whose cluster has had no worker, or whose scheduler has
    not answered, for ``timeout`` seconds."""

    EVERY = 2.0

    def __init__(self, client, address: str, timeout: float):
        self.client, self.address, self.timeout = client, address, timeout
        self.trouble_since: float | None = None
        self.next_check = time.monotonic() + self.EVERY

    def progress(self) -> None:
        self.trouble_since = None

    def idle(self, todo: int) -> None:
        now = time.monotonic()
        if now < self.next_check:
            return
        self.next_check = now + self.EVERY
        try:
            if self.client.status != "running":
                raise ConnectionError(self.client.status)
            info = _within(min(10.0, self.timeout), "no answer", self.client.scheduler_info, n_workers=0)
            trouble = None if info.get("n_workers") else "has had no workers"
        except Exception:  # noqa: BLE001 - a scheduler that does not answer, whatever the error
            trouble = "has not answered"
        if trouble is None:
            self.trouble_since = None
            return
        if self.trouble_since is None:
            self.trouble_since = now
        elif now - self.trouble_since >= self.timeout:
            raise LipSyncError(f"the Dask scheduler at {self.address} {trouble} for {self.timeout:g} s; "
                               f"{_not_done(todo)}")
