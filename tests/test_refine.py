"""The boundary-correction model (alignment/refine.py, data/boundary_model.json)."""

import json

import numpy as np
import pytest

from addon.engine.alignment import refine
from addon.engine.audio import Audio
from addon.engine.errors import LipSyncError

RATE = 16000


def fricative_then_vowel(vowel_at=0.5):
    """Silence, a fricative's noise from 0.3 s, a vowel (120 Hz and its harmonics) from ``vowel_at`` to 0.9 s."""
    t = np.arange(int(1.2 * RATE)) / RATE
    x = np.zeros_like(t)
    noise = (t >= 0.3) & (t < vowel_at)
    x[noise] = 0.05 * np.random.default_rng(0).normal(size=noise.sum())
    v = (t >= vowel_at) & (t < 0.9)
    x[v] = sum(0.3 / k * np.sin(2 * np.pi * 120 * k * t[v]) for k in range(1, 25))
    return Audio(x.astype(np.float32), RATE)


@pytest.mark.parametrize("off", [-0.015, 0.0, 0.015])
def test_a_vowel_start_moves_to_where_the_vowel_begins(off):
    audio = fricative_then_vowel()
    result = [[("S", 0.3, 0.5 + off), ("AA", 0.5 + off, 0.9)]]
    refine.refine_boundaries(audio, result, [False])
    assert abs(result[0][1][1] - 0.5) <= 0.006          # about a hop (5 ms) of the vowel's start
    assert result[0][0][2] == result[0][1][1]          # the fricative ends where the vowel starts


def test_moves_at_most_max_shift_and_keeps_every_phone_its_length():
    audio = fricative_then_vowel()
    doc = dict(refine.model())
    doc["weights"] = np.zeros_like(doc["weights"])
    doc["weights"][0] = 1.0                             # every boundary "a second late"
    result = [[("S", 0.3, 0.34), ("AA", 0.34, 0.9)], [("T", 0.9, 1.0)]]
    refine.refine_boundaries(audio, result, [False, False], doc=doc)
    assert result[0][1][1] == pytest.approx(0.33)      # the fricative keeps min_phone (30 ms)
    assert result[1][0][1] == pytest.approx(0.9 - doc["max_shift"])
    assert result[0][1][2] == result[1][0][1]


def test_phones_too_short_to_share_keep_their_boundary():
    # Phones of a line aligned on a slowed copy, scaled back, can be shorter than min_phone together.
    audio = fricative_then_vowel()
    doc = dict(refine.model())
    doc["weights"] = np.zeros_like(doc["weights"])
    doc["weights"][0] = 1.0                             # "late": the start would move earlier
    result = [[("S", 0.48, 0.50), ("AA", 0.50, 0.505)]]
    refine.refine_boundaries(audio, result, [False], doc=doc)
    assert result == [[("S", 0.48, 0.50), ("AA", 0.50, 0.505)]]


def test_words_left_and_labial_starts_keep_theirs():
    audio = fricative_then_vowel()
    doc = dict(refine.model())
    doc["weights"] = np.zeros_like(doc["weights"])
    doc["weights"][0] = -1.0                            # every boundary "early"
    result = [[("S", 0.3, 0.5)], [("AA", 0.5, 0.7)], [("M", 0.7, 0.8)], [("IY", 0.8, 0.9)], [("K", 0.95, 1.0)]]
    before = json.dumps(result)
    refine.refine_boundaries(audio, result, [False, True, False, True, False], doc=doc)
    after = json.loads(json.dumps(result))
    want = json.loads(before)
    want[4][0][1] = 0.95 + doc["max_shift"]             # after a pause: the start alone moves
    assert after == want


