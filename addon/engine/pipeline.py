"""The whole job: audio + transcript -> aligned phonemes -> viseme curves.

:func:`analyze` is the one call the command line, the Blender add-on and
other programs make.  Each step is also callable on its own.
"""

from __future__ import annotations

import copy
import csv
import json
import os
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Callable

import numpy as np

from . import audio as audio_mod
from . import arousal as arousal_mod
from . import coarticulation, emotion_track, pauses, presets, prosody, visemes, weights
from .alignment import AlignSettings, Alignment, align, check_transcript_matches
from .alignment.parallel import Background
from .audio import Audio
from .errors import AlignmentError, AudioError, LipSyncError
from .importers import read_alignment
from .language.phonemes import CLASSES, phone_class
from .language.pronounce import Lexicon
from .language.text import describe_skipped, normalize, skipped_words

MODELS = ("dominance", "rules")
#: Shorter audio cannot hold a spoken word (s).
MIN_SPEECH = 0.1
SCHEMA_VERSION = 1

#: Broadcast rates written with two decimals mean the NTSC ratios.
_NTSC = {23.976: Fraction(24000, 1001), 29.97: Fraction(30000, 1001), 59.94: Fraction(60000, 1001),
         47.952: Fraction(48000, 1001), 119.88: Fraction(120000, 1001)}


def parse_fps(value) -> float:
    """``"29.97"`` -> 30000/1001; ``"24000/1001"`` and plain numbers work too."""
    try:
        if isinstance(value, str) and "/" in value:
            a, b = value.split("/")
            fps = float(Fraction(int(a), int(b)))
        else:
            fps = float(value)
            for k, v in _NTSC.items():
                if abs(fps - k) < 0.006:
                    fps = float(v)
    except (ValueError, ZeroDivisionError):
        raise LipSyncError(f"frame rate {value!r} is not a number") from None
    if not (1.0 <= fps <= 1000.0):
        raise LipSyncError(f"frame rate {value!r} is out of range (1-1000 fps)")
    return fps


def align_audio(snd: Audio, text: str, lexicon: Lexicon | None = None,
                settings: AlignSettings | None = None,
                progress: Callable[[float], None] | None = None) -> Alignment:
    """Normalise ``text``, pronounce every word and align it to ``snd``."""
    lexicon = lexicon or Lexicon()
    words = normalize(text)
    prons = [lexicon.pronounce(w) for w in words]
    try:
        al = align(snd, [p.phones for p in prons], [w.pause_after for w in words],
                   [w.text for w in words], [p.source for p in prons], settings, progress)
    except (BrokenProcessPool, MemoryError):
        raise AlignmentError(f"the aligner ran out of memory (or a worker process was stopped) on "
                             f"{snd.duration / 60:.1f} minutes of audio: split the recording into shorter "
                             "lines") from None
    check_transcript_matches(al)
    skipped = skipped_words(text)
    if skipped:
        n = len(skipped)
        warning = (f"{n} word{'s' if n > 1 else ''} of the transcript left out, the aligner cannot use "
                   f"{'them' if n > 1 else 'it'}: {describe_skipped(skipped)}")
        al.notes.insert(0, warning)
        al.warnings.insert(0, warning)
    return al


def align_file(path: str | os.PathLike, text: str, **kw) -> Alignment:
    return align_audio(audio_mod.load(path), text, **kw)


