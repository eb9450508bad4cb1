"""Emotion changing inside a line: inline tags, change times, the cross-fade."""

import json

import numpy as np
import pytest

from addon.engine import cli, emotion_track, pipeline, presets
from addon.engine.alignment import AlignedWord, Alignment
from addon.engine.errors import LipSyncError, TranscriptError
from addon.engine.language.text import normalize
from addon.engine.settings import LineSettings
from voice_synth import voice


def test_tags_are_taken_out_and_placed_before_their_word():
    clean, tags = emotion_track.split_tags("I'm fine. [angry] Get out! [Neutral] Sorry [sighs].")
    assert "[" not in clean.replace("[sighs]", "")
    assert [w.text for w in normalize(clean)] == ["i'm", "fine", "get", "out", "sorry"]
    assert [(t.preset, t.word_index) for t in tags] == [("angry", 2), ("neutral", 4)]


def test_explicit_tags_and_preset_files(tmp_path):
    f = tmp_path / "grumpy.json"
    f.write_text(json.dumps({"name": "grumpy", "base": "sad", "gain": 0.9}))
    clean, tags = emotion_track.split_tags(f"[emotion: happy] Hi there [{f}] bye")
    assert [(t.preset, t.word_index) for t in tags] == [("happy", 0), (str(f), 2)]
    assert [w.text for w in normalize(clean)] == ["hi", "there", "bye"]


@pytest.mark.parametrize("text, bad", [("Fine.\nGet [angyr] out", "[angyr]"),
                                       ("Go [emotion:furious] now", "[emotion:furious]"),
                                       ("Go [missing.json] now", "[missing.json]")])
def test_unknown_tag_is_an_error_naming_it(text, bad):
    with pytest.raises(TranscriptError) as exc:
        emotion_track.split_tags(text)
    msg = str(exc.value)
    assert bad in msg and "line" in msg and "column" in msg and "\n" not in msg
    if "angyr" in bad:
        assert "line 2, column 5" in msg and "[angry]" in msg


def test_stage_directions_stay_stage_directions():
    clean, tags = emotion_track.split_tags("[sighs] Well [long pause] fine [sadly].")
    assert tags == []
    assert [w.text for w in normalize(clean)] == ["well", "fine"]


def test_mix_is_a_linear_cross_fade_ending_at_the_change():
    t = np.arange(0, 2, 0.01)
    m = emotion_track.mix(t, [1.0], 2, [1], fade=0.3)
    assert np.allclose(m.sum(axis=1), 1)
    assert (m[t <= 0.7, 1] == 0).all() and (m[t >= 1.0, 1] == 1).all()
    assert m[np.searchsorted(t, 0.85), 1] == pytest.approx(0.5, abs=0.04)
    step = emotion_track.mix(t, [1.0], 2, [1], fade=0.0)
    assert (step[t < 1.0, 1] == 0).all() and (step[t >= 1.0, 1] == 1).all()


@pytest.fixture(scope="module")
def line():
    return voice(0.5, syllables=("AA", "IY", "UW", "EH", "AA", "IY", "UW", "EH"))


def test_weights_follow_each_preset_on_each_side_without_a_jump(line):
    snd, al = line
    change = al.words[4].start
    neutral = pipeline.analyze(snd, settings=LineSettings.of(emotion="neutral"), alignment=al)
    angry = pipeline.analyze(snd, settings=LineSettings.of(emotion="angry"), alignment=al)
    mixed = pipeline.analyze(snd, settings=LineSettings.of(emotion="neutral"), alignment=al,
                             emotion_changes=[(change, "angry")])
    t = mixed.times
    before, after = t < change - 0.3, t >= change
    assert np.array_equal(mixed.curves[before], neutral.curves[before])
    assert np.array_equal(mixed.curves[after], angry.curves[after])
    assert not np.allclose(neutral.curves[after], angry.curves[after])   # the presets do differ there
    centres = np.array([(p.start + p.end) / 2 for p in al.phones])
    assert np.allclose(mixed.weights[centres >= change], angry.weights[centres >= change])
    assert np.allclose(mixed.weights[centres < change - 0.3], neutral.weights[centres < change - 0.3])
    # No jump: across the fade, each curve moves per frame no more than the
    # presets' own curves do, plus the gap between them times the fade's step.
    own = np.maximum(np.abs(np.diff(neutral.curves, axis=0)), np.abs(np.diff(angry.curves, axis=0)))
    step = 1.0 / (0.3 * mixed.fps)
    gap = np.abs(neutral.curves - angry.curves)
    assert (np.abs(np.diff(mixed.curves, axis=0)) <= own + step * np.maximum(gap[1:], gap[:-1]) + 1e-9).all()
    # A preset far from neutral: a hard cut jumps, the cross-fade does not.
    small = {"name": "small", "gain": 0.4}
    low = pipeline.analyze(snd, settings=LineSettings.of(emotion=small), alignment=al)
    own = np.maximum(np.abs(np.diff(neutral.curves, axis=0)), np.abs(np.diff(low.curves, axis=0)))
    gap = np.abs(neutral.curves - low.curves)
    vowel = al.phones[13]                  # word 4's vowel: a change (a marker) mid-vowel
    mid = (vowel.start + vowel.end) / 2
    k = np.searchsorted(t, mid)
    cut = pipeline.analyze(snd, settings=LineSettings.of(emotion="neutral", emotion_fade=0.0), alignment=al,
                           emotion_changes=[(mid, small)])
    assert (np.abs(cut.curves[k] - cut.curves[k - 1]) > own[k - 1] + 0.1).any()
    faded = pipeline.analyze(snd, settings=LineSettings.of(emotion="neutral"), alignment=al,
                             emotion_changes=[(mid, small)])
    assert (np.abs(np.diff(faded.curves, axis=0)) <= own + step * np.maximum(gap[1:], gap[:-1]) + 1e-9).all()
    doc = mixed.to_dict()
    assert doc["emotions"] == [{"emotion": "neutral", "time": 0.0, "fade": None},
                               {"emotion": "angry", "time": round(change, 4),
                                "fade": [round(change - 0.3, 4), round(change, 4)]}]


