"""Long work that keeps Blender responsive: Generate and Learn Preset from
the panel.

A :class:`Job` is one run split in three: its inputs are read from Blender
on the main thread before it starts, ``work`` (the engine: aligning,
fitting; no Blender data) runs in a background thread, and ``finish``
writes the result on the main thread when :meth:`Job.poll` finds the
thread done.  Cancelling makes the work's progress callback raise
:class:`Cancelled`; a cancelled or failed job writes nothing and
``rollback`` puts back what reading its inputs changed.

:class:`ModalJob` is the operator side: ``invoke`` starts the job, a timer
polls it, the status bar and the window manager's progress show how far it
is, Esc cancels.  Blender records the undo step when the operator finishes.
Everything but the few window calls is in :class:`Job`, so it runs (and is
tested) without a window.  One job of a kind runs at a time.
"""

from __future__ import annotations

import threading
import time
import traceback
from dataclasses import dataclass
from typing import Any
from collections.abc import Callable

import bpy

from ..engine.errors import LipSyncError
from . import run, sources

GENERATE = "generate"
LEARN = "learn"
POLL_SECONDS = 0.1

_running: dict[str, Job] = {}


class Cancelled(Exception):
    """Raised from a job's progress callback once the job was cancelled."""


class Busy(LipSyncError):
    """A job of the same kind is already running."""


@dataclass(frozen=True)
class Outcome:
    """How a job ended, as the operator reports it."""

    state: str      # "finished", "cancelled" or "failed"
    level: str      # report level: INFO, WARNING or ERROR
    message: str

    @property
    def finished(self) -> bool:
        return self.state == "finished"


def ensure_free(kind: str) -> None:
    """Raise :class:`Busy` if a job of ``kind`` is running."""
    other = _running.get(kind)
    if other is not None:
        raise Busy(f"{other.label} is still running: wait for it to finish, or press Esc to cancel it")


def cancel_all() -> None:
    for job in list(_running.values()):
        job.cancel()
        job.poll()


class Job:
    """One run: ``work(progress)`` in a thread, then ``finish(result)`` on the
    main thread, returning ``(report level, message)``.

    ``progress(step, frac)`` is the engine's callback.  ``phases`` maps a
    step to (start, share) of the whole when each step counts its own
    fraction; without it, ``frac`` is the whole job's.
    """

    def __init__(self, kind: str, label: str, work: Callable[[Callable[[str, float], None]], Any],
                 finish: Callable[[Any], tuple[str, str]], rollback: Callable[[], None] | None = None,
                 phases: dict[str, tuple[float, float]] | None = None):
        self.kind, self.label = kind, label
        self._work, self._finish, self._rollback = work, finish, rollback
        self._phases = phases or {}
        self.step, self.frac = "starting", 0.0
        self._cancel = False
        self._result: Any = None
        self._error: Outcome | None = None
        self._outcome: Outcome | None = None
        self._thread: threading.Thread | None = None
        self._t0 = time.perf_counter()

    # --- the background thread -------------------------------------------------
    def progress(self, step: str, frac: float) -> None:
        if self._cancel:
            raise Cancelled
        self.step, self.frac = step, frac

    def _run_work(self) -> None:
        try:
            self._result = self._work(self.progress)
        except Cancelled:
            pass
        except Exception as exc:  # noqa: BLE001 - reported, never lost in a thread
            self._error = failure(self.label, exc)

    # --- the main thread -------------------------------------------------------
    def start(self) -> Job:
        ensure_free(self.kind)
        _running[self.kind] = self
        self._t0 = time.perf_counter()
        self._thread = threading.Thread(target=self._run_work, name=f"lipsync-{self.kind}", daemon=True)
        self._thread.start()
        return self

    def cancel(self) -> None:
        """Stop: the thread ends at its next progress call, its result unused."""
        self._cancel = True
        if _running.get(self.kind) is self:
            del _running[self.kind]

    @property
    def working(self) -> bool:
        """The thread is still running (it may be winding down after a cancel)."""
        return self._thread is not None and self._thread.is_alive()

    @property
    def fraction(self) -> float:
        start, share = self._phases.get(self.step, (0.0, 1.0))
        return min(1.0, max(0.0, start + share * self.frac))

    def status(self) -> str:
        """The status bar's text while the job runs."""
        return (f"{self.label}: {self.step} {100 * self.fraction:.0f} % "
                f"({time.perf_counter() - self._t0:.0f} s) - Esc to cancel")

    def poll(self) -> Outcome | None:
        """None while the work runs; then how the job ended, once the result
        is written (by ``finish``, here on the main thread)."""
        if self._outcome is None:
            if self._cancel:
                self._end(Outcome("cancelled", "WARNING", f"{self.label}: cancelled, nothing was written"))
            elif not self.working:
                self._end(self._error or self._finished(self._result))
        return self._outcome

    def wait(self, timeout: float | None = None) -> Outcome | None:
        """Block until the work is done, then :meth:`poll` (scripts and tests;
        the UI polls from a timer instead)."""
        if self._thread is not None:
            self._thread.join(timeout)
        return self.poll()

    def run(self) -> Outcome:
        """The whole job in the calling thread (a script's synchronous run)."""
        self._run_work()
        self._end(self._error or self._finished(self._result))
        return self._outcome

    def _finished(self, result) -> Outcome:
        try:
            level, message = self._finish(result)
        except Exception as exc:  # noqa: BLE001
            return failure(self.label, exc)
        return Outcome("finished", level, message)

    def _end(self, outcome: Outcome) -> None:
        if _running.get(self.kind) is self:
            del _running[self.kind]
        self._outcome = outcome
        if not outcome.finished and self._rollback is not None:
            try:
                self._rollback()
            except Exception:  # noqa: BLE001 - the outcome is still reported
                traceback.print_exc()