def test_the_shipped_model_is_read_and_a_broken_one_is_named(tmp_path):
    doc = refine.model()
    assert doc["weights"].shape == (refine.n_features(doc),) and np.abs(doc["weights"]).sum() > 0
    bad = json.loads(refine.MODEL_FILE.read_text(encoding="utf-8"))
    bad["weights"] = bad["weights"][:-1]
    path = tmp_path / "boundary_model.json"
    path.write_text(json.dumps(bad), encoding="utf-8")
    n = len(bad["weights"])
    with pytest.raises(LipSyncError, match=rf"boundary_model.json: the boundary model has {n} weights"):
        refine.model(path)
    bad["weights"] = [0.0] * refine.n_features(doc)
    bad["by_class"] = ["before"]
    path.write_text(json.dumps(bad), encoding="utf-8")
    with pytest.raises(LipSyncError, match=r"by_class must hold \"after\""):
        refine.model(path)
    del bad["classes"]
    path.write_text(json.dumps(bad), encoding="utf-8")
    with pytest.raises(LipSyncError, match="lacks classes"):
        refine.model(path)
    path.write_text("{", encoding="utf-8")
    with pytest.raises(LipSyncError, match="cannot be read"):
        refine.model(path)


def test_band_levels_sum_each_band_s_bins():
    """The boundary model's band levels are each band's power summed over its own bins (from its
    low edge up to, not including, its high one), as a band-matrix product gives them."""
    doc = refine.model()
    rng = np.random.default_rng(3)
    snd = Audio(rng.normal(0, 0.1, 16000).astype(np.float32), 16000)
    n, h = int(round(doc["window"] * 16000)), int(round(doc["hop"] * 16000))
    freq = np.fft.rfftfreq(n, 1 / 16000)
    bands = np.stack([(freq >= lo) & (freq < hi) for lo, hi in doc["bands"]], 1).astype(float)
    seg = np.concatenate([np.zeros(n // 2), snd.samples.astype(float), np.zeros(n)])
    frames = np.lib.stride_tricks.sliding_window_view(seg, n)[::h]
    f = np.fft.rfft(frames * np.hanning(n), axis=1)
    levels = 10 * np.log10((np.abs(f) ** 2) @ bands + 1e-4)
    got = refine.band_changes(snd, doc)
    nb = len(doc["bands"])
    assert got.shape[1] == nb * len(refine.steps(doc))
    for k, step in enumerate(refine.steps(doc)):        # each step's changes, a block of columns
        s = int(round(step / doc["hop"]))
        expected = levels[2 * s:] - levels[:-2 * s]
        assert np.allclose(got[s:s + len(expected), k * nb:(k + 1) * nb], expected, atol=1e-6)
        assert np.abs(got[s:-s, k * nb:(k + 1) * nb]).max() > 0.1


def test_lines_read_through_espeak_or_ipa_take_the_other_languages_model(monkeypatch):
    english, other = refine.model(refine.MODEL_FILE), refine.model(refine.OTHER_LANGUAGES_FILE)
    assert other["weights"].shape == english["weights"].shape and not np.allclose(other["weights"], english["weights"])
    assert refine.model_for(["cmudict", "cmudict", "derived"]) is english
    assert refine.model_for(["espeak", "espeak", "cmudict"]) is other
    assert refine.model_for(["ipa"]) is other
    assert refine.model_for(["ipa", "cmudict"]) is english       # half or less: the English one
    assert refine.model_for([]) is english
    # The aligner hands the chosen model to its last step.
    from addon.engine.alignment import transcript
    from addon.engine.pipeline import analyze
    from addon.engine.settings import LineSettings
    from conftest import SAMPLE

    given = []
    real = transcript.refine_alignment
    monkeypatch.setattr(transcript, "refine_alignment",
                        lambda audio, al, doc=None: given.append(doc) or real(audio, al, doc))
    analyze(str(SAMPLE / "hello.wav"), "hello my name is bob")
    analyze(str(SAMPLE / "hello.wav"), "hallo mein name ist bob", LineSettings.of(language="de"))
    assert len(given) == 2 and given[0] is english and given[1] is other


def test_changes_over_each_step_and_for_the_class_before_are_features_the_file_asks_for():
    """A model file reads the bands' changes over each of its ``steps`` and, with ``by_class``
    holding "before", those changes again for the class of the phone before the boundary; a file
    with one ``step`` and no ``by_class`` reads the one change for the class after it."""
    audio = fricative_then_vowel()
    phones = [("S", 0.3, 0.5), ("AA", 0.5, 0.9)]
    plain = {k: v for k, v in refine.model().items() if k not in ("steps", "by_class")}
    c, a = len(plain["classes"]), len(plain["bands"]) * len(plain["offsets"])
    assert refine.n_features(plain) == 1 + 2 * c + a + c * a
    rich = dict(plain, steps=[0.01, 0.02], by_class=["after", "before"])
    assert refine.n_features(rich) == 1 + 2 * c + 2 * a + 2 * c * 2 * a
    x1, x2 = refine.features(audio, phones, plain)[1], refine.features(audio, phones, rich)[1]
    assert x1.shape == (refine.n_features(plain),) and x2.shape == (refine.n_features(rich),)
    bands = len(plain["bands"])
    acoustic1 = x1[1 + 2 * c:1 + 2 * c + a].reshape(len(plain["offsets"]), bands)
    acoustic2 = x2[1 + 2 * c:1 + 2 * c + 2 * a].reshape(len(plain["offsets"]), 2 * bands)
    assert np.allclose(acoustic2[:, :bands], acoustic1)          # the first step's changes, as before
    assert not np.allclose(acoustic2[:, bands:], acoustic1)      # the second step's differ
    fric, vowel = plain["classes"].index("fricative"), plain["classes"].index("vowel")
    after = x2[1 + 2 * c + 2 * a:1 + 2 * c + 2 * a + 2 * c * a].reshape(c, 2 * a)
    before = x2[1 + 2 * c + 2 * c * a + 2 * a:].reshape(c, 2 * a)
    assert np.allclose(after[vowel], acoustic2.ravel()) and not after[fric].any()
    assert np.allclose(before[fric], acoustic2.ravel()) and not before[vowel].any()


def test_a_word_fitting_its_sound_poorly_and_the_start_after_it_are_left():
    """A word that fits its sound far worse than the line's median (not said as written) keeps its
    phones, and so does the start of the word after it: the model's corrections assume the phones
    on either side of a boundary are the ones said."""
    from addon.engine.alignment.model import AlignedPhone, AlignedWord, Alignment
    from addon.engine.alignment.verify import POOR_FIT

    def line(fit_of_middle):
        words = [AlignedWord("so", 0.3, 0.5, ["S"], fit=-10.0), AlignedWord("ah", 0.5, 0.7, ["AA"], fit=fit_of_middle),
                 AlignedWord("so", 0.7, 0.9, ["S"], fit=-12.0), AlignedWord("ah", 0.9, 1.1, ["AA"], fit=-11.0)]
        phones = [AlignedPhone(w.phones[0], w.start, w.end, k) for k, w in enumerate(words)]
        return Alignment(words, phones, 1.2)

    _, _, left = refine.by_word(line(-11.0 - POOR_FIT - 1))
    assert left == [False, True, False, False]
    _, _, left = refine.by_word(line(-11.0 - POOR_FIT + 1))
    assert left == [False, False, False, False]
    audio = fricative_then_vowel(vowel_at=0.52)
    doc = dict(refine.model())
    doc["weights"] = np.zeros_like(doc["weights"])
    doc["weights"][0] = -1.0                            # every boundary "early"
    al = line(-11.0 - POOR_FIT - 1)
    refine.refine_alignment(audio, al, doc)
    assert [p.start for p in al.phones[:3]] == [0.3, 0.5, 0.7]        # the misfit word and the start after it
    assert al.phones[3].start == pytest.approx(0.9 + doc["max_shift"])
