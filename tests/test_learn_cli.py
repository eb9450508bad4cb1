"""``learn`` on the command line, as a user runs it on face-capture CSVs.

The captures are synthesized: eight ARKit mouth channels made by the angry
preset with the ARKit set's own poses through the engine's synthesis path,
plus noise, on three recordings.  Learning starts from neutral with the
same poses, so the starting preset already predicts every channel well: a
starting correlation near 0 would mean the baseline lost a channel.
"""

import io
import json

import numpy as np
import pytest

from addon.engine import audio as audio_mod
from addon.engine import learning, pipeline, presets, visemes
from addon.engine.cli import main as cli_main

from conftest import FIXTURES, SAMPLE, write_wav

CHANNELS = ["jawOpen", "mouthClose", "mouthFunnel", "mouthPucker", "mouthLowerDownLeft", "mouthLowerDownRight",
            "mouthStretchLeft", "mouthStretchRight"]


@pytest.fixture(scope="module")
def takes():
    """(name, audio, transcript, times, (frames, channels) tracks, alignment) per line."""
    vs = visemes.load("arkit")
    poses = {v: dict(m) for v, m in vs.shape_keys.items()}
    actor = presets.load("angry")
    rng = np.random.default_rng(11)
    out = []
    for path in (FIXTURES / "bob_map.wav", FIXTURES / "fast_bilabials.wav", SAMPLE / "hello.wav"):
        snd = audio_mod.load(path)
        text = path.with_suffix(".txt").read_text()
        al = pipeline.align_audio(snd, text)
        probe = learning.TrainingClip("probe", snd, al, np.array([0.0, snd.duration]), np.zeros((2, len(CHANNELS))),
                                   CHANNELS)
        prepared = learning.prepare(probe, vs, actor, 60.0, CHANNELS)
        y = learning.synthesise(prepared, actor, vs, CHANNELS, 60.0, poses)
        out.append((path.stem, snd, text, prepared.times, y + rng.normal(0, 0.01, y.shape), al))
    return out


def _write(folder, takes, order):
    """The takes as files a user has: WAV, transcript, and a capture CSV
    with its columns in ``order``."""
    folder.mkdir()
    cols = [CHANNELS.index(c) for c in order]
    for name, snd, text, times, y, _al in takes:
        write_wav(folder / f"{name}.wav", snd.samples, snd.rate)
        (folder / f"{name}.txt").write_text(text)
        rows = ["time," + ",".join(order)]
        rows += [f"{t:.5f}," + ",".join(f"{v:.4f}" for v in row[cols]) for t, row in zip(times, y)]
        (folder / f"{name}.csv").write_text("\n".join(rows) + "\n")
    return sorted(str(p) for p in folder.glob("*.wav"))


def _learn(wavs, out, capsys):
    assert cli_main(["learn", *wavs, "--out", str(out)]) == 0
    said = capsys.readouterr()
    return json.loads(out.with_name(out.stem + ".report.json").read_text()), said.out, said.err


def test_column_order_changes_nothing(takes, tmp_path, capsys):
    """The first column is a track like the others, not a basis shape key:
    shuffled columns give the same report, and the starting preset predicts
    whichever channel comes first."""
    shuffled = [CHANNELS[i] for i in np.random.default_rng(2).permutation(len(CHANNELS))]
    assert shuffled[0] != CHANNELS[0]
    a, said, _err = _learn(_write(tmp_path / "a", takes, CHANNELS), tmp_path / "a.json", capsys)
    b, _said, _err = _learn(_write(tmp_path / "b", takes, shuffled), tmp_path / "b.json", capsys)
    assert a["channels"] == CHANNELS and b["channels"] == shuffled
    for ch in CHANNELS:
        for who in ("start", "learned"):
            for m in ("correlation", "rmse"):
                assert a["per_track"][ch][who][m] == pytest.approx(b["per_track"][ch][who][m], abs=2e-3), (ch, who)
    for who in ("start", "learned"):
        assert a["summary"][who]["correlation"] == pytest.approx(b["summary"][who]["correlation"], abs=1e-3)
        assert a["summary"][who]["rmse"] == pytest.approx(b["summary"][who]["rmse"], abs=1e-3)
    for report in (a, b):
        first = report["per_track"][report["channels"][0]]["start"]["correlation"]
        assert first > 0.9, report["channels"][0]
    # The printed table names every track in full.
    rows = [line.split() for line in said.splitlines() if line.startswith("mean ")]
    assert [r[1] for r in rows] == CHANNELS[:6]


