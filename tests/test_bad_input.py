"""Bad input, made at test time: every case ends in a clear message (the
command line: exit status 1 and one ``error:`` line naming the file, line or
time; never a traceback) or in correct output with a warning."""

import json
import os
import subprocess
import sys
import wave
from pathlib import Path

import numpy as np
import pytest

from addon.engine.errors import LipSyncError
from addon.engine.importers import read_alignment

ROOT = Path(__file__).resolve().parent.parent
FIXTURES = Path(__file__).parent / "fixtures"


def write_wav(path, samples, rate=16000, width=2, channels=1):
    """``samples`` in [-1, 1], written as ``width``-byte PCM."""
    x = np.clip(np.asarray(samples, np.float64), -1, 1)
    if channels > 1:
        x = np.repeat(x[:, None], channels, axis=1)
    if width == 1:
        data = ((x * 127) + 128).astype(np.uint8).tobytes()
    elif width == 2:
        data = (x * 32767).astype("<i2").tobytes()
    elif width == 3:
        v = (x * 8388607).astype("<i4").reshape(-1, 1).view(np.uint8).reshape(-1, 4)[:, :3]
        data = v.tobytes()
    else:
        data = (x * 2147483647).astype("<i4").tobytes()
    with wave.open(str(path), "wb") as w:
        w.setnchannels(channels)
        w.setsampwidth(width)
        w.setframerate(rate)
        w.writeframes(data)
    return path


def voiced(seconds=1.0, rate=16000):
    """A vowel-like buzz (130 Hz with harmonics) with a syllable envelope."""
    t = np.arange(int(seconds * rate)) / rate
    buzz = sum(np.sin(2 * np.pi * 130 * k * t) / k for k in range(1, 12))
    env = np.clip(np.sin(np.pi * t * 4) ** 2, 0, 1) * (t > 0.1) * (t < seconds - 0.1)
    return 0.3 * buzz / np.max(np.abs(buzz)) * env


def run_cli(*args, cwd=None):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    p = subprocess.run([sys.executable, "-m", "addon", *map(str, args)], capture_output=True,
                       text=True, env=env, cwd=cwd or ROOT, timeout=120)
    return p.returncode, p.stdout, p.stderr


def assert_error(rc, out, err, *names):
    """Exit status 1, one ``error:`` line naming each of ``names``, no traceback."""
    assert "Traceback" not in out + err, err
    assert rc == 1, (rc, out, err)
    lines = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert len(lines) == 1, err
    for n in names:
        assert str(n) in lines[0], (n, lines[0])
    return lines[0]


@pytest.fixture(scope="module")
def one_second(tmp_path_factory):
    return write_wav(tmp_path_factory.mktemp("audio") / "line.wav", voiced(1.0))


# --- Imported alignments --------------------------------------------------------

def textgrid(intervals, xmax=1.0):
    items = "".join(f"        intervals [{k}]:\n            xmin = {a}\n            xmax = {b}\n"
                    f"            text = \"{t}\"\n" for k, (a, b, t) in enumerate(intervals, 1))
    return (f'File type = "ooTextFile"\nObject class = "TextGrid"\n\nxmin = 0\nxmax = {xmax}\n'
            f'tiers? <exists>\nsize = 1\nitem []:\n    item [1]:\n        class = "IntervalTier"\n'
            f'        name = "phones"\n        xmin = 0\n        xmax = {xmax}\n'
            f'        intervals: size = {len(intervals)}\n' + items)


def rhubarb_json(cues, duration=None):
    doc = {"mouthCues": [{"start": a, "end": b, "value": v} for a, b, v in cues]}
    if duration is not None:
        doc["metadata"] = {"duration": duration}
    # json.dumps writes NaN/Infinity as Rhubarb-like JSON would carry them
    return json.dumps(doc)


def papagayo(fps="24", frames="24", words=(("hello", 2, 10, ((2, "E"), (6, "O"))),)):
    lines = ["lipsync version 1", "line.wav", str(fps), str(frames), "1", "Voice 1", "hello", "1",
             "hello", "0", "24", str(len(words))]
    for text, a, b, phs in words:
        lines.append(f"{text} {a} {b} {len(phs)}")
        lines += [f"{f} {label}" for f, label in phs]
    return "\n".join(lines) + "\n"


GOOD_TG = [(0, 0.1, "sil"), (0.1, 0.3, "HH"), (0.3, 0.6, "AH0"), (0.6, 1.0, "sil")]