def failure(label: str, exc: Exception) -> Outcome:
    """An error as the user sees it: a :class:`LipSyncError`'s message, else
    a short line (the traceback goes to the console)."""
    if isinstance(exc, LipSyncError):
        return Outcome("failed", "ERROR", str(exc))
    traceback.print_exception(exc)
    return Outcome("failed", "ERROR", f"{label} failed unexpectedly ({type(exc).__name__}: {exc}); "
                                      "the console has the details")


class ModalJob:
    """Operator mixin: :meth:`run_modal` (from ``invoke``) starts a job and
    follows it while Blender stays usable; the job's outcome is the
    operator's report and result."""

    def run_modal(self, context, job: Job) -> set[str]:
        try:
            job.start()
        except Busy as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        wm = context.window_manager
        self._job = job
        self._timer = wm.event_timer_add(POLL_SECONDS, window=context.window)
        wm.progress_begin(0, 1000)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type == "ESC" and event.value == "PRESS":
            self._job.cancel()
        elif event.type != "TIMER":
            return {"PASS_THROUGH"}
        return self.follow(context)

    def cancel(self, context):
        """Blender drops the operator (a file is opened, Blender quits)."""
        self._job.cancel()
        self._job.poll()
        self._stop(context)

    def follow(self, context) -> set[str]:
        """One look at the job: show its progress, or end with its outcome."""
        outcome = self._job.poll()
        if outcome is None:
            context.window_manager.progress_update(int(1000 * self._job.fraction))
            context.workspace.status_text_set(self._job.status())
            return {"PASS_THROUGH"}  # still running; the timer event may be another operator's too
        self._stop(context)
        self.report({outcome.level}, outcome.message)
        return {"FINISHED"} if outcome.finished else {"CANCELLED"}

    def _stop(self, context) -> None:
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        if context.workspace is not None:
            context.workspace.status_text_set(None)


# --- settings put back when a job does not finish ---------------------------------

def snapshot(group) -> dict:
    """A property group's values (collections and nested groups included)."""
    out = {}
    for prop in group.bl_rna.properties:
        key = prop.identifier
        if key == "rna_type":
            continue
        value = getattr(group, key)
        if prop.type == "COLLECTION":
            out[key] = [snapshot(item) for item in value]
        elif prop.type == "POINTER" and isinstance(value, bpy.types.PropertyGroup):
            out[key] = snapshot(value)
        elif not prop.is_readonly:
            out[key] = tuple(value) if getattr(prop, "is_array", False) else value
    return out


def restore(group, values: dict) -> None:
    """Put back what :func:`snapshot` saw, where it changed."""
    for key, value in values.items():
        current = getattr(group, key)
        if isinstance(value, list):
            if [snapshot(item) for item in current] != value:
                current.clear()
                for item_values in value:
                    restore(current.add(), item_values)
        elif isinstance(value, dict):
            restore(current, value)
        elif (tuple(current) if isinstance(value, tuple) else current) != value:
            setattr(group, key, value)


# --- Generate's job ---------------------------------------------------------------

def lipsync_job(scene, line: sources.LineInputs, options: run.Options) -> Job:
    """Generate as a job: the mesh's mapping is read now, the engine runs in
    the thread, and the keys are written when the job is polled done, if
    the scene and the mesh are still there."""
    ensure_free(GENERATE)
    obj = line.target
    before = snapshot(obj.emotive_lipsync)
    plan = run.plan(scene, line, options)
    what = f"lip sync {line.clip.label!r} -> {obj.name}"

    def finish(analysis) -> tuple[str, str]:
        if bpy.data.scenes.get(plan.scene) is None:
            raise LipSyncError(f"scene {plan.scene!r} was deleted while its {what} was being made; "
                               "nothing was keyed")
        target = bpy.data.objects.get(plan.mesh)
        if target is None:
            raise LipSyncError(f"mesh {plan.mesh!r} was deleted or renamed while its {what} was being made; "
                               "nothing was keyed")
        return "INFO", run.key(target, plan, analysis).message()

    def rollback() -> None:
        target = bpy.data.objects.get(plan.mesh)
        if target is not None:
            restore(target.emotive_lipsync, before)

    return Job(GENERATE, what[0].upper() + what[1:], lambda progress: run.analyze(plan, progress), finish,
               rollback)
