"""Generate and Learn Preset run from the panel: the engine in a background
thread, the keys written on the main thread, Esc to cancel.

Headless ``bpy`` opens no window, so nothing sends a modal operator events;
these tests drive the job (:mod:`.blender.jobs`) the operator drives, and
the operator's own modal code with a stand-in for the window manager and the
workspace, feeding it the timer and Esc events Blender would.
"""

from __future__ import annotations

import os
import sys
import time
import wave
from dataclasses import replace
from importlib import import_module
from types import SimpleNamespace

import bpy
import numpy as np
import pytest

from conftest import FIXTURES, MODULE, SAMPLE, add_strip, fcurve_values, keyed_shape_keys

PIE = os.path.join(FIXTURES, "fast_bilabials.wav")
BOB = os.path.join(FIXTURES, "bob_map.wav")


def _mod(name):
    return import_module(f"{MODULE}.blender.{name}")


@pytest.fixture
def jobs(scene):
    mod = _mod("jobs")
    yield mod
    mod.cancel_all()  # a failed test leaves no job running for the next one


def _text(name, path):
    block = bpy.data.texts.new(name)
    with open(os.path.splitext(path)[0] + ".txt", encoding="utf-8") as fh:
        block.from_string(fh.read())
    return block


def _inputs(scene, mesh="Ada", path=PIE):
    """A strip, its transcript in the panel, and what Generate reads from
    them: (the line's inputs, the options)."""
    strip = add_strip(scene, "line", path, frame=1)
    block = _text("line", path)
    scene.emotive_lipsync.text_block = block
    inputs = _mod("sources").line_inputs(scene, strip=strip, target=bpy.data.objects[mesh], text_block=block,
                                         strip_properties=False)
    return inputs, _mod("run").options(scene)


def _curves(obj):
    return {k: fcurve_values(obj, k) for k in keyed_shape_keys(obj)}


def _nothing_keyed(obj):
    key = obj.data.shape_keys
    return not keyed_shape_keys(obj) and (key.animation_data is None or key.animation_data.action is None)


def _started(job, timeout=30.0):
    """Wait until the work has reported progress at least once."""
    t0 = time.perf_counter()
    while job.step == "starting":
        assert time.perf_counter() - t0 < timeout, "the job never reported progress"
        time.sleep(0.005)
    return job


# --- the job ----------------------------------------------------------------------

def test_job_writes_the_same_keys_as_the_synchronous_path(scene, jobs):
    inputs, options = _inputs(scene)
    assert len(inputs.target.emotive_lipsync.mapping) == 0  # mapped by the job, as Generate does
    job = jobs.lipsync_job(scene, inputs, options).start()
    t0 = time.perf_counter()
    while job.working:
        assert time.perf_counter() - t0 < 120
        time.sleep(0.01)
    assert _nothing_keyed(bpy.data.objects["Ada"])  # the thread wrote nothing: keys wait for the main thread
    outcome = job.poll()
    assert outcome.finished and outcome.level == "INFO"
    assert outcome.message.startswith("Lip sync 'line' -> Ada: ")
    assert job.fraction == 1.0
    ada = bpy.data.objects["Ada"]
    threaded = _curves(ada)
    assert threaded and set(threaded) == {k for mix in ada.emotive_lipsync.mapping_dict().values() for k in mix}

    assert bpy.ops.emotive_lipsync.clear(mesh="Ada") == {"FINISHED"}
    assert not keyed_shape_keys(ada)
    assert bpy.ops.emotive_lipsync.generate("EXEC_DEFAULT", mesh="Ada") == {"FINISHED"}
    synchronous = _curves(ada)
    assert set(synchronous) == set(threaded)
    for name, (frames, values) in synchronous.items():
        assert np.array_equal(frames, threaded[name][0]), name
        assert np.array_equal(values, threaded[name][1]), name
    jobs.ensure_free(jobs.GENERATE)  # the finished job no longer holds the slot


