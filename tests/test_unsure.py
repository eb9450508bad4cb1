"""Without a transcript, the lips close where the recogniser's lattice puts
much of its weight on words that close them, even when its best guess has
no /p b m/ there."""

from __future__ import annotations

import numpy as np

from addon.engine import audio as audio_mod
from addon.engine.alignment import recognize, unsure
from conftest import SAMPLE


def _weight(frames: int, runs: dict[tuple[int, int], tuple[str, float]]) -> np.ndarray:
    w = np.zeros((frames, 3))
    for (a, b), (phone, value) in runs.items():
        w[a:b, unsure.LABIAL.index(phone)] = value
    return w


def test_a_lip_closure_the_best_guess_missed_is_put_in_the_phone_it_falls_in():
    words = [("hung", [("HH", 0, 10, -1.0), ("AH", 10, 30, -2.0), ("NG", 30, 60, -3.0)], False)]
    out = unsure.with_closures(words, _weight(70, {(40, 50): ("M", 0.6)}))
    assert out[0][0] == "hung"
    assert [p[:3] for p in out[0][1]] == [("HH", 0, 10), ("AH", 10, 30), ("NG", 30, 40), ("M", 40, 50),
                                         ("NG", 50, 60)]
    assert out[0][1][2][3] == -3.0 and out[0][1][4][3] == -3.0     # the cut phone keeps its score
    assert words[0][1][2] == ("NG", 30, 60, -3.0)                   # the words given are left as they were


def test_no_closure_on_little_weight_on_a_moment_or_beside_a_closure_already_heard():
    words = [("an", [("AE", 0, 20), ("N", 20, 40)], False), ("be", [("B", 40, 45), ("IY", 45, 70)], False)]
    for weight in (_weight(80, {(5, 15): ("P", unsure.CLOSED - 0.05)}),        # too little weight
                   _weight(80, {(5, 5 + unsure.SHORTEST - 1): ("P", 0.9)}),    # too short
                   _weight(80, {(36, 44): ("B", 0.9)})):                       # the best guess closes there
        assert unsure.with_closures(words, weight) == words
    assert unsure.with_closures(words, None) == words
    # Enough of it, long enough, away from the /b/: a /p/ in "an".
    out = unsure.with_closures(words, _weight(80, {(5, 15): ("P", unsure.CLOSED + 0.05)}))
    assert [p[:3] for p in out[0][1]] == [("AE", 0, 5), ("P", 5, 15), ("AE", 15, 20), ("N", 20, 40)]
    assert out[1] == words[1]


def test_the_lattice_weighs_the_closures_of_the_words_heard():
    snd = audio_mod.load(SAMPLE / "hello.wav")        # "Hello! My name is Bob, ..."
    pcm = snd.pcm16(0.0, snd.duration, floor=False)
    decoder, search = recognize._decoder()
    decoder.activate_search(search)
    decoder.reinit_feat()
    decoder.start_utt()
    decoder.process_raw(pcm, full_utt=True)
    decoder.end_utt()
    frames = len(pcm) // 320 + 1
    weight = unsure.labial_weight(decoder, frames)
    assert weight is not None and weight.shape == (frames, 3)
    assert weight.min() >= 0.0 and weight.sum(axis=1).max() <= 1.0 + 1e-6
    best = [(sg.word, sg.start_frame, sg.end_frame + 1) for sg in decoder.seg()]
    closing = [(a, b) for w, a, b in best if any(p in unsure.LABIAL for p in (decoder.lookup_word(w) or "").split())]
    assert closing, best
    # Where the best guess says a word closing the lips, most of the lattice's weight says so too.
    for a, b in closing:
        assert weight[a:b].sum(axis=1).max() >= 0.5, (a, b, best)
    open_ = np.ones(frames, bool)
    for a, b in closing:
        open_[max(0, a - 10):b + 10] = False
    assert weight[open_].sum(axis=1).mean() < 0.2