ALIGNMENTS = {
    # name: (file name, content, words the error must contain)
    "tg_nan": ("a.TextGrid", textgrid([(0, 0.1, "sil"), ("nan", 0.3, "HH")]), ["line 20", "not a finite"]),
    "tg_inf": ("a.TextGrid", textgrid([(0, 0.1, "sil"), (0.1, "inf", "HH")]), ["line 21", "not a finite"]),
    "tg_negative": ("a.TextGrid", textgrid([(-0.5, 0.1, "sil"), (0.1, 0.3, "HH")]), ["line 16", "-0.5", "negative"]),
    "tg_reversed": ("a.TextGrid", textgrid([(0, 0.1, "sil"), (0.3, 0.1, "HH")]), ["line 20", "before it starts"]),
    "tg_out_of_order": ("a.TextGrid", textgrid([(0, 0.1, "sil"), (0.5, 0.6, "HH"), (0.2, 0.3, "AH0")]),
                        ["line 24", "0.2", "out of order"]),
    "tg_past_end": ("a.TextGrid", textgrid(GOOD_TG + [(1.0, 1e8, "sil")], 1e8), ["line 33", "1e+08", "past the end"]),
    "tg_cut_short": ("a.TextGrid", textgrid(GOOD_TG)[:-60], ["cut short"]),
    "tg_huge_size": ("a.TextGrid", textgrid(GOOD_TG).replace("size = 4", "size = 99999999999"), ["malformed"]),
    "tg_not_textgrid": ("a.TextGrid", "hello world\n", ["not a Praat TextGrid"]),
    "rh_json_nan": ("a.json", rhubarb_json([(0, 0.2, "X"), (float("nan"), 0.5, "B")]), ["cue 2", "not a finite"]),
    "rh_json_inf": ("a.json", rhubarb_json([(0, float("inf"), "B")]), ["cue 1", "not a finite"]),
    "rh_json_negative": ("a.json", rhubarb_json([(-1, 0.2, "B")]), ["cue 1", "negative"]),
    "rh_json_reversed": ("a.json", rhubarb_json([(0.5, 0.2, "B")]), ["cue 1", "before it starts"]),
    "rh_json_out_of_order": ("a.json", rhubarb_json([(0.5, 0.6, "B"), (0.1, 0.2, "C")]), ["cue 2", "out of order"]),
    "rh_json_past_end": ("a.json", rhubarb_json([(0, 0.2, "X"), (0.2, 1e8, "B")]), ["cue 2", "1e+08", "past the end"]),
    "rh_json_duration_past_end": ("a.json", rhubarb_json([(0, 0.2, "B")], 1e5), ["100000", "past the end"]),
    "rh_json_not_number": ("a.json", rhubarb_json([(0, "soon", "B")]), ["cue 1", "'soon'"]),
    "rh_json_no_cues": ("a.json", '{"cues": []}', ["not a Rhubarb JSON"]),
    "rh_json_cues_not_list": ("a.json", '{"mouthCues": 5}', ["not a Rhubarb JSON"]),
    "rh_json_broken": ("a.json", '{"mouthCues": [', ["not a Rhubarb JSON"]),
    "rh_tsv_nan": ("a.tsv", "0.0\tX\nnan\tB\n", ["line 2", "not a finite"]),
    "rh_tsv_negative": ("a.tsv", "-0.2\tX\n0.3\tB\n", ["line 1", "negative"]),
    "rh_tsv_out_of_order": ("a.tsv", "0.0\tX\n0.5\tB\n0.2\tC\n", ["line 3", "out of order"]),
    "rh_tsv_past_end": ("a.tsv", "0.0\tX\n100000000\tB\n", ["line 2", "1e+08", "past the end"]),
    "rh_tsv_not_time": ("a.tsv", "0.0\tX\nlater\tB\n", ["line 2", "'later'"]),
    "rh_tsv_one_column": ("a.tsv", "0.0\n", ["line 1", "time<TAB>shape"]),
    "rh_tsv_bad_shape": ("a.tsv", "0.0\tQ\n", ["'Q'", "0.000 s"]),
    "pgo_fps_zero": ("a.pgo", papagayo(fps="0"), ["line 3", "frame rate"]),
    "pgo_fps_negative": ("a.pgo", papagayo(fps="-24"), ["line 3", "frame rate"]),
    "pgo_fps_nan": ("a.pgo", papagayo(fps="nan"), ["line 3", "frame rate"]),
    "pgo_negative_frame": ("a.pgo", papagayo(words=(("hello", 2, 10, ((-4, "E"),)),)), ["line 14", "negative"]),
    "pgo_word_reversed": ("a.pgo", papagayo(words=(("hello", 10, 2, ((2, "E"),)),)), ["line 13", "before it starts"]),
    "pgo_out_of_order": ("a.pgo", papagayo(words=(("hello", 2, 10, ((6, "E"), (3, "O"))),)),
                         ["line 15", "out of order"]),
    "pgo_past_end": ("a.pgo", papagayo(words=(("hello", 2, 2400000000, ((2, "E"),)),)),
                     ["line 13", "past the end"]),
    "pgo_length_past_end": ("a.pgo", papagayo(frames="2400000000"), ["line 4", "past the end"]),
    "pgo_cut_short": ("a.pgo", papagayo()[:40], ["cut short"]),
    "pgo_not_papagayo": ("a.pgo", "hello\n", ["not a Papagayo"]),
    "unknown_extension": ("a.srt", "1\n00:00:00,000 --> 00:00:01,000\nhi\n", ["unknown alignment format"]),
}


