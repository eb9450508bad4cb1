"""A line in another language, lip-synced by the installed extension: eSpeak
NG (from the extension's espeakng-loader wheel) reads German and Japanese
(kanji through pykakasi), and speaks the line the test aligns."""

from __future__ import annotations

import os
from importlib import import_module

import numpy as np
import pytest

from conftest import MODULE


def _spoken(espeak, audio, text, voice):
    samples, rate = espeak.synthesize(text, voice)
    pad = np.zeros(int(0.3 * rate), np.float32)
    line = np.concatenate([pad, samples.astype(np.float32) / 32768.0, pad])
    line += np.random.default_rng(0).normal(0.0, 1e-3, line.size).astype(np.float32)   # a room's noise floor
    return audio.from_samples(line, rate)


@pytest.mark.parametrize("code, voice, text, said", [
    ("de", "de", "Mein Bruder baut 23 Boote.", "Mein Bruder baut 23 Boote."),
    ("ja", "ja", "私の名前はマリです。", "わたしのなまえわまりです。"),
])
def test_the_extension_aligns_a_line_in_another_language(extension, code, voice, text, said):
    # The wheels are installed (test_versions.test_installed_wheels_are_this_pythons); eSpeak NG's library loads.
    assert os.path.isfile(import_module("espeakng_loader").get_library_path())
    engine = import_module(MODULE + ".engine")
    espeak = import_module(MODULE + ".engine.language.espeak")
    audio = import_module(MODULE + ".engine.audio")
    result = engine.analyze(_spoken(espeak, audio, said, voice), text, engine.LineSettings.of(language=code, fps=100))
    doc = result.to_dict()
    assert doc["language"] == code
    assert len(doc["words"]) >= 5 and not any(w["estimated"] for w in doc["words"])
    closing = [p for p in result.alignment.phones if p.phone in ("P", "B", "M")]
    assert closing
    for p in closing:
        inside = (result.times >= p.start - 0.03) & (result.times <= p.end + 0.03)
        assert result.closure[inside].max() >= 0.5


def test_command_language_option_and_manifest_column(scene, tmp_path, capsys):
    """``blender --command lipsync``: --language for every line, a manifest's
    ``language`` column per line, and an unknown code named."""
    espeak = import_module(MODULE + ".engine.language.espeak")
    audio = import_module(MODULE + ".engine.audio")
    command = import_module(MODULE + ".blender.command")
    import bpy
    import wave

    for name, voice, text in (("de", "de", "Mama baut ein Boot."), ("es", "es", "Mi madre bebe mucho.")):
        snd = _spoken(espeak, audio, text, voice)
        with wave.open(str(tmp_path / f"{name}.wav"), "wb") as w:
            w.setnchannels(1)
            w.setsampwidth(2)
            w.setframerate(snd.rate)
            w.writeframes((np.clip(snd.samples, -1, 1) * 32767).astype("<i2").tobytes())
    manifest = tmp_path / "lines.csv"
    manifest.write_text("audio,mesh,frame,text,language\n"
                        f"{tmp_path / 'de.wav'},Ada,10,Mama baut ein Boot.,de\n"
                        f"{tmp_path / 'es.wav'},Kit,10,Mi madre bebe mucho.,\n"
                        f"{tmp_path / 'es.wav'},Kit,200,Mi madre bebe mucho.,xx\n", encoding="utf-8")
    code = command.execute(["--manifest", str(manifest), "--language", "spa"])
    out = capsys.readouterr()
    assert code == 1 and "lipsync: 2 of 3 lip-synced, 1 problem" in out.out
    err = [ln for ln in out.err.splitlines() if ln.startswith("lipsync: line")]
    assert len(err) == 1 and err[0].startswith("lipsync: line 4: unknown language 'xx'")
    assert bpy.data.objects["Ada"].data.shape_keys.animation_data.action is not None
    assert bpy.data.objects["Kit"].data.shape_keys.animation_data.action is not None
    assert command.execute(["--audio", str(tmp_path / "de.wav"), "--mesh", "Ada", "--text", "Mama",
                            "--language", "klingonish"]) == 1
    assert "unknown language 'klingonish'" in capsys.readouterr().err


def test_the_panels_language_drives_generate(scene, tmp_path):
    """The Language field of the panel: a German line from an audio file is
    keyed with the lips closing on its /m b/, and an unknown code is the
    operator's error, naming it."""
    import bpy
    import wave

    espeak = import_module(MODULE + ".engine.language.espeak")
    audio = import_module(MODULE + ".engine.audio")
    snd = _spoken(espeak, audio, "Mama baut ein Boot.", "de")
    path = tmp_path / "de.wav"
    with wave.open(str(path), "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(snd.rate)
        w.writeframes((np.clip(snd.samples, -1, 1) * 32767).astype("<i2").tobytes())
    st = scene.emotive_lipsync
    st.source, st.audio_file, st.start_frame, st.text = "FILE", str(path), 1, "Mama baut ein Boot."
    st.language = "xx"
    with pytest.raises(RuntimeError, match="unknown language 'xx'"):
        bpy.ops.emotive_lipsync.generate("EXEC_DEFAULT", mesh="Ada")
    st.language = "deu"
    assert bpy.ops.emotive_lipsync.generate("EXEC_DEFAULT", mesh="Ada") == {"FINISHED"}
    fcurves = bpy.data.objects["Ada"].data.shape_keys.animation_data.action
    assert fcurves is not None
    run = import_module(MODULE + ".blender.run")
    assert run.options(scene).line.language == "deu"
    # The lips close on the m of Mama and the b of baut and Boot: the MBP key reaches 1 three times or more.
    from conftest import fcurve_values

    _frames, mbp = fcurve_values(bpy.data.objects["Ada"], "MBP")
    peaks = np.flatnonzero((mbp[1:-1] >= 0.9) & (mbp[1:-1] >= mbp[:-2]) & (mbp[1:-1] > mbp[2:]))
    assert len(peaks) >= 3


def test_a_strips_language_in_batch_runs(scene, tmp_path):
    """*Generate for All Strips* and the command read each strip's
    ``lipsync_language`` (like its ``lipsync_text``); a bad one names the strip."""
    import bpy
    import wave

    from conftest import add_strip, fcurve_values

    espeak = import_module(MODULE + ".engine.language.espeak")
    audio = import_module(MODULE + ".engine.audio")
    snd = _spoken(espeak, audio, "Mama baut ein Boot.", "de")
    path = tmp_path / "de.wav"
    with wave.open(str(path), "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(snd.rate)
        w.writeframes((np.clip(snd.samples, -1, 1) * 32767).astype("<i2").tobytes())
    (tmp_path / "de.txt").write_text("Mama baut ein Boot.", encoding="utf-8")
    good = add_strip(scene, "Ada_de", str(path), frame=1, channel=1)
    good["lipsync_language"] = "deu"
    bad = add_strip(scene, "Kit_de", str(path), frame=1, channel=2)
    bad["lipsync_language"] = "xx"
    assert bpy.ops.emotive_lipsync.generate_all() == {"FINISHED"}   # one strip done, one problem
    _frames, mbp = fcurve_values(bpy.data.objects["Ada"], "MBP")
    assert mbp.max() >= 0.9
    assert bpy.data.objects["Kit"].data.shape_keys.animation_data is None
    sources = import_module(MODULE + ".blender.sources")
    assert sources.strip_language(good) == "de"
    with pytest.raises(Exception, match="strip 'Kit_de': its lipsync_language: unknown language 'xx'"):
        sources.strip_language(bad)
