"""The gesture layer without Blender: blinks, gaze, head and brows from a
line's words, pauses and voice; the channels a character has for them; the
keying step's gesture channels; the preset's numbers; the JSON and CSV."""

import csv
import json

import numpy as np
import pytest

from addon.engine import gestures, keys, pipeline, presets
from addon.engine.alignment import AlignedPhone, AlignedWord, Alignment
from addon.engine.errors import PresetError, SettingError
from addon.engine.settings import LineSettings
from voice_synth import voice

FPS = 100   # fine frames, to measure blink lengths and speeds


def long_line(seconds=60.0, seed=1):
    """A monologue: phrases of 3-7 words (M-vowel-S, 0.25 s each) parted by
    pauses of 0.3-1.2 s, with its voice: louder and higher on some vowels,
    quiet in the pauses.  Returns (alignment, voice times, pitch, intensity)."""
    rng = np.random.default_rng(seed)
    words, phones = [], []
    t = 0.5
    while t < seconds - 3:
        for _ in range(rng.integers(3, 8)):
            k = len(words)
            words.append(AlignedWord(f"w{k}", t, t + 0.25, ["M", "AA", "S"]))
            phones += [AlignedPhone("M", t, t + 0.06, k), AlignedPhone("AA", t + 0.06, t + 0.19, k),
                       AlignedPhone("S", t + 0.19, t + 0.25, k)]
            t += 0.25 + rng.uniform(0.0, 0.05)
        t += rng.uniform(0.3, 1.2)
    al = Alignment(words, phones, seconds)
    vt = np.arange(0, seconds, 0.01)
    speaking = np.zeros(len(vt), dtype=bool)
    for w in words:
        speaking |= (vt >= w.start) & (vt < w.end)
    loud = np.where(speaking, 65 + 8 * np.sin(vt * 1.7) ** 2 + rng.normal(0, 2, len(vt)), 30.0)
    pitch = np.where(speaking, 120 * 2 ** (3 * np.sin(vt * 0.9) / 12), np.nan)
    return al, vt, pitch, loud


@pytest.fixture(scope="module")
def monologue():
    al, vt, pitch, loud = long_line()
    times = np.arange(0, al.duration, 1 / FPS)
    return al, times, vt, pitch, loud


def motion_of(monologue, preset="neutral", seed=0):
    al, times, vt, pitch, loud = monologue
    return gestures.compute(al, times, vt, pitch, loud, presets.load(preset).gestures, seed)


def above_half(m):
    """(start, length) of each stretch with the lids more than half closed."""
    closed = np.concatenate([[False], m.blink > 0.5, [False]])
    edges = np.flatnonzero(np.diff(closed.astype(int)))
    return [(m.times[a], (b - a) / FPS) for a, b in zip(edges[::2], edges[1::2])]


def test_blinks_are_human_in_rate_and_length_and_gather_at_pauses(monologue):
    m = motion_of(monologue)
    minutes = m.times[-1] / 60
    shut = above_half(m)
    rate = len(shut) / minutes
    assert 12 <= rate <= 26, rate
    assert len(shut) >= len(m.blinks) - 2       # a double blink's two closings may merge into one
    assert all(0.05 <= length <= 0.5 for _, length in shut), shut
    near = [any(a - 0.35 <= s <= b + 0.35 for a, b in m.pauses) for s, _ in m.blinks]
    assert np.mean(near) >= 0.6, np.mean(near)
    gaps = np.diff([s for s, _ in m.blinks])
    assert gaps.min() >= 0.15 and gaps.max() < 12


def test_the_gaze_shifts_often_stays_near_rest_and_lids_follow_it_down(monologue):
    m = motion_of(monologue)
    assert np.abs(m.gaze).max() <= 15.0
    moving = np.flatnonzero(np.abs(np.diff(m.gaze, axis=0)).max(axis=1) > 0.05)
    shifts = m.times[moving[np.r_[True, np.diff(moving) > 3]]]
    assert len(shifts) >= m.times[-1] / 8
    assert np.diff(np.r_[0.0, shifts, m.times[-1]]).max() <= 8.0
    sad = motion_of(monologue, "sad")
    assert sad.gaze[:, 1].mean() < m.gaze[:, 1].mean() - 3     # sad looks down
    # Looking down, the lids come part of the way down, never as far as a blink.
    low = sad.gaze[:, 1] < -8
    lids_only = np.ones(len(sad.times), dtype=bool)
    for s, d in sad.blinks:
        lids_only &= ~((sad.times >= s - 0.02) & (sad.times <= s + d + 0.02))
    assert low.any() and (sad.blink[low & lids_only] > 0.05).mean() > 0.5
    assert sad.blink[lids_only].max() <= 0.31