def test_inline_tags_in_analyze_never_reach_the_aligner(monkeypatch, line):
    snd, al = line
    seen = {}

    def fake_align(_snd, text, *a, **kw):
        seen["text"] = text
        words = [w.text for w in normalize(text)]
        assert len(words) == len(al.words)
        return Alignment([AlignedWord(x, w.start, w.end, w.phones) for x, w in zip(words, al.words)],
                         list(al.phones), al.duration)

    monkeypatch.setattr(pipeline, "align_audio", fake_align)
    r = pipeline.analyze(snd, "one two three four [sad] five six seven [neutral] eight",
                         LineSettings.of(emotion="neutral"))
    assert "[" not in seen["text"] and "sad" not in seen["text"]
    assert [(e["emotion"], e["time"]) for e in r.emotions] == [
        ("neutral", 0.0), ("sad", round(al.words[4].start, 4)), ("neutral", round(al.words[7].start, 4))]
    sad = pipeline.analyze(snd, settings=LineSettings.of(emotion="sad"), alignment=al)
    neutral = pipeline.analyze(snd, settings=LineSettings.of(emotion="neutral"), alignment=al)
    mid = (r.times >= al.words[4].start) & (r.times < al.words[7].start - 0.3)
    assert np.array_equal(r.curves[mid], sad.curves[mid])
    end = r.times >= al.words[7].start
    assert np.array_equal(r.curves[end], neutral.curves[end])
    # A tag before the first word sets the line's emotion from the start.
    r = pipeline.analyze(snd, "[sad] one two three four five six seven eight", LineSettings.of(emotion="neutral"))
    assert np.array_equal(r.curves, sad.curves)
    assert r.emotions == [{"emotion": "sad", "time": 0.0, "fade": None}]
    # ... and the line's emotion is that one, as with --emotion sad.
    assert r.emotion == "sad" and r.to_dict()["emotion"] == sad.to_dict()["emotion"] == "sad"


def test_preset_file_in_a_tag_is_read_from_the_transcripts_folder(monkeypatch, line, tmp_path):
    """``[presets/grumpy.json]`` names a file beside the transcript, wherever the command runs."""
    snd, al = line
    folder = tmp_path / "script"
    (folder / "presets").mkdir(parents=True)
    (folder / "presets" / "grumpy.json").write_text('{"name": "grumpy", "base": "angry"}', encoding="utf-8")
    transcript = folder / "line.txt"
    transcript.write_text("[presets/grumpy.json] one two three four five six seven eight", encoding="utf-8")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)

    def fake_align(_snd, text, *a, **kw):
        words = [w.text for w in normalize(text)]
        return Alignment([AlignedWord(x, w.start, w.end, w.phones) for x, w in zip(words, al.words)],
                         list(al.phones), al.duration)

    monkeypatch.setattr(pipeline, "align_audio", fake_align)
    text = transcript.read_text(encoding="utf-8")
    r = pipeline.analyze(snd, text, transcript_path=transcript)
    angry = pipeline.analyze(snd, settings=LineSettings.of(emotion="angry"), alignment=al)
    assert r.emotion == "presets/grumpy.json" and np.array_equal(r.curves, angry.curves)
    # Without the transcript's folder the path means nothing here: an error naming the tag.
    with pytest.raises(LipSyncError, match=r"presets/grumpy\.json"):
        pipeline.analyze(snd, text)


def test_cli_unknown_tag_is_a_one_line_error(tmp_path, capsys, fixtures):
    rc = cli.main(["analyze", str(fixtures / "bob_map.wav"), "--text", "Bob [angyr] ran",
                   "--json", str(tmp_path / "o.json")])
    err = capsys.readouterr().err
    assert rc == 1 and "[angyr]" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o.json").exists()
    rc = cli.main(["analyze", str(fixtures / "bob_map.wav"), "--text", "Bob", "--emotion-fade", "-1",
                   "--json", str(tmp_path / "o.json")])
    err = capsys.readouterr().err
    assert rc == 1 and "fade" in err and len(err.strip().splitlines()) == 1