def test_progress_is_plain_lines_when_not_a_terminal(takes, tmp_path, capsys):
    _report, _said, err = _learn(_write(tmp_path / "a", takes[:2], CHANNELS), tmp_path / "a.json", capsys)
    assert "\r" not in err
    assert err.splitlines() == ["aligning the clips", "preparing the tracks", "fitting",
                                "evaluating on the held-out clips"]


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_is_a_bar_on_a_terminal():
    """One bar over the whole run, as ``batch`` shows on a terminal."""
    tty = _Terminal()
    with learning.Console(tty) as progress:
        for step in ("align", "prepare", "fit", "evaluate", "done"):
            progress(step, 0.0)
            progress(step, 1.0)
    shown = tty.getvalue()
    assert "\r" in shown and "fit" in shown and "100%" in shown and "\n" not in shown
    log = io.StringIO()
    with learning.Console(log) as progress:
        progress("fit", 0.2)
        progress("fit", 0.7)
    assert log.getvalue() == "fitting\n"


def test_a_rigs_own_mapping_is_the_start(takes):
    """Keys named the rig's own way (as in Blender, where the mesh's mapping
    says which key shows each viseme): the starting preset shows its poses
    on them, in the fit and in the report."""
    own = {ch: f"Face.{ch.upper()}_shape" for ch in CHANNELS}
    clips = [learning.TrainingClip(name, snd, al, times, y, [own[c] for c in CHANNELS])
             for name, snd, _text, times, y, al in takes]
    rig = {v: {own[k]: w for k, w in mix.items() if k in own}
           for v, mix in visemes.load("arkit").shape_keys.items()}
    blind = learning.learn(clips, viseme_set="arkit", max_iter=0).report
    seen = learning.learn(clips, viseme_set="arkit", max_iter=0, start_map=rig).report
    for ch in own.values():
        assert blind["per_track"][ch]["start"]["correlation"] == 0.0      # the set's names: none found
        assert seen["per_track"][ch]["start"]["correlation"] > 0.25, ch   # rounding barely moves in two lines
    assert seen["per_track"][own["jawOpen"]]["start"]["correlation"] > 0.9
    assert seen["summary"]["start"]["correlation"] > 0.7


def test_what_the_data_cannot_improve_is_kept_what_it_can_is_learned(takes):
    """An actor who moves the jaw further than the arkit set's poses, and
    rounds the lips exactly as they do, with the starting preset's timing:
    the jaw poses are learned, the rounding poses kept, and no track ends
    worse than the start."""
    vs = visemes.load("arkit")
    start = {v: dict(m) for v, m in vs.shape_keys.items()}
    actor = {v: {k: (min(1.0, w + 0.3) if k == "jawOpen" else w) for k, w in mix.items()} for v, mix in start.items()}
    neutral = presets.load("neutral")
    rng = np.random.default_rng(4)
    clips = []
    for name, snd, _text, _times, _y, al in takes:
        probe = learning.TrainingClip("probe", snd, al, np.array([0.0, snd.duration]), np.zeros((2, len(CHANNELS))),
                                   CHANNELS)
        prepared = learning.prepare(probe, vs, neutral, 60.0, CHANNELS)
        y = learning.synthesise(prepared, neutral, visemes.with_targets(vs, actor), CHANNELS, 60.0, actor)
        clips.append(learning.TrainingClip(name, snd, al, prepared.times, y + rng.normal(0, 0.01, y.shape), CHANNELS))
    result = learning.learn(clips, emotion="neutral", viseme_set="arkit", name="jaw")
    r = result.report
    assert "jaw poses" in r["parts"]["learned"] and "rounding poses" in r["parts"]["kept"], r["parts"]
    jaw = r["per_track"]["jawOpen"]
    assert jaw["learned"]["rmse"] < 0.6 * jaw["start"]["rmse"]
    for ch, t in r["per_track"].items():
        assert t["learned"]["rmse"] <= 1.005 * t["start"]["rmse"] + 0.0005, ch    # 0.0005: a 20th of the noise
        if t["start"]["correlation"] is not None:
            assert t["learned"]["correlation"] >= t["start"]["correlation"] - 0.01, ch
    targets = result.preset["learned"]["targets"]
    assert targets["aa"]["jawOpen"] == pytest.approx(1.0, abs=0.1)
    assert targets["ou"]["mouthPucker"] == start["ou"]["mouthPucker"]          # kept as the start shows it
    assert all(0.0 <= w <= 1.0 for mix in targets.values() for w in mix.values())
    assert "jaw poses" in result.preset["description"] and "rounding" not in result.preset["description"]