def test_the_head_moves_more_in_speech_and_with_loudness(monologue):
    al, times, vt, pitch, loud = monologue
    m = motion_of(monologue)
    angle = np.linalg.norm(m.head, axis=1)
    speaking = np.zeros(len(times), dtype=bool)
    for w in al.words:
        speaking |= (times >= w.start) & (times < w.end)
    assert 0.7 <= angle[speaking].std() <= 8 or 0.7 <= np.sqrt((angle[speaking] ** 2).mean()) <= 8
    speed = np.linalg.norm(np.diff(m.head, axis=0), axis=1) * FPS
    pause = np.zeros(len(times), dtype=bool)
    for a, b in m.pauses:
        if b - a >= 0.5:
            pause |= (times >= a) & (times < b)
    ratio = speed[speaking[1:]].mean() / speed[pause[1:]].mean()
    assert ratio >= 1.3, ratio
    level = np.interp(times[1:], vt, loud)
    assert np.corrcoef(speed, level)[0, 1] >= 0.2
    # Nods on the accents: the head is further down just after an accent than just before it.
    assert m.accents
    after = np.mean([np.interp(t + 0.1, times, m.head[:, 0]) - np.interp(t - 0.15, times, m.head[:, 0])
                     for t in m.accents])
    assert after > 0.5
    happy, sad = motion_of(monologue, "happy"), motion_of(monologue, "sad")
    assert np.abs(happy.head).mean() > np.abs(m.head).mean() > np.abs(sad.head).mean()


def test_presets_set_the_blinks(monologue):
    neutral, sad, angry, afraid = (motion_of(monologue, p) for p in ("neutral", "sad", "angry", "afraid"))
    assert len(angry.blinks) < len(neutral.blinks) < len(afraid.blinks)
    assert np.mean([d for _, d in sad.blinks]) > np.mean([d for _, d in neutral.blinks]) + 0.05


def test_the_same_line_gives_the_same_motion_and_a_seed_varies_it(monologue):
    a, b, c = motion_of(monologue), motion_of(monologue), motion_of(monologue, seed=3)
    for x, y in ((a.blink, b.blink), (a.gaze, b.gaze), (a.head, b.head), (a.brow, b.brow)):
        assert np.array_equal(x, y)
    assert a.blinks != c.blinks and not np.allclose(a.head, c.head)
    # The motion does not hang on the frame rate: 24 fps samples the same motion.
    al, times, vt, pitch, loud = monologue
    slow = gestures.compute(al, np.arange(0, al.duration, 1 / 24), vt, pitch, loud, presets.load("neutral").gestures)
    assert slow.blinks == a.blinks
    resampled = np.stack([np.interp(slow.times, a.times, a.head[:, j]) for j in range(3)], axis=1)
    assert np.allclose(slow.head, resampled, atol=0.05)


def test_no_blink_rate_no_blinks_and_a_short_line_still_has_motion():
    al, vt, pitch, loud = long_line(4.0)
    times = np.arange(0, 4.0, 1 / 30)
    g = presets.Gestures(blink_rate=0.0)
    m = gestures.compute(al, times, vt, pitch, loud, g)
    assert m.blinks == [] and m.blink.max() <= 0.31
    assert np.abs(m.head).max() > 0.2


def test_brows_rise_on_accents(monologue):
    m = motion_of(monologue)
    peaks = [np.interp(t + 0.02, m.times, m.brow) for t in m.accents]
    assert min(peaks) > 0.2
    assert np.median(m.brow) < 0.05


# --- a character's channels ---------------------------------------------------------

ARKIT = ["jawOpen", "eyeBlinkLeft", "eyeBlinkRight", "eyeLookUpLeft", "eyeLookDownLeft", "eyeLookInLeft",
         "eyeLookOutLeft", "eyeLookUpRight", "eyeLookDownRight", "eyeLookInRight", "eyeLookOutRight", "browInnerUp"]


