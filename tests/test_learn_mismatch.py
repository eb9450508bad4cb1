"""Learning from captures the engine's model did not make.

The captures come from :mod:`mismatch`: hand-made articulatory targets per
phoneme tracked by a critically damped system (a different blending law
from the dominance model), 45 ms late, in the sensor's own units and with
noise.  Learning must still improve on the starting preset where a viewer
looks, on clips it did not see: correlation AND RMSE of the jaw and the lip
aperture, and find the delay.  The learned preset cannot match such
captures exactly, so the margins are modest; the benchmark
``bench/learn_mismatch.py`` prints the full table.
"""

import json

import pytest

from addon.engine import learning, presets
from addon.engine.learning import capture
from addon.engine.cli import main as cli_main
from addon.engine.errors import ImportFormatError

import mismatch
from conftest import write_wav

DELAY = 0.045


@pytest.fixture(scope="module")
def captured():
    """6 clips: 3 sentences at 2 speaking rates."""
    return mismatch.clips(rates=(0.9, 1.15), delay=DELAY, names=("bob_map", "fast_bilabials", "hello"))


def test_learning_beats_the_start_on_unseen_clips(captured):
    result = learning.learn(captured, emotion="neutral", viseme_set="arkit", name="capt")
    r = result.report
    assert r["evaluation"] == "leave-one-clip-out" and len(r["per_clip"]) == len(captured)
    assert r["tracks"].startswith("proxies")
    for track in ("jaw", "lip_aperture"):
        t = r["per_track"][track]
        assert t["learned"]["correlation"] > t["start"]["correlation"] + 0.01, (track, t)
        assert t["learned"]["rmse"] < t["start"]["rmse"], (track, t)
        for clip in r["per_clip"]:
            assert set(clip["tracks"][track]["learned"]) == {"correlation", "rmse", "peak_timing_ms"}
    assert abs(r["delay_ms"] - 1000 * DELAY) <= 10.0, r["delay_ms"]
    assert all(abs(d - 1000 * DELAY) <= 15.0 for d in r["delay_per_fold_ms"]), r["delay_per_fold_ms"]
    assert r["better_than_builtin"] and r["kept"] == "learned" and "is better" in r["verdict"]
    # Proxies say nothing about a rig's poses: the preset carries dominance only.
    assert "learned" not in result.preset
    assert result.preset["dominance"] != presets.read("neutral")["dominance"]


def test_the_start_is_kept_unless_told(captured):
    """No fitting (no iterations): the learned preset is the start, so it is
    not better, and ``learn`` says so and keeps the start."""
    clips = captured[:3]
    r = learning.learn(clips, emotion="sad", viseme_set="arkit", name="same", max_iter=0)
    assert not r.report["better_than_builtin"] and r.report["kept"] == "start"
    assert "NOT better" in r.report["verdict"]
    assert r.preset["name"] == "same" and r.preset["dominance"] == presets.read("sad")["dominance"]
    forced = learning.learn(clips, emotion="sad", viseme_set="arkit", name="same", max_iter=0, keep_learned=True)
    assert forced.report["kept"] == "learned"


def _write_clip(folder, clip, gain=20.0):
    stem = folder / clip.name.replace("@", "_")
    write_wav(stem.with_suffix(".wav"), clip.audio.samples, clip.audio.rate)
    rows = ["t_ms,JawY_mm,LipGap_mm,Protrusion_mm,Tongue_mm"]
    rows += [f"{1000 * t:.2f}," + ",".join(f"{gain * v:.3f}" for v in row) + ",0.0"
             for t, row in zip(clip.times, clip.tracks)]
    stem.with_suffix(".csv").write_text("\n".join(rows) + "\n")
    stem.with_suffix(".txt").write_text(" ".join(w.text for w in clip.alignment.words))
    return stem.with_suffix(".wav")


def test_articulography_csv_on_the_command_line(captured, tmp_path, capsys):
    wavs = [str(_write_clip(tmp_path, c)) for c in captured[:3]]
    tmap = tmp_path / "ema.json"
    tmap.write_text(json.dumps({"time": "t_ms", "time_unit": "ms", "columns": {
        "JawY_mm": {"track": "jaw", "range": [0, 20]}, "LipGap_mm": {"track": "lip_aperture", "range": [0, 20]},
        "Protrusion_mm": "rounding"}}))
    out = tmp_path / "ema_neutral.json"
    assert cli_main(["learn", *wavs, "--out", str(out), "--track-map", str(tmap)]) == 0
    said = capsys.readouterr().out
    assert "capture delay" in said and "leave-one-clip-out" in said and "lip_aperture" in said
    report = json.loads(out.with_name(out.stem + ".report.json").read_text())
    assert report["channels"] == ["jaw", "lip_aperture", "rounding"] and len(report["per_clip"]) == 3
    assert presets.load(out).name == out.stem
    # A column the map names but the file lacks: one line naming the file.
    assert cli_main(["learn", *wavs, "--out", str(out), "--track-map",
                    "time=t_ms,time_unit=ms,JawY_mm=jaw,Nope=lip_aperture"]) == 1
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("error:") and "no column 'Nope'" in err and ".csv" in err


def test_track_csv_mapping(tmp_path):
    f = tmp_path / "take.csv"
    f.write_text("frame,time,LA,UL,p_aa\n0,0.00,10,1,0.1\n1,0.01,5,2,0.5\n2,0.02,0,3,0.9\n")
    m = capture.load_track_map("LA=lip_aperture,p_aa=viseme:aa")
    times, values, names = capture.read_track_csv(f, m)
    assert names == ["lip_aperture", "viseme:aa"] and times == pytest.approx([0, 0.01, 0.02])
    # saved by Notepad: UTF-8 with a byte-order mark
    (tmp_path / "m.json").write_text(json.dumps({"columns": {"LA": {"track": "lip_aperture", "range": [10, 0]}}}),
                                     encoding="utf-8-sig")
    _t, values, _n = capture.read_track_csv(f, capture.load_track_map(str(tmp_path / "m.json")))
    assert values[:, 0] == pytest.approx([0.0, 0.5, 1.0])       # a range turned over


@pytest.mark.parametrize("spec, message", [
    ("LA", "is not COLUMN=TRACK"),
    ("LA=tongue", "maps to 'tongue'"),
    ("LA=jaw,UL=jaw", "same track"),
])
def test_bad_track_maps(spec, message):
    with pytest.raises(ImportFormatError, match=message):
        capture.load_track_map(spec)


def test_bad_track_csv(tmp_path):
    f = tmp_path / "take.csv"
    f.write_text("time,LA\n0.0,1\n0.01,x\n")
    with pytest.raises(ImportFormatError, match=r"line 3: LA = 'x' is not a number"):
        capture.read_track_csv(f, capture.load_track_map("LA=jaw"))
    f.write_text("t,LA\n0.0,1\n0.0,2\n")
    with pytest.raises(ImportFormatError, match="time does not increase"):
        capture.read_track_csv(f, capture.load_track_map("LA=jaw"))
