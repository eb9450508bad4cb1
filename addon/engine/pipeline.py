"""The whole job: audio + transcript -> aligned phonemes -> viseme curves.

:func:`analyze` is the one call the command line, the batch runner, the
Blender add-on and other programs make.  It orchestrates the steps, each of
which lives in its own module and is callable on its own:

* decoding (:mod:`.audio`) and the voice's pitch, intensity and arousal
  (:mod:`.prosody`, :mod:`.arousal`);
* the transcript's words aligned to the audio (:mod:`.alignment`), or an
  alignment imported from another tool (:mod:`.importers`);
* the emotion over the line: its preset (one of the line's
  :class:`.settings.LineSettings`), inline tags and markers
  (:mod:`.presets`, :mod:`.emotion_track`);
* the curves (:mod:`.render`) and the gestures beside speech (blinks,
  gaze, head: :mod:`.gestures`), returned as a :class:`.output.Result`.
"""

from __future__ import annotations

import copy
import os
from collections.abc import Callable

import numpy as np

from . import arousal as arousal_mod
from . import audio as audio_mod
from . import coarticulation, emotion_track, gestures, presets, prosody
from .alignment import AlignSettings, Alignment, align_audio
from .alignment.parallel import Background
from .alignment.recognize import recognize
from .audio import Audio
from .errors import AudioError, LipSyncError
from .importers import END_TOLERANCE, read_alignment
from .language import Lexicon, resolve_language
from .output import Result
from .render import render
from .settings import LineSettings

#: Shorter audio cannot hold a spoken word (s).
MIN_SPEECH = 0.1


def check_alignment_times(al: Alignment, audio_duration: float) -> None:
    """An alignment handed over as an object: every phone and word time
    finite, not negative, not ending before it starts and not past the end
    of the audio (by more than the importers' tolerance)."""
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


def _once_per_name(lookup: Callable[[str], presets.Preset]) -> Callable[[str], presets.Preset]:
    """``lookup`` reading each preset once (a tag's name is looked up when
    the tag is found and again when it is timed); every caller gets its own
    copy.  A name that fails is not remembered, so it fails again alike."""
    found: dict[str, presets.Preset] = {}

    def once(name: str) -> presets.Preset:
        if name not in found:
            found[name] = lookup(name)
        return copy.deepcopy(found[name])
    return once


def _align(snd: Audio, text: str | None, lang, dictionary: str | None, settings: AlignSettings | None,
           progress: Callable[[float], None]) -> Alignment:
    """The transcript aligned to the audio, or, with no transcript, the
    words recognised in it (English only)."""
    if text is None:
        if not lang.is_english:
            raise LipSyncError(f"a line in {lang.name} needs its transcript: without one, speech is "
                               "recognised in English only")
        return recognize(snd, settings, progress)
    return align_audio(snd, text, Lexicon.with_user_file(dictionary, lang), settings, progress)


def analyze(audio: str | os.PathLike | Audio, text: str | None = None, settings: LineSettings | None = None, *,
            alignment: Alignment | str | os.PathLike | None = None,
            progress: Callable[[str, float], None] | None = None,
            emotion_changes: list | None = None,
            emotion_lookup: Callable[[str], presets.Preset] | None = None,
            transcript_path: str | os.PathLike | None = None) -> Result:
    """Audio + transcript (or an imported alignment) -> viseme curves.

    ``settings`` say how the line is animated (:class:`.settings.LineSettings`:
    the emotion, viseme set, coarticulation model, frame rate, language ...;
    default: ``LineSettings.of()``, neutral at 30 fps).

    With no transcript (``text`` None) and no alignment, the words are
    recognised from the audio (:mod:`.alignment.recognize`, marked
    ``recognized``).  A transcript is checked against the take
    (:mod:`.alignment.verify`): its words the audio does not hold are kept
    unspoken (no phones, the mouth at rest), and speech it leaves out is
    recognised and animated (``Alignment.unscripted``).  ``progress`` is
    called with (step, fraction done).

    Inline tags in ``text`` (``[angry]``) and ``emotion_changes`` ((time s,
    preset name, Preset or dict) pairs, e.g. from timeline markers) change the
    emotion inside the line, fading over ``settings.emotion_fade`` s; see
    :mod:`.emotion_track`.  ``emotion_lookup`` resolves a tag's name
    (default: :func:`presets.finder`: built-in names, and preset files
    relative to the folder of ``transcript_path``, the file the transcript
    was read from, whose name errors in a tag also give).
    """
    def report(step, frac):
        if progress:
            progress(step, frac)

    settings = settings or LineSettings.of()
    lang = resolve_language(settings.language)
    background = None
    vset = settings.visemes
    folder = os.path.dirname(os.path.abspath(transcript_path)) if transcript_path else None
    lookup = _once_per_name(emotion_lookup or presets.finder(folder))
    tags = []
    if text is not None:
        source = f"transcript {os.fspath(transcript_path)}" if transcript_path else "the transcript"
        text, tags = emotion_track.split_tags(text, known=lambda n: bool(lookup(n)), source=source)
    report("decode", 0.0)
    snd = audio if isinstance(audio, Audio) else audio_mod.load(audio)
    voice_model = arousal_mod.load_model()
    if alignment is None:
        if snd.duration < MIN_SPEECH:
            name = "the audio" if isinstance(audio, Audio) else f"audio file {os.fspath(audio)}"
            raise AudioError(f"{name} is too short to hold speech ({snd.duration:.3f} s; "
                             f"a line needs at least {MIN_SPEECH:.1f} s)")
        report("align", 0.1)
        background = _voice_beside_alignment(snd, settings.align, voice_model)
        try:
            al = _align(snd, text, lang, settings.dictionary, settings.align,
                        lambda f: report("align", 0.1 + 0.7 * f))
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
    script_starts = [w.start for w in al.words if not w.recognized]  # tags count the transcript's words
    changes = [emotion_track.Change(t, lookup(name), name)
               for t, name in emotion_track.tag_times(tags, script_starts, al.duration)]
    for t, p in emotion_changes or []:
        p = lookup(p) if isinstance(p, str) else presets.as_preset(p)
        changes.append(emotion_track.Change(float(t), p, p.name))
    report("curves", 0.9)
    r = render(al, tracks, settings, changes, estimate=voice)
    report("done", 1.0)
    notes = list(snd.notes) + list(al.notes)
    if not r.stats.voiced:
        notes.append("no voiced speech found: pitch plays no part in the weights (whispered?)")
    closure = coarticulation.closure_track(r.times, [(p.phone, p.start, p.end) for p in al.phones])
    emotions = emotion_track.timeline(settings.emotion_label, changes, settings.emotion_fade)
    motion = None
    if settings.gestures:
        # The gestures follow the emotion the line starts with.
        start = next((c.preset for c in sorted(changes, key=lambda c: c.time) if c.time <= 0), settings.emotion)
        motion = gestures.compute(al, r.times, tracks.times, tracks.pitch, tracks.intensity, start.gestures,
                                  settings.gesture_seed)
    return Result(duration=al.duration, fps=settings.fps, viseme_set=vset, emotion=emotions[0]["emotion"],
                  model=settings.coarticulation, alignment=al, pitch=r.pitch, intensity=r.intensity,
                  weights=r.weights, times=r.times, curves=r.curves, notes=notes, closure=closure,
                  warnings=list(snd.notes) + list(al.warnings), arousal=voice, emotions=emotions,
                  expression=r.expression, language=lang.code, gestures=motion)


__all__ = ["analyze", "measure_voice", "MIN_SPEECH"]