def test_cancel_raises_from_the_progress_callback_and_stops_the_work(jobs):
    calls, finished = [], []

    def work(progress):
        for i in range(500):
            progress("count", i / 500)
            calls.append(i)
            time.sleep(0.002)
        return "all done"

    job = jobs.Job("test", "Counting", work, lambda result: finished.append(result) or ("INFO", "done")).start()
    while job.frac < 0.05:
        time.sleep(0.002)
    job.cancel()
    outcome = job.poll()  # at once, without waiting for the thread
    assert outcome.state == "cancelled" and outcome.level == "WARNING"
    assert outcome.message == "Counting: cancelled, nothing was written"
    job.wait(10)
    assert not job.working
    assert 0 < len(calls) < 500  # the next progress call raised
    assert finished == []
    assert job.poll() is outcome  # reported once, the same every time asked


def test_cancelled_generate_writes_nothing_and_puts_the_mapping_back(scene, jobs):
    inputs, options = _inputs(scene)
    before = jobs.snapshot(inputs.target.emotive_lipsync)
    job = _started(jobs.lipsync_job(scene, inputs, options).start())
    assert len(bpy.data.objects["Ada"].emotive_lipsync.mapping)  # filled in when the job was made
    job.cancel()
    outcome = job.poll()
    assert outcome.state == "cancelled" and "cancelled, nothing was written" in outcome.message
    job.wait(120)
    assert not job.working
    ada = bpy.data.objects["Ada"]
    assert _nothing_keyed(ada)
    assert jobs.snapshot(ada.emotive_lipsync) == before
    assert len(bpy.data.actions) == 0
    # Another run can start at once.
    again = jobs.lipsync_job(scene, inputs, options).start()
    assert again.wait(120).finished and keyed_shape_keys(ada)


def test_errors_in_the_thread_are_reported_as_the_panel_reports_them(scene, jobs, tmp_path, capsys):
    def broken(_progress):
        raise ValueError("bad numbers")

    outcome = jobs.Job("test", "Counting", broken, lambda r: ("INFO", "")).start().wait(10)
    assert outcome.state == "failed" and outcome.level == "ERROR"
    assert outcome.message == ("Counting failed unexpectedly (ValueError: bad numbers); "
                               "the console has the details")
    assert "Traceback" in capsys.readouterr().err  # for the console, not for the report

    silent = str(tmp_path / "silence.wav")
    with wave.open(silent, "wb") as fh:
        fh.setnchannels(1)
        fh.setsampwidth(2)
        fh.setframerate(16000)
        fh.writeframes(np.zeros(32000, dtype=np.int16).tobytes())
    inputs, options = _inputs(scene, path=PIE)
    inputs = replace(inputs, clip=_mod("sources").file_clip(silent, 1))
    before = jobs.snapshot(inputs.target.emotive_lipsync)
    outcome = jobs.lipsync_job(scene, inputs, options).start().wait(120)
    assert outcome.state == "failed" and outcome.level == "ERROR"
    assert outcome.message.startswith("the audio holds no speech")
    ada = bpy.data.objects["Ada"]
    assert _nothing_keyed(ada)
    assert jobs.snapshot(ada.emotive_lipsync) == before
    jobs.ensure_free(jobs.GENERATE)


def test_a_second_generate_is_refused_while_one_runs(scene, jobs, operator):
    inputs, options = _inputs(scene)
    first = jobs.lipsync_job(scene, inputs, options).start()
    with pytest.raises(jobs.Busy, match=r"^Lip sync 'line' -> Ada is still running: wait for it to finish, "
                                        r"or press Esc to cancel it$"):
        jobs.lipsync_job(scene, replace(inputs, target=bpy.data.objects["Kit"]), options)
    assert _nothing_keyed(bpy.data.objects["Kit"])
    # The operator says so and does not start.
    window = _Window()
    waiting = jobs.Job(jobs.GENERATE, "Another", lambda p: None, lambda r: ("INFO", ""))
    assert operator.run_modal(window.context, waiting) == {"CANCELLED"}
    assert operator.reports == [({"ERROR"}, "Lip sync 'line' -> Ada is still running: wait for it to finish, "
                                      "or press Esc to cancel it")]
    assert window.calls == []
    # Learning is another kind of job: it may run meanwhile.
    jobs.Job(jobs.LEARN, "Learning", lambda p: None, lambda r: ("INFO", "")).start().wait(10)
    assert first.wait(120).finished
    jobs.ensure_free(jobs.GENERATE)