def test_channels_are_found_by_their_names_on_real_characters():
    arkit = gestures.match(ARKIT)
    assert arkit.shape_keys["blink_L"] == "eyeBlinkLeft" and arkit.shape_keys["look_out_R"] == "eyeLookOutRight"
    assert arkit.missing() == ["head (no Head or Neck bone)"] and arkit.missing(head_elsewhere=True) == []
    vroid = gestures.match(["Fcl_MTH_A", "Fcl_EYE_Close", "Fcl_EYE_Close_L", "Fcl_EYE_Close_R"],
                           ["J_Bip_C_Neck", "J_Bip_C_Head", "J_Adj_L_FaceEye", "J_Adj_R_FaceEye"])
    assert vroid.shape_keys == {"blink_L": "Fcl_EYE_Close_L", "blink_R": "Fcl_EYE_Close_R"}
    assert vroid.bones == {"head": "J_Bip_C_Head", "neck": "J_Bip_C_Neck", "eye_L": "J_Adj_L_FaceEye",
                           "eye_R": "J_Adj_R_FaceEye"}
    both = gestures.match(["Fcl_EYE_Close"])
    assert both.shape_keys == {"blink": "Fcl_EYE_Close"}
    mixamo = gestures.match([], ["mixamorig:Hips", "mixamorig:Neck", "mixamorig:Head", "mixamorig:LeftEye"])
    assert mixamo.bones == {"head": "mixamorig:Head", "neck": "mixamorig:Neck", "eye_L": "mixamorig:LeftEye"}
    assert mixamo.missing() == ["blinks (no eyeBlink or Fcl_EYE_Close keys)"]
    nothing = gestures.match(["A", "O"], ["spine"])
    assert len(nothing.missing()) == 3
    studio = gestures.match(["MyBlinkL"], [], {"shape_keys": {"blink_L": ["MyBlinkL"]}})
    assert studio.shape_keys == {"blink_L": "MyBlinkL"}


def test_gaze_drives_the_look_keys_the_way_the_eyes_turn(monologue):
    m = motion_of(monologue)
    curves = gestures.shape_key_curves(m, gestures.match(ARKIT))
    left = m.gaze[:, 0] > 3
    assert left.any() and (~left).any()
    # Looking to the character's left: the left eye looks out, the right eye in; the others rest.
    assert np.all(curves["eyeLookOutLeft"][left] > 0) and np.all(curves["eyeLookInRight"][left] > 0)
    assert np.allclose(curves["eyeLookOutLeft"], curves["eyeLookInRight"])
    assert np.all(curves["eyeLookInLeft"][left] == 0)
    assert np.array_equal(curves["eyeBlinkLeft"], curves["eyeBlinkRight"])


def _rotate(q, v):
    w, x, y, z = q
    u = np.array([x, y, z])
    return v + 2 * np.cross(u, np.cross(u, v) + w * v)


def test_turns_are_in_the_characters_frame_and_in_each_bones_own():
    q = gestures.character_turns(np.array([10.0]), np.array([0.0]), np.array([0.0]))[0]
    forward = np.array([0.0, -1.0, 0.0])
    assert _rotate(q, forward)[2] < -0.15             # a nod: the face turns down
    q = gestures.character_turns(np.array([0.0]), np.array([20.0]), np.array([0.0]))[0]
    assert _rotate(q, forward)[0] > 0.3                # a yaw: to the character's left (+X)
    # A bone lying along +Z (its Y axis up, as a head bone): the same turn about its own axes.
    rest = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])   # columns: the bone's X, Y, Z in the character's frame
    local = gestures.in_bone_frame(q[None, :], rest)[0]
    v_bone = np.array([0.3, 0.2, 0.9])
    assert np.allclose(rest @ _rotate(local, v_bone), _rotate(q, rest @ v_bone))


