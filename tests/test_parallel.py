"""Work run beside the alignment in a forked process."""

import os
import sys

import numpy as np
import pytest

from addon.engine import audio as audio_mod
from addon.engine import arousal, pipeline, prosody
from addon.engine.alignment.model import AlignSettings
from addon.engine.alignment.parallel import Background
from addon.engine.errors import AudioError

forks = pytest.mark.skipif(sys.platform in ("win32", "darwin") or (os.cpu_count() or 1) < 2,
                           reason="work runs in-process where fork is unavailable or unsafe")


@forks
def test_background_work_runs_in_another_process():
    assert Background(os.getpid, settings=AlignSettings(workers=2)).result() != os.getpid()


def test_one_worker_means_in_process():
    assert Background(os.getpid, settings=AlignSettings(workers=1)).result() == os.getpid()


def _fail(message):
    raise AudioError(message)


def test_an_error_in_background_work_surfaces_as_it_would_in_process():
    with pytest.raises(AudioError, match="clip.wav: broken"):
        Background(_fail, "clip.wav: broken", settings=AlignSettings(workers=2)).result()


def test_voice_measured_in_the_background_equals_voice_measured_in_process(fixtures):
    snd = audio_mod.load(fixtures / "bob_map.wav")
    (here, here_fr), (there, there_fr) = [
        Background(pipeline.measure_voice, snd, settings=AlignSettings(workers=w)).result() for w in (1, 2)]
    assert np.array_equal(here.times, there.times)
    assert np.array_equal(here.pitch, there.pitch, equal_nan=True)
    assert np.array_equal(here.intensity, there.intensity)
    assert np.array_equal(here_fr.centroid, there_fr.centroid, equal_nan=True)
    plain = arousal.estimate(snd, prosody.analyse(snd))
    assert arousal.estimate(snd, there, measured=there_fr).value == plain.value


def test_clips_between_split_and_stream_lengths_get_voice_beside_alignment():
    snd = audio_mod.Audio(np.zeros(16000 * 12, np.float32), 16000)
    settings = AlignSettings(workers=2)
    job = pipeline._voice_beside_alignment(snd, settings, {})
    assert job is not None
    job.close()
    short = audio_mod.Audio(np.zeros(16000 * 5, np.float32), 16000)
    assert pipeline._voice_beside_alignment(short, settings, {}) is None
