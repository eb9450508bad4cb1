import json
import subprocess
import sys

import numpy as np
import pytest

from conftest import FIXTURES, ROOT, SAMPLE, write_wav
from addon.engine import audio as audio_mod
from addon.engine.alignment import AlignSettings
from addon.engine.errors import AlignmentError, AudioError, LipSyncError, TranscriptError
from addon.engine.alignment import align_file
from addon.engine.pipeline import analyze
from addon.engine.settings import LineSettings


def test_every_word_aligned_in_order():
    text = (FIXTURES / "bob_map.txt").read_text()
    al = align_file(FIXTURES / "bob_map.wav", text)
    assert [w.text for w in al.words] == ["bob", "bought", "a", "map"]
    assert not any(w.estimated for w in al.words)
    starts = [p.start for p in al.phones]
    assert starts == sorted(starts)
    assert [p.phone for p in al.phones][:3] == ["B", "AA", "B"]
    # The last word is not dropped and ends inside the audio.
    assert al.words[-1].end <= al.duration and al.words[-1].end > al.words[-2].end


def test_alignment_finds_the_speech_not_the_silence(tmp_path):
    snd = audio_mod.load(FIXTURES / "bob_map.wav")
    pad = np.zeros(int(snd.rate * 1.5), np.float32)
    write_wav(tmp_path / "padded.wav", np.concatenate([pad, snd.samples, pad]))
    al = align_file(tmp_path / "padded.wav", "Bob bought a map.")
    plain = align_file(FIXTURES / "bob_map.wav", "Bob bought a map.")
    assert al.words[0].start > 1.3
    shift = np.array([a.start - b.start for a, b in zip(al.phones, plain.phones)])
    assert np.median(np.abs(shift - 1.5)) < 0.03


def test_long_pause_and_chunking(fixtures):
    text = "First part of the line. And the second part after a long pause."
    al = align_file(fixtures / "pause.wav", text, settings=AlignSettings(max_chunk=2.0))
    assert len(al.words) == 13 and [w.text for w in al.words][-1] == "pause"
    gap = al.words[5].start - al.words[4].end
    assert gap > 0.5          # the pause is found between "line" and "and"
    assert al.n_estimated == 0


def test_sample_with_every_format(tmp_path):
    text = (SAMPLE / "hello.txt").read_text()
    snd = audio_mod.load(SAMPLE / "hello.wav")
    stereo = np.stack([snd.samples, snd.samples * 0.5], axis=1).reshape(-1)
    write_wav(tmp_path / "stereo44k.wav", np.interp(np.arange(0, len(snd.samples), 16000 / 44100),
                                                   np.arange(len(snd.samples)), snd.samples), 44100)
    write_wav(tmp_path / "stereo.wav", stereo, 16000, channels=2)
    for f in ("stereo44k.wav", "stereo.wav"):
        r = analyze(tmp_path / f, text, LineSettings.of(fps=24))
        assert len(r.alignment.words) == 16 and r.alignment.n_estimated == 0


def test_missing_unreadable_empty_audio(tmp_path):
    with pytest.raises(AudioError, match="not found"):
        analyze(tmp_path / "nope.wav", "hello")
    bad = tmp_path / "bad.wav"
    bad.write_bytes(b"RIFF this is not audio at all" * 10)
    with pytest.raises(AudioError, match="cannot read audio"):
        analyze(bad, "hello")
    empty = tmp_path / "empty.wav"
    empty.write_bytes(b"")
    with pytest.raises(AudioError, match="empty"):
        analyze(empty, "hello")


def test_silence_is_a_clear_error(tmp_path):
    write_wav(tmp_path / "silence.wav", np.zeros(32000))
    with pytest.raises(AudioError, match="no speech"):
        analyze(tmp_path / "silence.wav", "hello there")


def test_empty_transcript_is_a_clear_error():
    with pytest.raises(TranscriptError, match="empty"):
        analyze(FIXTURES / "bob_map.wav", "  ")


def test_mismatched_transcript_is_caught_or_marked():
    text = ("The quick brown fox jumps over the lazy dog while seven wizards "
            "quietly juggle extraordinary luminous pineapples near the harbour")
    try:
        r = analyze(FIXTURES / "bob_map.wav", text)
    except AlignmentError as exc:
        assert "transcript" in str(exc)
    else:
        # Twenty words cannot fit into 1.7 s of four words: most are estimated.
        assert r.alignment.n_estimated > 0