@pytest.mark.parametrize("name", sorted(ALIGNMENTS))
def test_malformed_alignment_is_named(tmp_path, name):
    fname, content, words = ALIGNMENTS[name]
    path = tmp_path / fname
    path.write_text(content, encoding="utf-8")
    with pytest.raises(LipSyncError) as exc:
        read_alignment(path, audio_duration=1.0)
    msg = str(exc.value)
    for w in words:
        assert w in msg, (w, msg)
    if "unknown phone" not in msg and "unknown alignment" not in msg:
        assert str(path) in msg


@pytest.mark.parametrize("name", ["tg_past_end", "rh_json_past_end", "rh_tsv_nan", "pgo_fps_zero",
                                  "rh_json_inf", "tg_out_of_order"])
def test_malformed_alignment_on_the_command_line(tmp_path, one_second, name):
    fname, content, words = ALIGNMENTS[name]
    path = tmp_path / fname
    path.write_text(content, encoding="utf-8")
    out = tmp_path / "out.json"
    rc, so, se = run_cli("analyze", one_second, "--alignment", path, "--json", out)
    assert_error(rc, so, se, path, *words)
    assert not out.exists()


def test_alignment_within_tolerance_of_the_end_is_kept(tmp_path, one_second):
    """A cue a little past the end (rounding, a last frame) is fine."""
    path = tmp_path / "a.json"
    path.write_text(rhubarb_json([(0.0, 0.3, "X"), (0.3, 0.6, "B"), (0.6, 1.2, "X")], 1.2))
    al = read_alignment(path, audio_duration=1.0)
    assert [p.phone for p in al.phones] == ["K"]
    out = tmp_path / "out.json"
    rc, so, se = run_cli("analyze", one_second, "--alignment", path, "--json", out)
    assert rc == 0, se
    assert json.loads(out.read_text())["phonemes"][0]["phone"] == "K"


def test_alignment_object_past_the_end_is_refused():
    from addon.engine.alignment import AlignedPhone, AlignedWord, Alignment
    from addon.engine.audio import from_samples
    from addon.engine.pipeline import analyze

    snd = from_samples(voiced(1.0), 16000)
    for a, b in ((0.1, 1e8), (float("nan"), 0.2), (-1.0, 0.2)):
        al = Alignment([AlignedWord("bob", 0.1, 0.5, ["B"])], [AlignedPhone("B", a, b, 0)], 1.0)
        with pytest.raises(LipSyncError, match="alignment's phone 1"):
            analyze(snd, alignment=al)


# --- Transcripts -----------------------------------------------------------------

from addon.engine.language.text import decode_text, read_text_file

LINE = "Café Bob bought a map"


@pytest.mark.parametrize("raw", [LINE.encode("utf-8"), b"\xef\xbb\xbf" + LINE.encode("utf-8"),
                                 LINE.encode("utf-16"), b"\xff\xfe" + LINE.encode("utf-16-le"),
                                 b"\xfe\xff" + LINE.encode("utf-16-be")],
                         ids=["utf8", "utf8-bom", "utf16", "utf16le-bom", "utf16be-bom"])
def test_transcript_encodings_read_without_a_note(raw):
    assert decode_text(raw) == (LINE, [])


@pytest.mark.parametrize("enc", ["cp1252", "latin-1"])
def test_windows_transcript_read_with_a_note(tmp_path, enc):
    path = tmp_path / "line.txt"
    path.write_bytes((LINE + " \u2019" if enc == "cp1252" else LINE).encode(enc))
    text, notes = read_text_file(path)
    assert text.startswith(LINE)
    assert len(notes) == 1 and str(path) in notes[0] and "not UTF-8" in notes[0]