def test_keying_adds_gesture_channels_and_leaves_the_users_and_speechs_alone(monologue):
    snd, al = voice(0.6, syllables=("AA", "IY", "EH", "AA"))
    r = pipeline.analyze(snd, settings=LineSettings.of("sad"), alignment=al)
    assert r.gestures is not None
    mapping = {"MBP": {"mouthClose": 1.0}, "AHH": {"jawOpen": 1.0}, "IEE": {"eyeBlinkLeft": 0.0}}
    face = {"AU1": {"browInnerUp": 1.0}}
    found = gestures.match(ARKIT + ["mouthClose"], ["Neck", "Head", "LeftEye", "RightEye"])
    line = keys.mesh_keys(r, mapping, keys.conventions.Closure(viseme="MBP"), face)
    sad_brow = next(c for c in line.channels if c.name == "browInnerUp").values.copy()
    line = keys.with_gestures(line, r.gestures, found, face, animated=["eyeLookUpLeft", "Neck"])
    by = {c.name: c for c in line.channels}
    assert by["eyeBlinkRight"].drivers == (keys.GESTURE,)
    assert by["eyeBlinkLeft"].drivers == (keys.SPEECH,)          # speech owns its keys
    assert "eyeLookUpLeft" not in by and "eyeLookUpLeft" in line.gesture_kept
    assert set(line.turns) == {"Head", "LeftEye", "RightEye"} and "Neck" in line.gesture_kept
    assert by["browInnerUp"].drivers == (keys.EXPRESSION, keys.GESTURE)
    assert np.all(by["browInnerUp"].values >= sad_brow - 1e-12)
    assert line.gesture_missing == []
    off = keys.with_gestures(keys.mesh_keys(r, mapping, keys.conventions.Closure(viseme="MBP"), face), None, found)
    assert not off.gesture_keys and not off.turns


# --- settings, presets, output ----------------------------------------------------------


def test_the_preset_checks_its_gesture_numbers(tmp_path):
    assert presets.load("neutral").gestures == presets.Gestures()
    assert presets.load("sad").gestures.gaze_down > 0
    for doc, field in (({"gestures": {"blink_rate": 90}}, "gestures.blink_rate"),
                       ({"gestures": {"blinks": 3}}, "gestures.blinks"),
                       ({"gestures": {"nod": "big"}}, "gestures.nod"),
                       ({"gestures": []}, "gestures")):
        with pytest.raises(PresetError) as err:
            presets.as_preset({"name": "x", **doc})
        assert err.value.field == field
    p = presets.as_preset({"name": "lively", "base": "happy", "gestures": {"head_range": 6}})
    assert p.gestures.head_range == 6 and p.gestures.nod == presets.load("happy").gestures.nod
    presets.save(p, tmp_path / "lively.json")
    assert presets.load(tmp_path / "lively.json").gestures == p.gestures


def test_settings_turn_gestures_off_and_seed_them():
    with pytest.raises(SettingError):
        LineSettings.of(gestures="no")
    with pytest.raises(SettingError):
        LineSettings.of(gesture_seed=1.5)
    s = LineSettings.of(gestures=False, gesture_seed=4)
    assert LineSettings.from_dict(json.loads(json.dumps(s.to_dict()))) == s


def test_json_and_csv_carry_the_gesture_tracks(tmp_path):
    snd, al = voice(0.6)
    r = pipeline.analyze(snd, settings=LineSettings.of(), alignment=al)
    doc = json.loads(json.dumps(r.to_dict()))["gestures"]
    assert set(gestures.Motion.TRACKS) <= set(doc) and len(doc["blink"]) == len(r.times)
    assert np.allclose(doc["head_pitch"], r.gestures.head[:, 0], atol=1e-4)
    r.write_csv(tmp_path / "a.csv")
    rows = list(csv.reader(open(tmp_path / "a.csv")))
    assert rows[0][-len(gestures.Motion.TRACKS):] == list(gestures.Motion.TRACKS)
    assert float(rows[5][rows[0].index("gaze_yaw")]) == pytest.approx(r.gestures.gaze[4, 0], abs=1e-4)
    off = pipeline.analyze(snd, settings=LineSettings.of(gestures=False), alignment=al)
    assert off.gestures is None and off.to_dict()["gestures"] is None
    assert np.array_equal(off.curves, r.curves)                 # the mouth is the same either way


# --- learned from a capture ------------------------------------------------------------

CAPTURE_FPS = 60


