"""Hand edits kept over a new run (addon/engine/edits.py): found as the
difference from what a run keyed, anchored to the words and phones, moved
with them to a new take, dropped with a word the new line lacks."""

from __future__ import annotations

import json

import numpy as np
import pytest

from addon.engine import edits
from addon.engine.alignment.model import AlignedPhone, AlignedWord, Alignment
from addon.engine.edits import Edit, Take, Timing

FPS = 30.0
#: "bob bought a map": words and phones, s from the line's start.
WORDS = [("Bob", 0.20, 0.50, ["B", "AA", "B"]), ("bought", 0.50, 0.80, ["B", "AO", "T"]),
         ("a", 0.80, 0.90, ["AH"]), ("map", 0.90, 1.30, ["M", "AE", "P"])]


def _timing(words=WORDS, shift=0.0, scale=1.0, jitter=0.0, seed=0) -> Timing:
    """The words, each phone a third of its word, times ``t * scale + shift``
    (each boundary moved by up to ``jitter`` s at random)."""
    rng = np.random.default_rng(seed)
    out_w, out_p = [], []
    for k, (text, a, b, phones) in enumerate(words):
        out_w.append((text, a * scale + shift, b * scale + shift))
        cuts = np.linspace(a, b, len(phones) + 1) * scale + shift
        cuts[1:-1] += rng.uniform(-jitter, jitter, len(cuts) - 2)
        out_p += [(p, cuts[i], cuts[i + 1], k) for i, p in enumerate(phones)]
    return Timing(tuple(out_w), tuple(out_p))