@pytest.mark.parametrize("raw, words", [
    (b"\x00\x01\x02\x00binary", ["not a text file"]),
    (b"\xff\xfe\x00\xd8", ["UTF-16-LE", "byte-order mark"]),
], ids=["binary", "bad-utf16"])
def test_unreadable_transcript_is_named(tmp_path, raw, words):
    path = tmp_path / "line.txt"
    path.write_bytes(raw)
    with pytest.raises(LipSyncError) as exc:
        read_text_file(path)
    for w in [str(path)] + words:
        assert w in str(exc.value)


def test_transcript_path_missing_or_folder(tmp_path):
    with pytest.raises(LipSyncError, match="not found"):
        read_text_file(tmp_path / "nope.txt")
    with pytest.raises(LipSyncError, match="is a folder"):
        read_text_file(tmp_path)


def test_latin1_transcript_on_the_command_line(tmp_path):
    path = tmp_path / "line.txt"
    path.write_bytes("Bob bought a map, café".encode("latin-1"))
    out = tmp_path / "out.json"
    rc, so, se = run_cli("analyze", FIXTURES / "bob_map.wav", "--transcript", path, "--json", out)
    assert rc == 0, se
    assert "Traceback" not in se
    assert any(ln.startswith("warning:") and str(path) in ln and "not UTF-8" in ln for ln in se.splitlines()), se
    doc = json.loads(out.read_text())
    assert any("not UTF-8" in n for n in doc["notes"])
    assert [w["word"] for w in doc["words"]][:4] == ["bob", "bought", "a", "map"]


@pytest.mark.parametrize("content, words", [
    (b"", ["transcript is empty", "line.txt"]),
    (b"  \n\t\n", ["transcript is empty", "line.txt"]),
    (b"... !? -- ,", ["no spoken words"]),
    (b"[laughs] (sighs)", ["no spoken words"]),
    (b"\x00\x00\x00\x00", ["not a text file", "line.txt"]),
], ids=["empty", "blank", "punctuation", "stage-directions", "binary"])
def test_unusable_transcript_on_the_command_line(tmp_path, content, words):
    path = tmp_path / "line.txt"
    path.write_bytes(content)
    rc, so, se = run_cli("analyze", FIXTURES / "bob_map.wav", "--transcript", path, "--json", tmp_path / "o.json")
    assert_error(rc, so, se, *words)


@pytest.mark.parametrize("where", ["missing", "folder"])
def test_transcript_missing_or_folder_on_the_command_line(tmp_path, where):
    path = tmp_path / "nope.txt" if where == "missing" else tmp_path
    rc, so, se = run_cli("analyze", FIXTURES / "bob_map.wav", "--transcript", path, "--json", tmp_path / "o.json")
    assert_error(rc, so, se, path, "not found" if where == "missing" else "folder")


# --- Outputs ---------------------------------------------------------------------

@pytest.mark.parametrize("case", ["missing-folder", "folder", "under-a-file", "is-the-audio", "same-json-csv"])
def test_unusable_output_is_refused_before_the_work(tmp_path, case):
    audio = tmp_path / "line.wav"
    audio.write_bytes((FIXTURES / "bob_map.wav").read_bytes())
    before = audio.read_bytes()
    (tmp_path / "afile").write_text("keep me")
    args, words = {
        "missing-folder": (["--json", tmp_path / "nope" / "o.json"], ["does not exist", tmp_path / "nope"]),
        "folder": (["--csv", tmp_path], ["is a folder", "--csv"]),
        "under-a-file": (["--json", tmp_path / "afile" / "o.json"], ["is not a folder"]),
        "is-the-audio": (["--json", audio], ["is also an input"]),
        "same-json-csv": (["--json", tmp_path / "o.x", "--csv", tmp_path / "o.x"], ["same file"]),
    }[case]
    rc, so, se = run_cli("analyze", audio, "--text", "Bob bought a map.", *args)
    assert_error(rc, so, se, *words)
    assert audio.read_bytes() == before
    assert (tmp_path / "afile").read_text() == "keep me"
    assert not (tmp_path / "o.x").exists()


def test_read_only_output_is_refused(tmp_path, monkeypatch):
    from addon.engine import cli

    out = tmp_path / "o.json"
    out.write_text("old")
    monkeypatch.setattr(os, "access", lambda *a, **k: False)  # as if read-only (root may write anything)
    rc = cli.main(["analyze", str(FIXTURES / "bob_map.wav"), "--text", "Bob", "--json", str(out)])
    assert rc == 1
    assert out.read_text() == "old"
    new = tmp_path / "new.json"
    assert cli.main(["analyze", str(FIXTURES / "bob_map.wav"), "--text", "Bob", "--json", str(new)]) == 1
    assert not new.exists()