def test_mesh_deleted_while_running_is_reported_and_nothing_written(scene, jobs):
    inputs, options = _inputs(scene)
    job = jobs.lipsync_job(scene, inputs, options).start()
    bpy.data.objects.remove(bpy.data.objects["Ada"])
    outcome = job.wait(120)
    assert outcome.state == "failed" and outcome.level == "ERROR"
    assert outcome.message == ("mesh 'Ada' was deleted or renamed while its lip sync 'line' -> Ada was being "
                               "made; nothing was keyed")
    assert len(bpy.data.actions) == 0


def test_scene_deleted_while_running_is_reported_and_nothing_written(scene, jobs):
    inputs, options = _inputs(scene)
    bpy.data.scenes.new("Other")
    job = jobs.lipsync_job(scene, inputs, options).start()
    name = scene.name
    bpy.data.scenes.remove(scene)
    outcome = job.wait(120)
    assert outcome.state == "failed"
    assert outcome.message == (f"scene {name!r} was deleted while its lip sync 'line' -> Ada was being made; "
                               "nothing was keyed")
    assert _nothing_keyed(bpy.data.objects["Ada"])
    assert len(bpy.data.actions) == 0


def test_mesh_losing_its_shape_keys_while_running_writes_nothing(scene, jobs):
    inputs, options = _inputs(scene)
    job = jobs.lipsync_job(scene, inputs, options).start()
    ada = bpy.data.objects["Ada"]
    ada.shape_key_remove(ada.data.shape_keys.key_blocks["MBP"])
    outcome = job.wait(120)
    assert outcome.state == "failed"
    assert outcome.message == "mesh 'Ada' no longer has shape key 'MBP'; nothing was keyed"
    assert _nothing_keyed(ada)


def test_keys_from_a_job_are_one_undo_step(scene, jobs):
    assert "UNDO" in _mod("operators").LIPSYNC_OT_generate.bl_options
    inputs, options = _inputs(scene)
    bpy.ops.ed.undo_push(message="before lip sync")
    assert jobs.lipsync_job(scene, inputs, options).start().wait(120).finished
    keyed = _curves(bpy.data.objects["Ada"])
    # What Blender does when the modal operator returns FINISHED (it has UNDO).
    bpy.ops.ed.undo_push(message=_mod("operators").LIPSYNC_OT_generate.bl_label)
    bpy.ops.ed.undo()
    ada = bpy.data.objects["Ada"]  # references do not survive an undo
    assert _nothing_keyed(ada) and len(ada.emotive_lipsync.mapping) == 0
    bpy.ops.ed.redo()
    again = _curves(bpy.data.objects["Ada"])
    assert set(again) == set(keyed)
    assert all(np.array_equal(again[k][1], keyed[k][1]) for k in keyed)


# --- the operator -----------------------------------------------------------------

class _Window:
    """Stands in for the window manager and the workspace."""

    def __init__(self):
        self.calls, self.progress, self.status = [], [], []
        self.context = SimpleNamespace(window_manager=self, workspace=self, window=None)

    def event_timer_add(self, step, window=None):
        self.calls.append("timer_add")
        return "timer"

    def event_timer_remove(self, timer):
        assert timer == "timer"
        self.calls.append("timer_remove")

    def modal_handler_add(self, op):
        self.calls.append("handler_add")
        return True

    def progress_begin(self, lo, hi):
        self.calls.append("progress_begin")

    def progress_update(self, value):
        self.progress.append(value)

    def progress_end(self):
        self.calls.append("progress_end")

    def status_text_set(self, text):
        self.status.append(text)


class _Operator:
    """A modal operator with Blender's report(), the mixin's code unchanged."""

    def __init__(self):
        self.reports = []

    def report(self, level, message):
        self.reports.append((set(level), message))


def _event(kind, value="NOTHING"):
    return SimpleNamespace(type=kind, value=value)


