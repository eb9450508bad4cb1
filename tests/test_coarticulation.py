import numpy as np
import pytest

from addon.engine import presets, visemes
from addon.engine.alignment import AlignedPhone, Alignment
from addon.engine.render import curves
from addon.engine.prosody import ClipStats

STATS = ClipStats(100, 150, 200, 40, 60, 80, True)


def utterance(phones, rate=1.0, start=0.3):
    """Phones with typical durations divided by ``rate``, after a pause."""
    out, t = [], start
    for p in phones.split():
        d = (0.12 if p in {"AA", "AE", "IY", "EY", "OW", "UW", "AH"} else 0.07) / rate
        out.append(AlignedPhone(p, t, t + d, 0))
        t += d
    return Alignment([], out, t + 0.4)


def run(al, model, fps=30, emotion="neutral", vset="default"):
    n = len(al.phones)
    v = visemes.load(vset)
    w, times, c = curves(al, np.full(n, 150.0), np.full(n, 60.0), STATS, v, presets.load(emotion), model, fps)
    return v, times, c


PHRASE = "M EY B IY B AA B IY M EY K S P AH M P K IH N P AY"


@pytest.mark.parametrize("model", ["rules", "dominance"])
@pytest.mark.parametrize("rate", [0.5, 1.0, 2.0, 4.0])
@pytest.mark.parametrize("fps", [24, 30])
def test_lips_close_on_every_bilabial(model, rate, fps):
    al = utterance(PHRASE, rate)
    v, times, c = run(al, model, fps)
    mbp = v.index("MBP")
    for p in al.phones:
        if p.phone in {"P", "B", "M"}:
            k = np.flatnonzero((times >= p.start) & (times <= p.end))
            if len(k) == 0:
                k = [int(np.argmin(np.abs(times - (p.start + p.end) / 2)))]
            assert c[k, mbp].max() >= 0.85, (p, c[k, mbp])
            # ... and the mouth is not also open there.
            assert c[k].max(axis=0)[v.index("AHH")] < 0.4


@pytest.mark.parametrize("model", ["rules", "dominance"])
def test_teeth_on_lip_for_f_and_v(model):
    al = utterance("F AY V F AE V", 3.0)
    v, times, c = run(al, model, 24)
    fv = v.index("FV")
    for p in al.phones:
        if p.phone in {"F", "V"}:
            k = int(np.argmin(np.abs(times - (p.start + p.end) / 2)))
            assert c[k, fv] >= 0.85


@pytest.mark.parametrize("model", ["rules", "dominance"])
@pytest.mark.parametrize("vset", ["default", "oculus", "preston_blair", "rhubarb", "arkit"])
def test_weights_in_range_and_rest_in_silence(model, vset):
    al = utterance(PHRASE, 1.0, start=1.0)
    v, times, c = run(al, model, 60, "angry", vset)
    assert c.min() >= 0.0 and c.max() <= 1.0
    assert c.max() > 0.5
    silent = times < 0.5
    assert c[silent].max() < 0.05


@pytest.mark.parametrize("model", ["rules", "dominance"])
def test_anticipation_before_the_phoneme(model):
    al = utterance("AA S UW", 1.0, start=0.5)
    v, times, c = run(al, model, 60)
    uw = next(p for p in al.phones if p.phone == "UW")
    before = (times > uw.start - 0.08) & (times < uw.start)
    assert c[before, v.index("UUU")].max() > 0.05   # rounding starts before the /u/ sounds


def test_sad_is_softer_than_angry_and_happy():
    al = utterance(PHRASE, 1.0)
    peaks = {}
    for emo in ("sad", "neutral", "happy", "angry"):
        v, times, c = run(al, "dominance", 30, emo)
        peaks[emo] = c[:, v.index("AHH")].max()
    assert peaks["sad"] < peaks["neutral"] < peaks["happy"] <= peaks["angry"] + 1e-9


def test_odd_frame_rates():
    al = utterance(PHRASE)
    for fps in (23.976, 29.97, 25, 60):
        v, times, c = run(al, "dominance", fps)
        assert np.allclose(np.diff(times), 1 / fps)
        assert len(times) == int(np.floor(al.duration * fps + 1e-9)) + 1


def test_rules_delete_short_h_and_t():
    al = Alignment([], [AlignedPhone("AA", 0.2, 0.4, 0), AlignedPhone("HH", 0.4, 0.42, 0),
                        AlignedPhone("AA", 0.42, 0.6, 0)], 1.0)
    v, times, c = run(al, "rules", 100)
    assert c[:, v.index("GK")].max() == 0.0
    al.phones[1].end = 0.5
    al.phones[2].start = 0.5
    v, times, c = run(al, "rules", 100)
    assert c[:, v.index("GK")].max() > 0.3


def test_gaussian_smoothing_matches_a_convolution_column_by_column():
    from addon.engine.smoothing import gaussian

    rng = np.random.default_rng(3)
    x = rng.normal(size=(200, 7))
    sigma = 2.6
    radius = int(np.ceil(3 * sigma))
    kernel = np.exp(-0.5 * (np.arange(-radius, radius + 1) / sigma) ** 2)
    kernel /= kernel.sum()
    want = np.stack([np.convolve(np.pad(x[:, j], radius, mode="edge"), kernel, mode="valid")
                     for j in range(x.shape[1])], axis=1)
    got = gaussian(x, sigma)
    assert got.shape == x.shape
    assert np.allclose(got, want, atol=1e-12)
    # 1-D input, a constant stays constant at the edges, and the input is not changed.
    ramp = np.linspace(0.0, 1.0, 50)
    assert gaussian(ramp, sigma).shape == ramp.shape
    assert np.allclose(gaussian(np.full(30, 0.4), sigma), 0.4)
    assert np.allclose(gaussian(x, sigma), got) and not np.shares_memory(gaussian(x, 0.0), x)
