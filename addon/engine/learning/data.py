"""Training data: clips with audio, phoneme timings and measured tracks,
and their preparation for the fit (resampled tracks, viseme events and
targets from the engine's own weights)."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import audio as audio_mod
from .. import coarticulation, pauses, prosody
from ..alignment import Alignment, align_audio
from ..audio import Audio
from ..errors import LipSyncError
from ..framerate import frame_times
from ..importers import read_alignment
from ..language import CLASSES, Lexicon, read_text_file
from ..presets import Preset, as_preset
from ..render import phoneme_weights, rest_target
from .capture import read_capture_csv, read_head_csv, read_track_csv


@dataclass
class TrainingClip:
    """One example: audio, phoneme timings and measured tracks."""

    name: str
    audio: Audio
    alignment: Alignment
    times: np.ndarray            # track sample times, s from the audio's start
    tracks: np.ndarray           # (samples, channels)
    channels: list[str]
    #: The head's rotation on ``times`` (samples, 3: pitch, yaw, roll, degrees), where the capture has it.
    head: np.ndarray | None = None

    def __post_init__(self):
        if self.tracks.ndim != 2 or self.tracks.shape[0] != len(self.times):
            raise LipSyncError(f"{self.name}: {len(self.times)} times but {self.tracks.shape[0]} rows of tracks")
        if self.tracks.shape[1] != len(self.channels):
            raise LipSyncError(f"{self.name}: {self.tracks.shape[1]} track columns but {len(self.channels)} names")
        cover = self.times[-1] - self.times[0]
        if abs(cover - self.audio.duration) > max(0.5, 0.1 * self.audio.duration):
            raise LipSyncError(f"{self.name}: the tracks cover {cover:.2f} s but the audio lasts "
                               f"{self.audio.duration:.2f} s; do they belong together?")


@dataclass
class Prepared:
    name: str
    times: np.ndarray            # model frames
    y: np.ndarray                # (frames, channels) measured, resampled
    centres: np.ndarray
    half: np.ndarray
    cls: np.ndarray              # class index per segment
    targets: np.ndarray          # (segments, visemes) w_i e_{v_i}
    alignment: Alignment = None
    pitch: np.ndarray = None
    intensity: np.ndarray = None
    stats: object = None
    raw_t: np.ndarray = None     # the measured tracks as given (channels in fit order)
    raw_y: np.ndarray = None
    closure: np.ndarray = None   # (frames,) True inside /p b m/
    closures: list = None        # the engine's closure step: coarticulation.closure_steps
    rest: np.ndarray = None      # (frames,) 0 where a pause forces the rest pose (pauses.rest_envelope)
    caps: dict = None            # closure viseme -> (vowel frames, most it may show): closure_caps
    duration: float = None       # s, the span the model frames cover

    def aligned(self, delay: float) -> np.ndarray:
        """The measured tracks on the model frames, read ``delay`` s later
        (a capture that lags the sound by ``delay``)."""
        y = np.empty((len(self.times), self.raw_y.shape[1]))
        for j in range(y.shape[1]):
            y[:, j] = np.interp(self.times + delay, self.raw_t, self.raw_y[:, j])
        return y


def prepare(clip: TrainingClip, vset, preset: Preset | dict, fps: float, channels: list[str]) -> Prepared:
    preset = as_preset(preset)
    snd, al = clip.audio, clip.alignment
    tracks = prosody.analyse(snd)
    stats, pitch, inten = prosody.for_preset(tracks, [(p.start, p.end) for p in al.phones], preset.weights)
    w = phoneme_weights(al, pitch, inten, stats, vset, preset)
    spans = [(p.phone, p.start, p.end) for p in al.phones]
    events = coarticulation.build_events(spans, w, vset, preset.rules.diphthong_split)
    rest_i, rest_w = rest_target(vset, preset)
    duration = max(al.duration, snd.duration)
    segs = coarticulation.segments_with_silence(events, duration, rest_i, rest_w)
    times = frame_times(duration, fps)
    order = [clip.channels.index(c) for c in channels]
    raw_y = clip.tracks[:, order]
    y = np.empty((len(times), len(channels)))
    for j in range(len(channels)):
        y[:, j] = np.interp(times, clip.times, raw_y[:, j])
    closure = np.zeros(len(times), bool)
    for p in al.phones:
        if p.phone in ("P", "B", "M"):
            closure |= (times >= p.start) & (times <= p.end)
    targets = np.zeros((len(segs), len(vset.visemes)))
    for i, s in enumerate(segs):
        if s.viseme >= 0:
            targets[i, s.viseme] = s.weight
    rest = pauses.rest_for(times, [(p.start, p.end) for p in al.phones], duration)
    return Prepared(clip.name, times, y, np.array([s.centre for s in segs]),
                    preset.dominance.plateau * np.array([(s.end - s.start) / 2 for s in segs]),
                    np.array([CLASSES.index(s.cls) for s in segs]), targets, al, pitch, inten, stats,
                    np.asarray(clip.times, float), raw_y, closure, coarticulation.closure_steps(times, events), rest,
                    coarticulation.closure_caps(times, events), duration)



def load_clip(audio_path: str | os.PathLike, tracks_path: str | os.PathLike | None = None,
              transcript: str | None = None, alignment_path: str | os.PathLike | None = None,
              capture_fps: float = 60.0, dictionary: str | None = None,
              track_map: dict | None = None) -> TrainingClip:
    """A training clip from files: ``line.wav`` with ``line.csv`` (capture)
    and ``line.txt`` (transcript) or ``line.TextGrid`` (alignment) beside it,
    unless given.  With ``track_map`` (:func:`..capture.load_track_map`)
    the CSV holds generic tracks, else ARKit blendshapes."""
    audio_path = Path(audio_path)
    stem = audio_path.with_suffix("")
    tracks_path = Path(tracks_path) if tracks_path else stem.with_suffix(".csv")
    snd = audio_mod.load(audio_path)
    head = None
    if track_map is not None:
        times, values, channels = read_track_csv(tracks_path, track_map, capture_fps)
    else:
        times, values, channels = read_capture_csv(tracks_path, capture_fps)
        head = read_head_csv(tracks_path, capture_fps)
    if alignment_path is None and transcript is None:
        grid = stem.with_suffix(".TextGrid")
        if grid.is_file():
            alignment_path = grid
        elif stem.with_suffix(".txt").is_file():
            transcript, _notes = read_text_file(stem.with_suffix(".txt"))
        else:
            raise LipSyncError(f"{audio_path.name}: no transcript ({stem.name}.txt) or alignment "
                               f"({stem.name}.TextGrid) beside it")
    if alignment_path is not None:
        al = read_alignment(alignment_path, audio_duration=snd.duration)
        al.duration = max(al.duration, snd.duration)
    else:
        al = align_audio(snd, transcript, Lexicon.with_user_file(dictionary))
    return TrainingClip(audio_path.stem, snd, al, times, values, channels, head)