def _curve(n, seed=1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.clip(np.convolve(rng.random(n + 8), np.ones(9) / 9, mode="valid")[:n], 0, 1)


def _take(n=60, first=10, names=("jawOpen", "mouthClose"), timing=None, seed=1) -> Take:
    values = np.stack([_curve(n, seed + j) for j in range(len(names))], axis=1)
    return Take(first, FPS, timing or _timing(), list(names), values)


def _frame(t, first=10):
    return int(round(first + t * FPS))


# --- the line's timing -------------------------------------------------------------

def test_the_timing_holds_the_spoken_words_and_their_phones():
    words = [AlignedWord("Hello", 0.1, 0.4, ["HH", "AH"]), AlignedWord("there", 0.4, 0.4, [], spoken=False),
             AlignedWord("Bob", 0.5, 0.8, ["B", "AA", "B"])]
    phones = [AlignedPhone("HH", 0.1, 0.2, 0), AlignedPhone("AH", 0.2, 0.4, 0), AlignedPhone("B", 0.5, 0.6, 2),
              AlignedPhone("AA", 0.6, 0.7, 2), AlignedPhone("B", 0.7, 0.8, 2)]
    timing = Timing.of(Alignment(words, phones, 1.0))
    assert [w[0] for w in timing.words] == ["Hello", "Bob"]
    assert [p[3] for p in timing.phones] == [0, 0, 1, 1, 1]
    assert Timing.from_dict(json.loads(json.dumps(timing.to_dict()))) == timing


def test_a_take_is_stored_as_plain_data_and_read_back():
    take = _take()
    take.keys = {"jawOpen": np.array([0.0, 5.0, 59.0])}
    take.held = {"mouthClose": [(3, 7)]}
    meta = json.loads(json.dumps(take.meta()))
    back = Take.from_meta(meta, take.values.ravel().tolist())
    np.testing.assert_array_equal(back.values, take.values)
    assert back.names == take.names and back.first == take.first and back.timing == take.timing
    np.testing.assert_array_equal(back.keys["jawOpen"], [0, 5, 59])
    assert back.held == {"mouthClose": [(3, 7)]}


# --- finding the edits ----------------------------------------------------------------

def test_a_raised_key_is_one_edit_of_its_size():
    take = _take()
    now = take.values.copy()
    row = 21
    now[row, 0] += 0.25
    found = edits.find(take, {n: now[:, j] for j, n in enumerate(take.names)})
    assert len(found) == 1
    e = found[0]
    assert (e.channel, e.first, e.replace) == ("jawOpen", take.first + row, False)
    np.testing.assert_allclose(e.values, [0.25])


def test_an_untouched_curve_has_no_edits_and_a_deleted_curve_is_left_out():
    take = _take()
    assert edits.find(take, {n: take.values[:, j] + 5e-5 for j, n in enumerate(take.names)}) == []
    now = take.values[:, 1].copy()
    now[3:6] = 0.9
    found = edits.find(take, {"mouthClose": now})
    assert [(e.channel, e.first, len(e.values)) for e in found] == [("mouthClose", take.first + 3, 3)]


def test_keys_deleted_and_keyed_anew_are_a_replacement():
    take = _take()
    now = take.values.copy()
    now[20:26, 0] = 0.8                       # a hold
    every = take.frames.astype(float)
    found = edits.find(take, {"jawOpen": now[:, 0]}, {"jawOpen": every})
    assert [e.replace for e in found] == [False]   # the same keys moved: an offset
    hold = np.concatenate([every[:20], [take.first + 20.0, take.first + 25.0], every[26:]])
    found = edits.find(take, {"jawOpen": now[:, 0]}, {"jawOpen": hold})
    assert [e.replace for e in found] == [True]
    np.testing.assert_allclose(found[0].values, 0.8)
    # Keys only deleted (a cleaned curve) keep following the run's curve: an offset.
    thinned = every[::3]
    now = np.interp(take.frames, thinned, np.interp(thinned, take.frames, take.values[:, 0]))
    assert not any(e.replace for e in edits.find(take, {"jawOpen": now}, {"jawOpen": thinned}))


# --- the warp --------------------------------------------------------------------------

def test_the_warp_follows_the_words_and_phones():
    old = _timing()
    assert np.allclose(edits.Warp(old, old)([0.0, 0.3, 0.95, 2.0]), [0.0, 0.3, 0.95, 2.0])
    later = edits.Warp(old, _timing(shift=0.3))
    assert np.allclose(later([0.0, 0.35, 1.1, 3.0]), [0.3, 0.65, 1.4, 3.3])
    slower = edits.Warp(old, _timing(scale=1.5), smooth=0)
    assert np.allclose(slower([0.2, 0.65, 1.3]), [0.3, 0.975, 1.95])


def test_the_warp_moves_by_the_shift_of_the_sounds_around_despite_their_jitter():
    old = _timing()
    warp = edits.Warp(old, _timing(shift=0.3, jitter=0.02, seed=4))
    t = np.linspace(0.25, 1.25, 40)
    assert np.abs(warp(t) - t - 0.3).max() < 0.5 / FPS


def test_a_changed_word_is_gone_and_the_others_still_anchor():
    old = _timing()
    new_words = [WORDS[0], WORDS[1], ("the", 0.8, 0.9, ["DH", "AH"]), WORDS[3]]
    warp = edits.Warp(old, _timing(new_words, shift=0.2))
    assert warp.gone(0.85) == "a" and warp.gone(0.6) is None and warp.gone(0.1) is None
    assert np.allclose(warp([0.35, 1.0]), [0.55, 1.2])


# --- carrying the edits ------------------------------------------------------------------

def _raise(take, t, size=0.25, channel=0):
    """The take's curves with one key of ``channel`` raised at line time ``t``; the edits found."""
    now = take.values.copy()
    now[_frame(t, take.first) - take.first, channel] += size
    return edits.find(take, {n: now[:, j] for j, n in enumerate(take.names)})


def test_an_edit_survives_another_preset_and_nothing_else_changes():
    take = _take()
    found = _raise(take, 0.65)
    fresh = np.stack([_curve(60, 7), _curve(60, 8)], axis=1)     # the same line, other curves
    out = edits.carry(take, found, take.timing, take.first, FPS, take.names, fresh)
    row = _frame(0.65) - take.first
    assert out.values[row, 0] == pytest.approx(fresh[row, 0] + 0.25)
    others = np.ones(out.values.shape, dtype=bool)
    others[row, 0] = False
    np.testing.assert_array_equal(out.values[others], fresh[others])
    assert (out.kept, out.moved, out.dropped) == (1, 0, [])
    assert out.message() == "hand edits: 1 kept"


@pytest.mark.parametrize("jitter", [0.0, 0.015])
def test_an_edit_moves_with_its_sound_to_a_later_take(jitter):
    take = _take(n=60)
    found = _raise(take, 0.65)
    new = _timing(shift=0.3, jitter=jitter, seed=2)
    fresh = np.stack([_curve(70, 7), _curve(70, 8)], axis=1)
    out = edits.carry(take, found, new, take.first, FPS, take.names, fresh)
    row = _frame(0.65) - take.first + 9
    diff = out.values - fresh
    assert diff[row, 0] == pytest.approx(0.25)
    diff[row, 0] = 0
    assert np.abs(diff).max() == 0
    assert (out.kept, out.moved) == (0, 1)
    assert "1 moved with their sound" in out.message()


def test_an_edit_stretches_with_a_slower_take_and_moves_with_the_strip():
    take = _take(n=60)
    now = take.values.copy()
    rows = np.arange(_frame(0.55), _frame(0.75) + 1) - take.first       # over "bought"
    bump = np.hanning(len(rows) + 2)[1:-1] * 0.3
    now[rows, 0] += bump
    found = edits.find(take, {"jawOpen": now[:, 0]})
    assert len(found) == 1
    fresh = np.zeros((90, 2))
    out = edits.carry(take, found, _timing(scale=1.5), 40, FPS, take.names, fresh)
    got = np.flatnonzero(out.values[:, 0])
    # The keys start on frame 40 now (the strip moved), and the word lasts half as long again.
    assert 40 + got[0] == pytest.approx(40 + 0.55 * 1.5 * FPS, abs=1.5)
    assert len(got) == pytest.approx(1.5 * len(rows), abs=2)
    assert out.values[:, 0].max() == pytest.approx(bump.max())


def test_an_edit_on_a_word_gone_from_the_transcript_is_dropped_and_said():
    take = _take()
    found = _raise(take, 0.85) + _raise(take, 0.35, channel=1)       # on "a", and on "Bob"
    new_words = [WORDS[0], WORDS[1], WORDS[3]]
    fresh = np.zeros((60, 2))
    out = edits.carry(take, found, _timing(new_words), take.first, FPS, take.names, fresh)
    assert out.kept == 1 and len(out.dropped) == 1
    assert out.dropped[0] == f"jawOpen at frame {_frame(0.85)}: on 'a', which the new line does not say"
    assert np.abs(out.values[:, 0]).max() == 0
    assert "1 dropped (jawOpen at frame" in out.message()


def test_an_edit_on_a_channel_no_longer_keyed_or_outside_the_line_is_dropped():
    take = _take()
    found = _raise(take, 0.35, channel=1)
    out = edits.carry(take, found, take.timing, take.first, FPS, ["jawOpen"], np.zeros((60, 1)))
    assert out.dropped == [f"mouthClose at frame {_frame(0.35)}: this run does not key mouthClose"]
    out = edits.carry(take, found, take.timing, take.first, FPS, take.names, np.zeros((5, 2)))
    assert out.dropped[0].endswith("it would land outside the new line")


def test_locked_frames_get_no_edit_and_an_edit_inside_them_stays():
    take = _take()
    found = _raise(take, 0.35) + _raise(take, 0.95)
    lock = (_frame(0.3), _frame(0.4))
    fresh = np.zeros((60, 2))
    out = edits.carry(take, found, take.timing, take.first, FPS, take.names, fresh, lock=lock)
    assert out.locked == 1 and out.kept == 1
    assert out.values[_frame(0.35) - take.first, 0] == 0
    assert out.values[_frame(0.95) - take.first, 0] == pytest.approx(0.25)
    # An edit moved into the locked frames is not laid there.
    out = edits.carry(take, _raise(take, 0.95), _timing(shift=-0.55), take.first, FPS, take.names, fresh,
                      lock=lock)
    assert out.dropped and out.dropped[0].endswith("it would land in the locked frames")


def test_a_replaced_stretch_is_values_and_stays_replaced_on_the_next_run():
    take = _take()
    now = take.values[:, 0].copy()
    now[20:26] = 0.8
    keys = np.concatenate([take.frames[:20], [take.first + 20, take.first + 25], take.frames[26:]]).astype(float)
    found = edits.find(take, {"jawOpen": now}, {"jawOpen": keys})
    fresh = np.stack([_curve(60, 7), _curve(60, 8)], axis=1)
    out = edits.carry(take, found, take.timing, take.first, FPS, take.names, fresh)
    np.testing.assert_allclose(out.values[20:26, 0], 0.8)
    assert out.held == {"jawOpen": [(20, 25)]}
    # The next run finds the hold again (keys on every frame now) and keeps it a hold.
    again = Take(take.first, FPS, take.timing, take.names,
                 edits.remembered(fresh, out.values, out.values, take.first, take.names), held=out.held)
    np.testing.assert_allclose(again.values, fresh)
    found = edits.find(again, {"jawOpen": out.values[:, 0]}, {"jawOpen": take.frames.astype(float)})
    assert [e.replace for e in found] == [True]
    out2 = edits.carry(again, found, take.timing, take.first, FPS, take.names, np.zeros((60, 2)))
    np.testing.assert_allclose(out2.values[20:26, 0], 0.8)


# --- what a run keeps for the next ------------------------------------------------------

def test_the_copy_kept_takes_the_laid_edits_off_and_keeps_the_old_copy_on_locked_frames():
    fresh = np.full((10, 1), 0.5)
    final = fresh.copy()
    final[4, 0] += 0.25
    drawn = final + 0.01                          # a reduced curve strays from its values
    kept = edits.remembered(fresh, final, drawn, 100, ["jawOpen"])
    np.testing.assert_allclose(kept, drawn - (final - fresh))
    old = Take(95, FPS, Timing(), ["jawOpen"], np.full((10, 1), 0.2))
    kept = edits.remembered(fresh, final, drawn, 100, ["jawOpen"], lock=(102, 103), old=old)
    np.testing.assert_allclose(kept[2:4, 0], 0.2)
    kept = edits.remembered(fresh, final, drawn, 100, ["jawOpen"], lock=(102, 103))
    np.testing.assert_allclose(kept[2:4, 0], drawn[2:4, 0])


def test_an_edit_peak_keeps_its_size_whatever_the_fraction_of_frame_it_moves_by():
    take = _take()
    for shift in (0.29, 0.3, 0.31):
        out = edits.carry(take, _raise(take, 0.65), _timing(shift=shift), take.first, FPS, take.names,
                          np.zeros((70, 2)))
        assert out.values[:, 0].max() == pytest.approx(0.25)
        assert np.count_nonzero(out.values) == 1


def test_an_edit_with_no_word_to_anchor_it_stays_where_it_was():
    take = _take(timing=Timing())
    out = edits.carry(take, _raise(take, 0.65), Timing(), take.first, FPS, take.names, np.zeros((60, 2)))
    assert out.kept == 1 and out.values[_frame(0.65) - take.first, 0] == pytest.approx(0.25)


def test_edit_peak_and_frames():
    e = Edit("jawOpen", 10, np.array([0.1, -0.3, 0.2]))
    assert e.peak == 11 and list(e.frames) == [10, 11, 12]


def test_words_are_matched_around_the_changes_of_a_long_line():
    import time

    from addon.engine.edits import _matched

    a = [f"w{k}" for k in range(3000)]
    b = a[:1000] + ["new"] + a[1001:2000] + a[2001:] + ["end"]
    t0 = time.perf_counter()
    m = _matched(a, b)
    assert time.perf_counter() - t0 < 2.0
    assert m[999] == 999 and 1000 not in m and m[1001] == 1001 and m[2001] == 2000 and m[2999] == 2998
    assert _matched(["a", "b", "c"], ["a", "x", "c"]) == {0: 0, 2: 2}
    assert _matched(["the", "cat"], ["the", "the", "cat"]) in ({0: 0, 1: 2}, {0: 1, 1: 2})


def test_a_long_line_is_warped_quickly():
    import time

    words = [(f"w{k}", 0.3 * k, 0.3 * k + 0.25, ["AA", "B", "IY"]) for k in range(2000)]
    old = _timing(words)
    new = _timing(words[:700] + words[701:], shift=0.3)
    t0 = time.perf_counter()
    warp = edits.Warp(old, new)
    assert time.perf_counter() - t0 < 2.0
    assert warp.gone(0.3 * 700 + 0.1) == "w700"
    assert warp(0.3 * 100 + 0.1) == pytest.approx(0.3 * 100 + 0.4)