def test_cli_json_contract(tmp_path):
    out, csv_out = tmp_path / "o.json", tmp_path / "o.csv"
    cmd = [sys.executable, "-m", "addon", "analyze", str(SAMPLE / "hello.wav"), "--transcript",
           str(SAMPLE / "hello.txt"), "--viseme-set", "oculus", "--emotion", "happy",
           "--coarticulation", "rules", "--fps", "29.97", "--json", str(out), "--csv", str(csv_out)]
    run = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    doc = json.loads(out.read_text())
    assert doc["fps"] == pytest.approx(30000 / 1001)
    assert doc["viseme_set"] == "oculus" and doc["visemes"][0] == "sil"
    assert {"word", "start", "end", "estimated"} <= set(doc["words"][0])
    assert {"phone", "start", "end", "word_index", "pitch_hz", "intensity_db", "weight",
            "estimated"} <= set(doc["phonemes"][0])
    frames = np.array(doc["frames"]["weights"])
    assert frames.shape == (len(doc["frames"]["time"]), 15)
    assert frames.min() >= 0 and frames.max() <= 1
    assert doc["duration"] == pytest.approx(6.33, abs=0.05)
    lines = csv_out.read_text().splitlines()
    assert lines[0].startswith("frame,time,sil,PP") and len(lines) == len(doc["frames"]["time"]) + 1


def test_cli_errors_are_one_line(tmp_path):
    run = subprocess.run([sys.executable, "-m", "addon", "analyze", str(tmp_path / "x.wav"), "--text", "hi",
                          "--json", str(tmp_path / "o.json")], cwd=ROOT, capture_output=True, text=True)
    assert run.returncode == 1
    assert run.stderr.startswith("error: audio file not found") and "Traceback" not in run.stderr
    run = subprocess.run([sys.executable, "-m", "addon", "analyze", str(FIXTURES / "bob_map.wav"),
                          "--emotion", "furious", "--text", "Bob", "--json", str(tmp_path / "o.json")],
                         cwd=ROOT, capture_output=True, text=True)
    assert run.returncode == 1 and "built-in presets" in run.stderr


def test_imported_alignment_skips_the_aligner(tmp_path):
    tsv = tmp_path / "cues.tsv"
    tsv.write_text("0.00\tX\n0.30\tA\n0.45\tD\n0.80\tX\n")
    r = analyze(FIXTURES / "bob_map.wav", None, LineSettings.of(viseme_set="rhubarb", fps=100), alignment=tsv)
    a = r.viseme_set.index("A")
    k = int(0.37 * 100)
    assert r.curves[k, a] > 0.85


def test_bad_fps():
    with pytest.raises(LipSyncError, match="frame rate"):
        analyze(FIXTURES / "bob_map.wav", "Bob bought a map", LineSettings.of(fps="fast"))


def _two_lines(tmp_path):
    """The shipped line, a pause, then the bob/map fixture: one clip of ~9.5 s."""
    a = audio_mod.load(SAMPLE / "hello.wav").samples
    b = audio_mod.load(FIXTURES / "bob_map.wav").samples
    write_wav(tmp_path / "two.wav", np.concatenate([a, np.zeros(8000, np.float32), b]))
    return tmp_path / "two.wav", (SAMPLE / "hello.txt").read_text() + " " + (FIXTURES / "bob_map.txt").read_text()


def _many_lines(tmp_path, times=2):
    """Every fixture line with a transcript, then again: one clip of ~33 s."""
    lines = [(SAMPLE / "hello.wav", (SAMPLE / "hello.txt").read_text()),
             (FIXTURES / "pause.wav", "First part of the line. And the second part after a long pause."),
             (FIXTURES / "bob_map.wav", (FIXTURES / "bob_map.txt").read_text()),
             (FIXTURES / "fast_bilabials.wav", (FIXTURES / "fast_bilabials.txt").read_text())] * times
    gap = np.zeros(6400, np.float32)
    samples = np.concatenate([x for path, _ in lines for x in (audio_mod.load(path).samples, gap)])
    write_wav(tmp_path / "long.wav", samples)
    return tmp_path / "long.wav", " ".join(t for _, t in lines)


@pytest.mark.parametrize("lines, parts", [("two", 2), ("many", 4)])
def test_long_clip_aligned_in_pieces_matches_one_pass(tmp_path, monkeypatch, lines, parts):
    from addon.engine.alignment import pieces

    # The ~33 s clip's fast bilabials leave the cut pass that scores every
    # third frame without a path; the one scoring every second frame cuts it.
    path, text = _two_lines(tmp_path) if lines == "two" else _many_lines(tmp_path)
    one = align_file(path, text, settings=AlignSettings(split_above=1e9, stream_above=1e9))
    made = []
    choose = pieces._choose_cuts
    monkeypatch.setattr(pieces, "_choose_cuts", lambda *a: made.append(choose(*a)) or made[-1])
    split = align_file(path, text, settings=AlignSettings(split_above=1.0, workers=2))
    assert len(made) == 1 and len(made[0]) == parts - 1
    assert [w.text for w in split.words] == [w.text for w in one.words]
    assert split.n_estimated == 0 and one.n_estimated == 0
    starts = np.array([p.start for p in split.phones]) - np.array([p.start for p in one.phones])
    assert np.median(np.abs(starts)) <= 0.011 and np.mean(np.abs(starts) <= 0.04) >= 0.9
    if lines == "two":  # the last four words are bob/map, after the pause
        assert split.words[-4].start > audio_mod.load(SAMPLE / "hello.wav").duration