@pytest.fixture
def operator(jobs):
    cls = type("ModalGenerate", (jobs.ModalJob, _Operator), {})
    return cls()


def test_modal_operator_shows_progress_and_finishes_with_the_keys(scene, jobs, operator):
    window = _Window()
    inputs, options = _inputs(scene)
    job = jobs.lipsync_job(scene, inputs, options)
    assert operator.run_modal(window.context, job) == {"RUNNING_MODAL"}
    assert window.calls == ["timer_add", "progress_begin", "handler_add"]
    assert operator.modal(window.context, _event("MOUSEMOVE")) == {"PASS_THROUGH"}  # Blender stays usable
    t0 = time.perf_counter()
    while (result := operator.modal(window.context, _event("TIMER"))) == {"PASS_THROUGH"}:  # running
        assert time.perf_counter() - t0 < 120
        time.sleep(0.02)
    assert result == {"FINISHED"}
    running = window.status[:-1]
    assert running and all(s.startswith("Lip sync 'line' -> Ada: ") and s.endswith("Esc to cancel")
                           for s in running)
    assert window.status[-1] is None  # the status bar is cleared
    assert window.progress == sorted(window.progress) and 0 <= window.progress[0] <= window.progress[-1] <= 1000
    assert window.calls[-2:] == ["timer_remove", "progress_end"]
    [(level, message)] = operator.reports
    assert level == {"INFO"} and message.startswith("Lip sync 'line' -> Ada: ")
    assert keyed_shape_keys(bpy.data.objects["Ada"])


def test_esc_cancels_the_modal_operator(scene, jobs, operator):
    window = _Window()
    inputs, options = _inputs(scene)
    job = jobs.lipsync_job(scene, inputs, options)
    assert operator.run_modal(window.context, job) == {"RUNNING_MODAL"}
    assert operator.modal(window.context, _event("ESC", "RELEASE")) == {"PASS_THROUGH"}
    assert operator.modal(window.context, _event("ESC", "PRESS")) == {"CANCELLED"}
    assert operator.reports == [({"WARNING"}, "Lip sync 'line' -> Ada: cancelled, nothing was written")]
    assert window.status[-1] is None and window.calls[-2:] == ["timer_remove", "progress_end"]
    job.wait(120)
    assert _nothing_keyed(bpy.data.objects["Ada"])
    assert len(bpy.data.objects["Ada"].emotive_lipsync.mapping) == 0
    jobs.ensure_free(jobs.GENERATE)


def test_operator_dropped_by_blender_cancels_its_job(scene, jobs, operator):
    window = _Window()
    inputs, options = _inputs(scene)
    job = jobs.lipsync_job(scene, inputs, options)
    operator.run_modal(window.context, job)
    operator.cancel(window.context)  # Blender opens another file
    assert job.poll().state == "cancelled" and window.status[-1] is None
    job.wait(120)
    assert _nothing_keyed(bpy.data.objects["Ada"])


def test_invoke_without_a_window_runs_synchronously(scene, jobs):
    _inputs(scene)
    assert bpy.app.background
    for cls in (_mod("operators").LIPSYNC_OT_generate, _mod("learning").LIPSYNC_OT_learn_preset):
        ran = []
        stand_in = SimpleNamespace(execute=lambda context, ran=ran: ran.append(context) or {"FINISHED"})
        assert cls.invoke(stand_in, bpy.context, _event("LEFTMOUSE", "PRESS")) == {"FINISHED"}
        assert ran == [bpy.context]
    assert bpy.ops.emotive_lipsync.generate("INVOKE_DEFAULT", mesh="Ada") == {"FINISHED"}
    assert keyed_shape_keys(bpy.data.objects["Ada"])  # written before the call returned
    jobs.ensure_free(jobs.GENERATE)
    with pytest.raises(RuntimeError, match="audio file not found: .*bob_map.wav.missing"):
        bpy.ops.emotive_lipsync.generate("INVOKE_DEFAULT", mesh="Kit", filepath=BOB + ".missing")


# --- Learn Preset uses the same job -----------------------------------------------