def test_read_only_output_message(tmp_path, monkeypatch, capsys):
    from addon.engine import cli

    monkeypatch.setattr(os, "access", lambda *a, **k: False)
    cli.main(["analyze", str(FIXTURES / "bob_map.wav"), "--text", "Bob", "--json", str(tmp_path / "n.json")])
    err = capsys.readouterr().err
    assert f"error: cannot write --json output {tmp_path / 'n.json'}: no permission to write in {tmp_path}" in err


# --- Words the aligner cannot use -------------------------------------------------

def test_skipped_words_are_named_on_stderr_and_in_the_notes(tmp_path):
    out = tmp_path / "o.json"
    rc, so, se = run_cli("analyze", FIXTURES / "bob_map.wav", "--text", "Bob 😀 bought 你好 a map", "--json", out)
    assert rc == 0, se
    warn = [ln for ln in se.splitlines() if ln.startswith("warning:")]
    assert len(warn) == 1 and "'😀' (an emoji" in warn[0] and "'你好' (not in the Latin alphabet: CJK)" in warn[0]
    doc = json.loads(out.read_text())
    assert [w["word"] for w in doc["words"]] == ["bob", "bought", "a", "map"]
    assert any("2 words of the transcript left out" in n and "你好" in n for n in doc["notes"])


@pytest.mark.parametrize("text, words", [
    ("Привет мир", ["'Привет' (not in the Latin alphabet: Cyrillic)", "'мир'"]),
    ("你好 😀", ["CJK", "emoji"]),
    ("Ελλάδα", ["Greek"]),
])
def test_transcript_with_no_usable_word_says_why(tmp_path, text, words):
    rc, so, se = run_cli("analyze", FIXTURES / "bob_map.wav", "--text", text, "--json", tmp_path / "o.json")
    assert_error(rc, so, se, "no words the aligner can use", *words)


def test_accented_latin_numbers_and_symbols_are_spoken_not_skipped(tmp_path):
    from addon.engine.language.text import normalize, skipped_words

    text = "Zoë paid $5 for 2 maps & 1 café, at 10:30 (sighs) \u201cokay\u201d"
    assert skipped_words(text) == []
    spoken = [w.text for w in normalize(text)]
    assert spoken[:3] == ["zoë", "paid", "five"] and "and" in spoken and "café" in spoken


# --- Audio -------------------------------------------------------------------------

def bob_samples():
    with wave.open(str(FIXTURES / "bob_map.wav")) as w:
        assert w.getsampwidth() == 2 and w.getnchannels() == 1
        return np.frombuffer(w.readframes(w.getnframes()), "<i2") / 32768.0, w.getframerate()


@pytest.fixture(scope="module")
def bob_reference():
    from addon.engine.pipeline import analyze

    return analyze(str(FIXTURES / "bob_map.wav"), "Bob bought a map.")


@pytest.mark.parametrize("rate, width, channels", [
    (8000, 1, 1), (11025, 2, 2), (22050, 3, 1), (32000, 2, 1), (44100, 2, 2), (48000, 4, 1), (96000, 2, 6),
])
def test_any_rate_width_and_channel_count(tmp_path, bob_reference, rate, width, channels):
    """The same line at other rates, sample widths and channel counts gives the same words at the same times."""
    from addon.engine.pipeline import analyze

    from addon.engine.audio import resample

    x, r0 = bob_samples()
    path = write_wav(tmp_path / "line.wav", resample(x, r0, rate), rate, width, channels)
    result = analyze(str(path), "Bob bought a map.")
    assert [w.text for w in result.alignment.words] == ["bob", "bought", "a", "map"]
    assert not any(w.estimated for w in result.alignment.words)
    assert result.duration == pytest.approx(bob_reference.duration, abs=0.01)
    if rate >= r0 and width >= 2:   # the same sound: the same timings
        for w, ref in zip(result.alignment.words, bob_reference.alignment.words):
            assert abs(w.start - ref.start) < 0.02, (w, ref)
            assert abs(w.end - ref.end) < 0.1, (w, ref)  # the last /p/'s release into silence varies