def test_pieces_are_an_even_number_of_about_the_piece_length():
    from addon.engine.alignment.pieces import piece_count

    settings = AlignSettings(piece=7.0)
    assert [piece_count(d, settings) for d in (10.5, 20.0, 26.0, 45.0, 89.0)] == [2, 2, 4, 6, 12]


def _words(pauses: dict[int, int], n: int = 10, length: int = 40) -> list[tuple[int, int]]:
    """Frames of ``n`` words of ``length`` frames, 5 frames apart except
    ``pauses[i]`` frames after word i."""
    segs, t = [], 0
    for i in range(n):
        segs.append((t, t + length))
        t += length + pauses.get(i, 5)
    return segs


def test_cuts_go_in_a_real_pause_near_each_share_of_the_clip():
    from addon.engine.alignment.pieces import _choose_cuts

    # Ten words of 40 frames; pauses of 5 frames, but 25 after word 3 and
    # 15 after word 7 (both within half a piece of the quarter marks).
    segs = _words({2: 25, 6: 15})
    cuts = _choose_cuts(segs, 4, segs[-1][1])
    assert [k for k, _ in cuts] == [3, 5, 7]
    assert cuts[0][1] == pytest.approx((segs[2][1] + segs[3][0]) / 2 * 0.01)
    assert all(segs[k - 1][1] * 0.01 < c < segs[k][0] * 0.01 for k, c in cuts)
    # At least two words a piece; a clip of three words is not cut at all.
    assert len(_choose_cuts(segs[:5], 4, segs[4][1])) == 1 and _choose_cuts(segs[:3], 4, segs[2][1]) is None


def test_cuts_keep_the_pieces_even_rather_than_chase_the_widest_pause():
    from addon.engine.alignment.pieces import _choose_cuts

    # A 100-frame pause after word 2 and a 15-frame one after word 4, both
    # within half a piece of the clip's middle (frame 275).  The nearer, even
    # cut wins: the wide pause would leave pieces of 3 and 7 words.
    segs = _words({2: 100, 4: 15})
    assert [k for k, _ in _choose_cuts(segs, 2, segs[-1][1])] == [5]
    # Silence costs the passes as much as speech: after 400 frames of it, the
    # clip's middle lies before the words' middle and the wide pause is cut.
    late = [(a + 400, b + 400) for a, b in segs]
    assert [k for k, _ in _choose_cuts(late, 2, late[-1][1])] == [3]


def test_chunked_fallback_when_the_one_pass_fails(tmp_path, monkeypatch):
    from addon.engine.alignment import core as align_mod

    path, text = _two_lines(tmp_path)
    one = align_file(path, text)
    monkeypatch.setattr(align_mod, "_whole", lambda *a, **k: ("failed", 0, "forced for the test"))
    al = align_file(path, text, settings=AlignSettings(split_above=1e9, max_chunk=3.0))
    assert [w.text for w in al.words] == [w.text for w in one.words]
    assert al.n_estimated == 0
    err = np.abs(np.array([w.start for w in al.words]) - np.array([w.start for w in one.words]))
    assert np.median(err) <= 0.03



def test_long_clip_aligned_window_by_window_matches_one_pass(tmp_path, monkeypatch):
    """Long recordings are aligned in windows of bounded length (bounded
    memory); small windows on a ~33 s clip take the same code path."""
    from addon.engine.alignment import stream

    path, text = _many_lines(tmp_path)
    one = align_file(path, text, settings=AlignSettings(stream_above=1e9, split_above=1e9))
    windows = []
    walk = stream._walk

    def spy(*args):
        placed, word = walk(*args)
        windows.extend(placed)
        return placed, word

    monkeypatch.setattr(stream, "_walk", spy)
    reported = []
    al = align_file(tmp_path / "long.wav", text, settings=AlignSettings(stream_above=5.0, window=6.0, workers=1),
                    progress=reported.append)
    assert len(windows) >= 4  # the clip was walked in several windows from both ends
    # Progress moves while the windows are walked, never backwards.
    assert reported == sorted(reported) and reported[-1] == 1.0
    assert len({round(f, 6) for f in reported if 0 < f < 0.6}) >= 3
    assert [w.text for w in al.words] == [w.text for w in one.words]
    assert one.n_estimated == 0 and al.n_estimated == 0
    starts = [p.start for p in al.phones]
    assert starts == sorted(starts)
    assert all(p.end > p.start for p in al.phones)
    assert all(a.end <= b.start + 1e-9 for a, b in zip(al.words, al.words[1:]))
    err = np.abs(np.array([w.start for w in al.words]) - np.array([w.start for w in one.words]))
    assert np.median(err) <= 0.011 and np.mean(err <= 0.05) >= 0.9
    # The two sides walked in two worker processes (where fork is available)
    # give the same alignment.
    monkeypatch.setattr(stream, "_walk", walk)
    two = align_file(tmp_path / "long.wav", text, settings=AlignSettings(stream_above=5.0, window=6.0, workers=2))
    assert [(p.phone, p.start, p.end) for p in two.phones] == [(p.phone, p.start, p.end) for p in al.phones]