def _captured_clip(seed, blinks_at, down=0.24, head_deg=3.0):
    """A synthetic ARKit capture of a short line: lids closing at
    ``blinks_at`` (s, 0.2 s each), the gaze ``down`` of the way down with a
    glance aside every second, the head nodding ``head_deg`` degrees."""
    from addon.engine import learning
    from addon.engine.learning import capture

    snd, al = voice(0.5, syllables=("AA", "IY", "UW", "EH", "AA", "IY", "UW", "EH"), seed=seed)
    channels = list(capture.ARKIT)
    times = np.arange(0, al.duration, 1 / CAPTURE_FPS)
    rng = np.random.default_rng(seed)
    y = np.clip(0.02 + rng.normal(0, 0.005, (len(times), len(channels))), 0, 1)
    for s in blinks_at:
        x = (times - s) / 0.2
        shut = np.where((x >= 0) & (x <= 1), np.sin(np.pi * np.clip(x, 0, 1)), 0.0)
        for c in ("eyeBlinkLeft", "eyeBlinkRight"):
            y[:, channels.index(c)] = np.maximum(y[:, channels.index(c)], shut)
    for c in ("eyeLookDownLeft", "eyeLookDownRight"):
        y[:, channels.index(c)] = down
    aside = (np.floor(times) % 2 == 1) * 0.2
    y[:, channels.index("eyeLookOutLeft")] = aside
    y[:, channels.index("eyeLookInRight")] = aside
    head = np.stack([head_deg * np.sin(2 * np.pi * 0.7 * times), 0.5 * np.sin(times), 0.0 * times], axis=1)
    return learning.TrainingClip(f"c{seed}", snd, al, times, y, channels, head)


def test_learn_measures_the_gestures_a_capture_shows():
    from addon.engine import learning

    clips = [_captured_clip(s, [0.5, 1.7]) for s in range(3)]
    seconds = sum(c.times[-1] - c.times[0] for c in clips)
    result = learning.learn(clips, emotion="neutral", viseme_set="arkit", name="captured", max_iter=2,
                            keep_learned=True, delay=0.0)
    got = result.preset["gestures"]
    assert got["blink_rate"] == pytest.approx(6 / seconds * 60, rel=0.05)
    assert got["blink_duration"] == pytest.approx(0.2 * (2 / 3) / 0.61, abs=0.03)   # sin above 0.5: 2/3 of it
    assert got["gaze_down"] == pytest.approx((0.24 - 0.02) * 25, abs=0.3)      # down against up at rest (0.02)
    assert 1.0 < got["gaze_range"] < 4.0 and got["gaze_interval"] < 2.0
    assert got["head_range"] == pytest.approx(3.0 / np.sqrt(2), abs=0.5)
    assert result.report["gestures"]["evidence"]["blinks"] == 6
    # What the capture does not show keeps the starting preset's number.
    assert got["nod"] == presets.load("neutral").gestures.nod
    presets.validate(dict(result.preset), "captured")


def test_live_link_faces_head_rotation_is_read_in_degrees(tmp_path):
    from addon.engine.learning import capture

    f = tmp_path / "take.csv"
    f.write_text("Timecode,BlendShapeCount,EyeBlinkLeft,JawOpen,HeadYaw,HeadPitch,HeadRoll\n"
                 "10:20:30:00.000,61,0.1,0.2,0.1,-0.05,0.0\n10:20:30:01.000,61,0.1,0.2,0.2,0.0,0.01\n")
    head = capture.read_head_csv(f, fps=60)
    assert head == pytest.approx(np.degrees([[-0.05, 0.1, 0.0], [0.0, 0.2, 0.01]]))
    f.write_text("time,jawOpen\n0,0.1\n0.5,0.2\n")
    assert capture.read_head_csv(f) is None


def test_a_studios_channel_table_is_checked_field_by_field(tmp_path):
    from addon.engine import conventions

    good = {"shape_keys": {"blink_L": ["Lid_Close_L"]}, "bones": {"head": ["c_head.x"]}}
    assert gestures.check_table(good, "gestures.json") is good
    # It lives among the studio's naming conventions and is not read as one.
    (tmp_path / conventions.GESTURES_FILE).write_text(json.dumps(good))
    assert len(conventions.load_all([tmp_path])) == len(conventions.load_all())
    for doc, field in (({"keys": {}}, "keys"), ({"bones": ["head"]}, "bones"),
                       ({"bones": {"skull": ["x"]}}, "bones.skull"),
                       ({"shape_keys": {"blink_L": "Lid_Close_L"}}, "shape_keys.blink_L"),
                       ({"shape_keys": {"blink_L": [""]}}, "shape_keys.blink_L")):
        with pytest.raises(PresetError) as err:
            gestures.check_table(doc, "studio/gestures.json")
        assert err.value.field == field and "studio/gestures.json" in str(err.value)