def _audio_case(tmp_path, case):
    p = tmp_path / "line.wav"
    raw = (FIXTURES / "bob_map.wav").read_bytes()
    if case == "missing":
        return tmp_path / "nope.wav", ["audio file not found"]
    if case == "folder":
        (tmp_path / "take.wav").mkdir()
        return tmp_path / "take.wav", ["is a folder"]
    if case == "empty":
        p.write_bytes(b"")
        return p, ["empty (0 bytes)"]
    if case == "header-only":
        p.write_bytes(raw[:30])
        return p, ["cannot read audio file", "it is a WAV file", "cannot be decoded"]
    if case == "text":
        p.write_text("this is not audio")
        return p, ["cannot read audio file", "it is a text file, not audio. Use WAV, FLAC, Ogg"]
    if case == "random":
        p.write_bytes(np.random.default_rng(1).bytes(4000))
        return p, ["cannot read audio file"]
    if case == "ogg":
        p = tmp_path / "line.ogg"
        p.write_bytes(b"OggS\x00\x02" + bytes(200))
        return p, ["it is an Ogg file (Vorbis or Opus)", "cannot be decoded"]
    if case == "m4a":
        p = tmp_path / "line.m4a"
        p.write_bytes(b"\x00\x00\x00\x20ftypM4A " + bytes(200))
        return p, ["MP4/M4A"]
    if case == "silence":
        return write_wav(p, np.zeros(16000)), ["holds no speech", "-120 dBFS"]
    if case == "hum":
        return write_wav(p, 1e-4 * np.sin(np.arange(32000) / 10)), ["holds no speech"]
    if case == "noise":
        return write_wav(p, np.random.default_rng(0).uniform(-0.5, 0.5, 32000)), ["holds no speech"]
    if case == "too-short":
        return write_wav(p, voiced(0.05)), ["too short", "0.050 s"]
    if case == "one-sample":
        return write_wav(p, np.array([0.1])), ["too short", "0.000 s"]
    raise AssertionError(case)


AUDIO_ERRORS = ["missing", "folder", "empty", "header-only", "text", "random", "ogg", "m4a", "silence",
                "hum", "noise", "too-short", "one-sample"]


@pytest.mark.parametrize("case", AUDIO_ERRORS)
def test_unusable_audio_on_the_command_line(tmp_path, case):
    path, words = _audio_case(tmp_path, case)
    rc, so, se = run_cli("analyze", path, "--text", "Bob bought a map.", "--json", tmp_path / "o.json")
    line = assert_error(rc, so, se, *words)
    assert ".." not in line
    if case not in ("silence", "hum", "noise"):
        assert str(path) in line
    assert not (tmp_path / "o.json").exists()