@dataclass
class Result:
    """Everything :func:`analyze` found, and the curves."""

    duration: float
    fps: float
    viseme_set: visemes.VisemeSet
    emotion: str
    model: str
    alignment: Alignment
    pitch: np.ndarray          # per phoneme, Hz (NaN: no pitch)
    intensity: np.ndarray      # per phoneme, dB
    weights: np.ndarray        # per phoneme
    times: np.ndarray          # per frame, s
    curves: np.ndarray         # (frames, visemes) in [0, 1]
    notes: list[str] = field(default_factory=list)
    closure: np.ndarray = field(default_factory=lambda: np.zeros(0))  # per frame: lips closed (/p b m/), 0-1
    #: The notes a user must see (printed as warnings): words left out, a guessed encoding.
    warnings: list[str] = field(default_factory=list)
    arousal: arousal_mod.Estimate | None = None   # how excited the voice sounds, -1 to 1
    emotions: list[dict] = field(default_factory=list)  # the emotion over time (inline tags, markers)

    def to_dict(self) -> dict:
        al = self.alignment
        return {
            "schema": SCHEMA_VERSION,
            "duration": round(self.duration, 6),
            "fps": self.fps,
            "viseme_set": self.viseme_set.name,
            "emotion": self.emotion,
            "coarticulation": self.model,
            "visemes": list(self.viseme_set.visemes),
            "words": [{"word": w.text, "start": round(w.start, 4), "end": round(w.end, 4),
                       "estimated": bool(w.estimated), "pronunciation": w.source or None}
                      for w in al.words],
            "phonemes": [{"phone": p.phone, "start": round(p.start, 4), "end": round(p.end, 4),
                          "word_index": p.word_index,
                          "pitch_hz": None if not np.isfinite(f) else round(float(f), 2),
                          "intensity_db": round(float(i), 2), "weight": round(float(w), 4),
                          "estimated": bool(p.estimated)}
                         for p, f, i, w in zip(al.phones, self.pitch, self.intensity, self.weights)],
            "frames": {"time": [round(float(t), 6) for t in self.times],
                       "weights": np.round(self.curves, 4).tolist(),
                       "closure": np.round(self.closure, 4).tolist()},
            "notes": self.notes,
            "arousal": self.arousal.to_dict() if self.arousal is not None else None,
            "emotions": self.emotions or [{"emotion": self.emotion, "time": 0.0, "fade": None}],
        }

    def write_json(self, path: str | os.PathLike) -> None:
        # Encoded whole before the file is opened: json.dumps uses the C
        # encoder (json.dump to a file does not; 4 against 13 ms on a 27 s
        # line), and a value that cannot be encoded leaves no partial file.
        text = json.dumps(self.to_dict(), separators=(",", ":"))
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(text)

    def write_csv(self, path: str | os.PathLike) -> None:
        """The frame table: frame, time, then one column per viseme."""
        with open(path, "w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            w.writerow(["frame", "time"] + list(self.viseme_set.visemes))
            for k, (t, row) in enumerate(zip(self.times, self.curves)):
                w.writerow([k, f"{t:.6f}"] + [f"{x:.4f}" for x in row])


def check_output_path(path: str | os.PathLike, what: str = "output", inputs=()) -> None:
    """Raise :class:`LipSyncError` now, before any work, if ``path`` cannot
    be written: its folder is missing or not a folder, it is a folder, it is
    read-only, or it is one of the ``inputs`` (which writing would destroy)."""
    path = os.path.abspath(os.fspath(path))
    folder = os.path.dirname(path)
    if os.path.isdir(path):
        raise LipSyncError(f"{what} {path} is a folder; give a file name")
    if not os.path.exists(folder):
        raise LipSyncError(f"cannot write {what} {path}: the folder {folder} does not exist")
    if not os.path.isdir(folder):
        raise LipSyncError(f"cannot write {what} {path}: {folder} is not a folder")
    for other in inputs:
        if other and os.path.exists(other) and os.path.exists(path) and os.path.samefile(path, other):
            raise LipSyncError(f"{what} {path} is also an input; writing it would replace it")
    if os.path.exists(path):
        if not os.access(path, os.W_OK):
            raise LipSyncError(f"cannot write {what} {path}: the file is read-only")
    elif not os.access(folder, os.W_OK | os.X_OK):
        raise LipSyncError(f"cannot write {what} {path}: no permission to write in {folder}")


def frame_times(duration: float, fps: float) -> np.ndarray:
    return np.arange(int(np.floor(duration * fps + 1e-9)) + 1) / fps


def phone_ranges(phones: list[str], vset: visemes.VisemeSet, preset: dict) -> np.ndarray:
    """(W_min, W_p, W_max) of each phoneme's (first) viseme, scaled by the preset."""
    scale = preset["weights"]["range_scale"]
    out = np.zeros((len(phones), 3))
    for k, p in enumerate(phones):
        vs = vset.of(p)
        base = vset.ranges[vset.index(vs[0])] if vs else np.zeros(3)
        out[k] = np.clip(base * np.asarray(scale[phone_class(p)]), 0.0, 1.0)
    return out


def phoneme_weights(alignment: Alignment, pitch: np.ndarray, intensity: np.ndarray, stats: prosody.ClipStats,
                    vset: visemes.VisemeSet, preset: dict, arousal: np.ndarray | None = None) -> np.ndarray:
    """Equations 1-2: each phoneme's viseme weight from its pitch and intensity.
    ``arousal`` (per phoneme, -1 to 1) widens or narrows the ranges by the
    preset's ``weights.follow_voice``."""
    phones = [p.phone for p in alignment.phones]
    ranges = phone_ranges(phones, vset, preset)
    amount = preset["weights"].get("follow_voice", 0.0)
    if arousal is not None and amount > 0 and len(phones):
        ranges = np.clip(ranges * arousal_mod.range_factor(arousal, amount)[:, None], 0.0, 1.0)
    return weights.phoneme_weights(phones, pitch, intensity, stats, ranges, preset["weights"]["other_source"])


def rest_target(vset: visemes.VisemeSet, preset: dict) -> tuple[int | None, float]:
    """The viseme silence shows and its weight (None, 0: silence is the basis)."""
    rest = vset.rest
    if not rest:
        return None, 0.0
    i = vset.index(rest)
    return i, float(vset.ranges[i][1] * preset["weights"]["range_scale"]["silence"][1])


def curves(alignment: Alignment, pitch: np.ndarray, intensity: np.ndarray, stats: prosody.ClipStats,
           vset: visemes.VisemeSet, preset: dict, model: str, fps: float, arousal: np.ndarray | None = None
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Weights per phoneme, frame times and viseme curves."""
    if model not in MODELS:
        raise LipSyncError(f"unknown coarticulation model {model!r}: use {' or '.join(MODELS)}")
    w = phoneme_weights(alignment, pitch, intensity, stats, vset, preset, arousal)
    times = frame_times(alignment.duration, fps)
    spans = [(p.phone, p.start, p.end) for p in alignment.phones]
    split = preset["rules"]["diphthong_split"]
    n_v = len(vset.visemes)
    if model == "rules":
        de = preset["rules"]["deletion"]
        kept, kw = coarticulation.delete_short(spans, w, de["phones"], de["threshold"])
        events = coarticulation.build_events(kept, kw, vset, split)
        out = coarticulation.rules(events, times, n_v, preset)
    else:
        events = coarticulation.build_events(spans, w, vset, split)
        rest_i, rest_w = rest_target(vset, preset)
        out = coarticulation.dominance(events, times, n_v, preset, alignment.duration, rest_i, rest_w)
    out = coarticulation.smooth(out, fps, preset["smoothing"])
    out = pauses.force_rest(out, times, [(p.start, p.end) for p in alignment.phones], alignment.duration)
    out = coarticulation.enforce_closures(out, times, events, preset["closure"]["strength"])
    out = np.clip(out * preset["gain"], 0.0, 1.0)
    return w, times, out


def viseme_set_for(preset: dict, viseme_set: str | None = None) -> visemes.VisemeSet:
    """The viseme set to use: ``viseme_set`` (default: ``default``), unless
    the preset was learned from animation, whose set and poses it carries."""
    learned = preset.get("learned")
    if learned is None:
        return visemes.load(viseme_set or "default")
    base = visemes.load(learned["viseme_set"])
    if viseme_set is not None and visemes.load(viseme_set).name != base.name:
        raise LipSyncError(f"preset {preset.get('name', '')!r} was learned with the {base.name!r} viseme set; "
                           f"it cannot drive {viseme_set!r}")
    return visemes.with_targets(base, learned["targets"])


def check_alignment_times(al: Alignment, audio_duration: float) -> None:
    """An alignment handed over as an object: every phone and word time
    finite, not negative, not ending before it starts and not past the end
    of the audio (by more than the importers' tolerance)."""
    from .importers import END_TOLERANCE

    limit = audio_duration + END_TOLERANCE
    items = [("phone", k, p.phone, p.start, p.end) for k, p in enumerate(al.phones)]
    items += [("word", k, w.text, w.start, w.end) for k, w in enumerate(al.words)]
    for kind, k, label, a, b in items:
        where = f"the alignment's {kind} {k + 1} ({label!r})"
        if not (np.isfinite(a) and np.isfinite(b)):
            raise LipSyncError(f"{where}: its times ({a}, {b}) are not finite numbers")
        if a < 0 or b < a:
            raise LipSyncError(f"{where}: its times ({a:g} s to {b:g} s) are negative or reversed")
        if b > limit:
            raise LipSyncError(f"{where}: it ends at {b:g} s, past the end of the audio ({audio_duration:.3f} s)")
    if not np.isfinite(al.duration) or al.duration > limit:
        raise LipSyncError(f"the alignment's length ({al.duration:g} s) is past the end of the audio "
                           f"({audio_duration:.3f} s)")


def measure_voice(snd: Audio, model: dict | None = None) -> tuple[prosody.Tracks, arousal_mod.Frames | None]:
    """Pitch and intensity tracks, and the frames arousal is judged on
    (by ``model``, default :func:`.arousal.load_model`)."""
    tracks = prosody.analyse(snd)
    if snd.duration < MIN_SPEECH:
        return tracks, None
    model = model or arousal_mod.load_model()
    return tracks, arousal_mod.frames(snd, tracks, float(model.get("speech_db", 35.0)))


def _voice_beside_alignment(snd: Audio, settings: AlignSettings | None, model: dict) -> Background | None:
    """:func:`measure_voice` on the second core while the first one finds
    where to cut the clip, for clips aligned in pieces
    (:attr:`AlignSettings.split_above` to ``stream_above``); longer ones
    keep both cores busy aligning, shorter ones are aligned in one pass."""
    settings = settings or AlignSettings()
    if not settings.split_above < snd.duration <= settings.stream_above:
        return None
    return Background(measure_voice, snd, model, settings=settings)


def _once_per_name(lookup: Callable[[str], dict]) -> Callable[[str], dict]:
    """``lookup`` reading each preset once (a tag's name is looked up when
    the tag is found and again when it is timed); every caller gets its own
    copy.  A name that fails is not remembered, so it fails again alike."""
    found: dict[str, dict] = {}

    def once(name: str) -> dict:
        if name not in found:
            found[name] = lookup(name)
        return copy.deepcopy(found[name])
    return once


def analyze(audio: str | os.PathLike | Audio, text: str | None = None, *,
            alignment: Alignment | str | os.PathLike | None = None,
            viseme_set: str | None = None, emotion: str | dict = "neutral",
            coarticulation_model: str = "dominance", fps=30, dictionary: str | None = None,
            settings: AlignSettings | None = None,
            progress: Callable[[str, float], None] | None = None,
            emotion_changes: list | None = None, emotion_fade: float = emotion_track.DEFAULT_FADE,
            emotion_lookup: Callable[[str], dict] | None = None) -> Result:
    """Audio + transcript (or an imported alignment) -> viseme curves.

    ``emotion`` is a built-in preset name, a preset file path or a preset
    dict; ``viseme_set`` a built-in set name or a file path (default:
    ``default``, or the set a learned preset was trained with).  ``progress``
    is called with (step, fraction done).

    Inline tags in ``text`` (``[angry]``) and ``emotion_changes`` ((time s,
    preset name or dict) pairs, e.g. from timeline markers) change the
    emotion inside the line, fading over ``emotion_fade`` s; see
    :mod:`.emotion_track`.  ``emotion_lookup`` resolves a tag's name
    (default: :func:`presets.load`).
    """
    def report(step, frac):
        if progress:
            progress(step, frac)

    fps = parse_fps(fps)
    background = None
    preset = presets.resolve(dict(emotion), "preset") if isinstance(emotion, dict) else presets.load(emotion)
    vset = viseme_set_for(preset, viseme_set)
    if coarticulation_model not in MODELS:
        raise LipSyncError(f"unknown coarticulation model {coarticulation_model!r}: use {' or '.join(MODELS)}")
    lookup = _once_per_name(emotion_lookup or presets.load)
    tags = []
    if text is not None:
        text, tags = emotion_track.split_tags(text, known=lambda n: bool(lookup(n)))
    if emotion_fade < 0 or not np.isfinite(emotion_fade):
        raise LipSyncError(f"the emotion fade must be 0 s or more, got {emotion_fade!r}")
    report("decode", 0.0)
    snd = audio if isinstance(audio, Audio) else audio_mod.load(audio)
    voice_model = arousal_mod.load_model()
    if alignment is None:
        if text is None:
            raise LipSyncError("give a transcript, or an alignment file to import")
        if snd.duration < MIN_SPEECH:
            name = "the audio" if isinstance(audio, Audio) else f"audio file {os.fspath(audio)}"
            raise AudioError(f"{name} is too short to hold speech ({snd.duration:.3f} s; "
                             f"a line needs at least {MIN_SPEECH:.1f} s)")
        report("align", 0.1)
        lexicon = Lexicon.with_user_file(dictionary)
        background = _voice_beside_alignment(snd, settings, voice_model)
        try:
            al = align_audio(snd, text, lexicon, settings, lambda f: report("align", 0.1 + 0.7 * f))
        except BaseException:
            if background is not None:
                background.close()
            raise
    elif isinstance(alignment, Alignment):
        al = alignment
        check_alignment_times(al, snd.duration)
    else:
        al = read_alignment(alignment, audio_duration=snd.duration)
    al.duration = max(snd.duration, al.duration if alignment is not None else 0.0)
    report("prosody", 0.8)
    tracks, measured = background.result() if background is not None else measure_voice(snd, voice_model)
    voice = arousal_mod.estimate(snd, tracks, al, voice_model, measured=measured) if measured is not None else None
    changes = [emotion_track.Change(t, lookup(name), name)
               for t, name in emotion_track.tag_times(tags, [w.start for w in al.words], al.duration)]
    for t, p in emotion_changes or []:
        p = presets.resolve(dict(p), "preset") if isinstance(p, dict) else lookup(p)
        changes.append(emotion_track.Change(float(t), p, p.get("name", "")))
    report("curves", 0.9)
    pitch, inten, w, times, out, stats = emotion_track.render(al, tracks, preset, changes, vset,
                                                               coarticulation_model, fps, voice, emotion_fade,
                                                               viseme_set)
    report("done", 1.0)
    notes = list(snd.notes) + list(al.notes)
    if not stats.voiced:
        notes.append("no voiced speech found: pitch plays no part in the weights (whispered?)")
    closure = coarticulation.closure_track(times, [(p.phone, p.start, p.end) for p in al.phones])
    return Result(al.duration, fps, vset, preset.get("name", str(emotion)), coarticulation_model, al,
                  pitch, inten, w, times, out, notes, closure, list(snd.notes) + list(al.warnings), voice,
                  emotion_track.timeline(preset.get("name", str(emotion)), changes, emotion_fade))


__all__ = ["analyze", "align_audio", "align_file", "curves", "parse_fps", "Result", "CLASSES"]