def test_presets_with_different_viseme_sets_cannot_share_a_line(line, tmp_path):
    snd, al = line
    p = presets.read("neutral")
    p["learned"] = {"viseme_set": "arkit", "targets": {"aa": {"jawOpen": 1.0}}}
    with pytest.raises(Exception, match="viseme set"):
        pipeline.analyze(snd, settings=LineSettings.of(emotion="neutral"), alignment=al, emotion_changes=[(0.5, p)])
    with pytest.raises(Exception, match="viseme set"):   # also when it takes over from the start
        pipeline.analyze(snd, settings=LineSettings.of(emotion="neutral"), alignment=al, emotion_changes=[(0.0, p)])


def test_batch_honours_inline_tags(tmp_path, fixtures):
    import shutil

    from addon.engine import batch

    shutil.copy(fixtures / "bob_map.wav", tmp_path / "bob_map.wav")
    (tmp_path / "m.csv").write_text('audio,text\nbob_map.wav,"Bob bought [sad] a map."\n')
    rep = batch.run(tmp_path / "m.csv", workers=1, progress=False)
    assert rep.count("ok") == 1
    doc = json.loads((tmp_path / "bob_map.json").read_text())
    assert [w["word"] for w in doc["words"]] == ["bob", "bought", "a", "map"]
    assert [e["emotion"] for e in doc["emotions"]] == ["neutral", "sad"]
    assert doc["emotions"][1]["time"] == doc["words"][2]["start"]


def test_batch_emotion_fade_option_reaches_every_line(tmp_path, fixtures):
    import shutil

    shutil.copy(fixtures / "bob_map.wav", tmp_path / "bob_map.wav")
    (tmp_path / "m.csv").write_text('audio,text\nbob_map.wav,"Bob bought [angry] a map."\n')
    assert cli.main(["batch", str(tmp_path / "m.csv"), "--emotion-fade", "0.05", "--quiet"]) == 0
    doc = json.loads((tmp_path / "bob_map.json").read_text())
    want = pipeline.analyze(fixtures / "bob_map.wav", "Bob bought [angry] a map.", LineSettings.of(emotion_fade=0.05))
    start, end = doc["emotions"][1]["fade"]
    assert end - start == pytest.approx(0.05)
    assert doc.pop("produced_by")["settings"]["emotion_fade"] == 0.05
    assert doc == json.loads(json.dumps(want.to_dict(), separators=(",", ":")))
    default = pipeline.analyze(fixtures / "bob_map.wav", "Bob bought [angry] a map.")
    assert not np.allclose(default.curves, want.curves)     # the option changed the animation


@pytest.mark.parametrize("command", ["analyze", "batch"])
@pytest.mark.parametrize("option, value, says", [("--workers", "-2", "--workers"),
                                                 ("--emotion-fade", "-1", "--emotion-fade"),
                                                 ("--emotion-fade", "nan", "--emotion-fade")])
def test_cli_option_checks_are_one_line_errors(command, option, value, says, tmp_path, capsys, fixtures):
    (tmp_path / "m.csv").write_text("audio,text\n" + str(fixtures / "bob_map.wav") + ",Bob\n")
    args = (["analyze", str(fixtures / "bob_map.wav"), "--text", "Bob", "--json", str(tmp_path / "o.json")]
            if command == "analyze" else ["batch", str(tmp_path / "m.csv"), "--out", str(tmp_path / "out")])
    assert cli.main(args + [option, value]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and says in err and err.startswith("error:")
    assert not (tmp_path / "o.json").exists() and not (tmp_path / "out").exists()


def test_cli_and_batch_read_a_tags_preset_file_from_the_transcripts_folder(tmp_path, monkeypatch, fixtures):
    script = tmp_path / "script"
    (script / "presets").mkdir(parents=True)
    (script / "presets" / "grumpy.json").write_text('{"name": "grumpy", "base": "sad"}', encoding="utf-8")
    (script / "bob.txt").write_text("[presets/grumpy.json] Bob", encoding="utf-8")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    out = tmp_path / "o.json"
    assert cli.main(["analyze", str(fixtures / "bob_map.wav"), "--transcript", str(script / "bob.txt"),
                     "--json", str(out), "--quiet"]) == 0
    sad = tmp_path / "sad.json"
    assert cli.main(["analyze", str(fixtures / "bob_map.wav"), "--text", "Bob", "--emotion", "sad",
                     "--json", str(sad), "--quiet"]) == 0
    got, want = json.loads(out.read_text()), json.loads(sad.read_text())
    assert got["emotion"] == "presets/grumpy.json" and got["frames"] == want["frames"]
    manifest = tmp_path / "lines.csv"
    manifest.write_text(f"audio,transcript\n{fixtures / 'bob_map.wav'},{script / 'bob.txt'}\n", encoding="utf-8")
    assert cli.main(["batch", str(manifest), "--out", str(tmp_path / "batch"), "--quiet"]) == 0
    doc = json.loads((tmp_path / "batch" / "bob_map.json").read_text())
    assert doc["emotion"] == "presets/grumpy.json" and doc["frames"] == want["frames"]