def test_truncated_wav_is_read_with_a_warning(tmp_path):
    raw = (FIXTURES / "bob_map.wav").read_bytes()
    path = tmp_path / "cut.wav"
    path.write_bytes(raw[: len(raw) * 3 // 4])
    out = tmp_path / "o.json"
    rc, so, se = run_cli("analyze", path, "--text", "Bob bought a map.", "--json", out)
    assert rc == 0, se
    assert "Traceback" not in se and "PraatWarning" not in se
    assert any(ln.startswith("warning:") and "cut short" in ln and str(path) in ln for ln in se.splitlines()), se
    doc = json.loads(out.read_text())
    assert any("cut short" in n for n in doc["notes"])
    assert [w["word"] for w in doc["words"]] == ["bob", "bought", "a", "map"]


def test_clipped_audio_still_lip_syncs(tmp_path):
    """Hard-clipped speech (every sample at full scale) is still speech."""
    from addon.engine.pipeline import analyze

    x, r0 = bob_samples()
    path = write_wav(tmp_path / "loud.wav", np.clip(x * 50, -1, 1), r0)
    result = analyze(str(path), "Bob bought a map.")
    assert [w.text for w in result.alignment.words] == ["bob", "bought", "a", "map"]
    assert np.all((result.curves >= 0) & (result.curves <= 1))


# --- Presets and viseme-set files ----------------------------------------------------

PRESETS = {
    "not-json": (b"{nope", ["(file)", "not valid JSON", "line 1"]),
    "list": (b"[1, 2]", ["(top level)", "JSON object"]),
    "gain-text": (b'{"name": "x", "gain": "loud"}', ["'gain'", "'loud'"]),
    "gain-nan": (b'{"name": "x", "gain": NaN}', ["'gain'", "nan"]),
    "gain-inf": (b'{"name": "x", "gain": Infinity}', ["'gain'", "inf"]),
    "gain-negative": (b'{"name": "x", "gain": -3}', ["'gain'", "-3"]),
    "unknown-field": (b'{"name": "x", "gian": 1}', ["'gian'", "not a preset field"]),
    "bad-base": (b'{"name": "x", "base": "grumpy"}', ["'base'", "'grumpy'", "not a preset"]),
    "base-number": (b'{"name": "x", "base": 5}', ["'base'", "name of another preset"]),
    "base-missing-file": (b'{"name": "x", "base": "/nonexistent/b.json"}', ["'base'", "/nonexistent/b.json",
                                                                            "does not exist"]),
    "base-itself": (b'{"name": "x", "base": "p.json"}', ["'base'", "chain is too long"]),
    "binary": (b"\x00\xff\xfe\x01", ["not UTF-8"]),
    "latin-1": ('{"name": "caf\xe9"}'.encode("latin-1"), ["not UTF-8", "byte 13"]),
}


def test_preset_base_file_beside_the_preset(tmp_path):
    from addon.engine import presets

    (tmp_path / "b.json").write_text('{"name": "b", "base": "angry", "gain": 1.5}')
    (tmp_path / "p.json").write_text('{"name": "p", "base": "b.json"}')
    p = presets.load(tmp_path / "p.json")
    assert p.name == "p" and p.gain == 1.5


RANGE = '{"range": [0, 0.5, 1]}'
VISEME_SETS = {
    "empty-file": (b"", ["(file)", "not valid JSON"]),
    "list": (b"[1]", ["(top level)", "JSON object"]),
    "name-number": (b'{"name": 5}', ["'name'"]),
    "visemes-list": (b'{"name": "v", "visemes": [], "phonemes": {}}', ["'visemes'"]),
    "no-visemes": (b'{"name": "v", "visemes": {}, "phonemes": {}}', ["'visemes'", "empty"]),
    "range-short": ((b'{"name": "v", "visemes": {"A": {"range": [1, 0.5]}}, "phonemes": {"AA": "A"}}'),
                    ["'visemes.A.range'", "three numbers"]),
    "range-nan": ((b'{"name": "v", "visemes": {"A": {"range": [NaN, 0.5, 1]}}, "phonemes": {"AA": "A"}}'),
                  ["'visemes.A.range'", "nan"]),
    "unknown-viseme": (('{"name": "v", "visemes": {"A": ' + RANGE + '}, "phonemes": {"AA": "B"}}').encode(),
                       ["'phonemes.AA'", "'B'"]),
    "phones-missing": (('{"name": "v", "visemes": {"A": ' + RANGE + '}, "phonemes": {"AA": "A"}}').encode(),
                       ["'phonemes'", "does not map", "AE"]),
    "binary": (b"\xff\xfe\x00", ["not UTF-8"]),
}


DATA_FILES = {**{("--emotion", "p.json", case): v for case, v in PRESETS.items()},
              **{("--viseme-set", "v.json", case): v for case, v in VISEME_SETS.items()}}


@pytest.mark.parametrize("flag, name, case", sorted(DATA_FILES))
def test_malformed_data_file_names_file_and_field(tmp_path, flag, name, case):
    content, words = DATA_FILES[flag, name, case]
    path = tmp_path / name
    path.write_bytes(content)
    rc, so, se = run_cli("analyze", FIXTURES / "bob_map.wav", "--text", "Bob", flag, path,
                         "--json", tmp_path / "o.json", cwd=tmp_path)
    assert_error(rc, so, se, path, *words)


@pytest.mark.parametrize("flag, value, words", [
    ("--emotion", "grumpy", ["grumpy:", "not a preset"]),
    ("--viseme-set", "nope", ["nope:", "not a viseme set"]),
    ("--emotion", "/nonexistent/p.json", ["does not exist"]),
    ("--fps", "0", ["out of range"]),
    ("--fps", "nan", ["frame rate"]),
    ("--fps", "30/0", ["not a number"]),
    ("--dictionary", "/nonexistent.dict", ["not found"]),
])
def test_bad_option_values(tmp_path, flag, value, words):
    rc, so, se = run_cli("analyze", FIXTURES / "bob_map.wav", "--text", "Bob", flag, value,
                         "--json", tmp_path / "o.json")
    assert_error(rc, so, se, *words)


# --- Transcripts that do not fit the audio ---------------------------------------------

def test_transcript_much_shorter_than_the_speech_warns(tmp_path):
    out = tmp_path / "o.json"
    rc, so, se = run_cli("analyze", FIXTURES / "bob_map.wav", "--text", "Bob", "--json", out)
    assert rc == 0, se
    warn = [ln for ln in se.splitlines() if ln.startswith("warning:")]
    assert len(warn) == 1 and "of speech not in the transcript" in warn[0], se
    doc = json.loads(out.read_text())
    # The speech the transcript leaves out is recognised and animated, and listed.
    assert [w["word"] for w in doc["words"] if not w.get("recognized")] == ["bob"]
    assert len(doc["words"]) > 1 and doc["unscripted"]
    assert any("not in the transcript" in n for n in doc["notes"])


def test_complete_transcript_gives_no_warning(tmp_path):
    rc, so, se = run_cli("analyze", FIXTURES / "bob_map.wav", "--transcript", FIXTURES / "bob_map.txt",
                         "--json", tmp_path / "o.json")
    assert rc == 0 and "warning" not in se, se


def test_transcript_far_longer_than_the_audio_is_an_error(tmp_path):
    """Nothing fits: most of the phonemes cannot be aligned to the audio at all."""
    rc, so, se = run_cli("analyze", FIXTURES / "bob_map.wav", "--text", "Bob bought a map. " * 8,
                         "--json", tmp_path / "o.json")
    assert_error(rc, so, se, "could not be aligned", "does the transcript belong to this recording")


def test_another_lines_transcript_is_animated_with_one_warning(tmp_path):
    """A transcript whose sounds fit the audio poorly may be another line's: the line is animated with
    the words given, and one warning asks."""
    rc, so, se = run_cli("analyze", FIXTURES / "bob_map.wav", "--text", "Maybe Bobby makes pumpkin pie, baby.",
                         "--json", tmp_path / "o.json")
    assert rc == 0 and "Traceback" not in se, se
    warnings = [line for line in se.splitlines() if line.startswith("warning:")]
    assert len(warnings) == 1 and "fit the audio poorly" in warnings[0] and "belong to this recording" in warnings[0]
    doc = json.loads((tmp_path / "o.json").read_text())
    assert [w["word"] for w in doc["words"]] == ["maybe", "bobby", "makes", "pumpkin", "pie", "baby"]


def test_numbers_are_spoken(tmp_path):
    from addon.engine.pipeline import analyze

    result = analyze(str(FIXTURES / "bob_map.wav"), "Bob bought 1 map.")
    assert [w.text for w in result.alignment.words] == ["bob", "bought", "one", "map"]
    assert not result.warnings


def test_aligner_running_out_of_memory_is_an_error_not_a_traceback(tmp_path, monkeypatch, capsys):
    """A worker killed by the system (a very long recording) is reported in one line."""
    from concurrent.futures.process import BrokenProcessPool

    from addon.engine import cli
    from addon.engine.alignment import transcript

    def killed(*a, **k):
        raise BrokenProcessPool("A process in the process pool was terminated abruptly")

    monkeypatch.setattr(transcript, "align", killed)
    rc = cli.main(["analyze", str(FIXTURES / "bob_map.wav"), "--text", "Bob", "--json", str(tmp_path / "o.json")])
    err = capsys.readouterr().err
    assert rc == 1 and "Traceback" not in err
    assert "error: the aligner ran out of memory" in err and "split the recording" in err


@pytest.mark.parametrize("fit,warned", [(-100.0, True), (-70.0, True), (-55.0, False), (-20.0, False)])
def test_a_transcript_that_fits_its_sound_poorly_is_warned_of_never_refused(fit, warned):
    """Five words of four phonemes, each fitting its sound at ``fit`` per frame: below FIT_WARNED the line
    is animated with a warning; squeezed phonemes (fast speech) are no evidence either way."""
    from addon.engine.alignment.core import FIT_WARNED, check_transcript_matches
    from addon.engine.alignment.model import AlignedPhone, AlignedWord, Alignment

    def alignment(source="cmudict"):
        phones, t = [], 0.0
        for k in range(20):
            phones.append(AlignedPhone("AH", t, t + 0.03, k // 4))      # every phone at the shortest length
            t += 0.03
        words = [AlignedWord(f"w{i}", phones[4 * i].start, phones[4 * i + 3].end, ["AH"] * 4, source, fit=fit)
                 for i in range(5)]
        return Alignment(words, phones, t)

    al = alignment()
    check_transcript_matches(al)
    assert bool(al.warnings) == warned == (fit < FIT_WARNED)
    if warned:
        assert al.warnings == [f"the transcript's sounds fit the audio poorly ({fit:.0f} per frame; a transcript said "
                               f"as written fits above {FIT_WARNED:.0f}): does it belong to this recording? "
                               "Animated with its words"]
    # Lines not in English, and words read from IPA, are not judged so: their phones are the nearest English ones.
    for other in (alignment(), alignment("ipa")):
        check_transcript_matches(other, judge_fit=other.words[0].source == "ipa")
        assert other.warnings == []