def test_learn_preset_job_saves_only_when_it_finishes(scene, jobs):
    # Kit's lines keyed with the angry preset stand in for hand-keyed ones
    # (each transcript is the .txt beside its audio).
    for name, path, frame in (("Kit_a", BOB, 1), ("Kit_b", PIE, 80), ("Kit_c", SAMPLE, 160)):
        add_strip(scene, name, path, frame=frame)
        assert bpy.ops.emotive_lipsync.generate(strip=name, mesh="Kit", emotion="angry") == {"FINISHED"}
    learning = _mod("learning")
    kit = bpy.data.objects["Kit"]
    data = learning.collect(scene, kit, [])
    path = os.path.join(_mod("userdata").folder(create=True), "kit_job.json")

    cancelled = _started(learning.learn_job(scene, "arkit", data, "neutral", "kit_job", 0.34).start())
    cancelled.cancel()
    assert cancelled.poll().state == "cancelled"
    cancelled.wait(120)
    assert not os.path.exists(path) and scene.emotive_lipsync.emotion != "kit_job"

    job = learning.learn_job(scene, "arkit", data, "neutral", "kit_job", 0.34).start()
    seen = []
    while job.poll() is None:
        seen.append(job.fraction)
        time.sleep(0.01)
    outcome = job.poll()
    assert outcome.finished and outcome.message.startswith(
        "Learned preset 'kit_job' from 3 clips (leave-one-clip-out, 3 held out)")
    assert os.path.isfile(path) and scene.emotive_lipsync.emotion == "kit_job"
    assert seen == sorted(seen) and job.fraction == 1.0  # the steps add up to one bar


@pytest.mark.skipif((os.cpu_count() or 1) < 2 or os.name == "nt" or sys.platform == "darwin",
                    reason="lines are aligned in pieces on two cores only where processes can be forked")
def test_a_line_over_ten_seconds_is_aligned_in_pieces_from_the_jobs_thread(scene, jobs, tmp_path, monkeypatch):
    """A line of 10 to 90 s is cut into pieces aligned in forked processes
    while the voice is measured in another: from the job's background
    thread inside Blender too, with every word placed by the aligner."""
    said = "First part of the line. And the second part after a long pause."     # pause.wav, as said
    parts = [(os.path.join(FIXTURES, "pause.wav"), said), (BOB, None), (os.path.join(FIXTURES, "pause.wav"), said),
             (PIE, None)]
    frames, texts = [], []
    for path, text in parts:
        with wave.open(path, "rb") as w:
            rate = w.getframerate()
            frames.append(w.readframes(w.getnframes()) + b"\0\0" * int(0.4 * rate))
        if text is None:
            with open(os.path.splitext(path)[0] + ".txt", encoding="utf-8") as fh:
                text = fh.read().strip()
        texts.append(text)
    line = str(tmp_path / "long_line.wav")
    with wave.open(line, "wb") as w:
        w.setnchannels(1), w.setsampwidth(2), w.setframerate(rate)
        w.writeframes(b"".join(frames))
    with open(os.path.splitext(line)[0] + ".txt", "w", encoding="utf-8") as fh:
        fh.write(" ".join(texts))
    pieces = import_module(f"{MODULE}.engine.alignment.pieces")
    cuts = []
    choose = pieces._choose_cuts
    monkeypatch.setattr(pieces, "_choose_cuts", lambda *a: cuts.append(choose(*a)) or cuts[-1])
    inputs, options = _inputs(scene, path=line)
    clip = inputs.clip
    assert clip.audio.duration > 10.0
    outcome = jobs.lipsync_job(scene, inputs, options).start().wait(120)
    assert outcome is not None and outcome.finished, outcome
    assert len(cuts) == 1 and cuts[0], "the line was not cut into pieces"
    assert "estimated" not in outcome.message
    ada = bpy.data.objects["Ada"]
    keyed = _curves(ada)
    assert keyed
    # The keys reach the end of the line: the last piece was placed too.
    last = max(frames[-1] for frames, _ in keyed.values())
    assert last >= clip.first_frame + 0.9 * scene.render.fps * clip.audio.duration
