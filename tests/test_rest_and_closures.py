"""The mouth rests in pauses; lips close on /p b m/ but never inside a vowel."""

import numpy as np
import pytest

from addon.engine import coarticulation, pauses, presets, visemes
from addon.engine.alignment import AlignedPhone, Alignment
from addon.engine.render import curves
from addon.engine.prosody import ClipStats

STATS = ClipStats(100, 150, 200, 40, 60, 80, True)


def phrase(spec, start=0.2):
    """'AA:0.12 M:0.06 ...' -> phones back to back; '_:0.5' is a pause."""
    out, t = [], start
    for item in spec.split():
        p, d = item.split(":")
        if p != "_":
            out.append(AlignedPhone(p, t, t + float(d), 0))
        t += float(d)
    return Alignment([], out, t + 0.3)


def run(al, model="dominance", fps=100):
    n = len(al.phones)
    v = visemes.load("default")
    _w, times, c = curves(al, np.full(n, 150.0), np.full(n, 60.0), STATS, v, presets.load("neutral"), model, fps)
    return v, times, c


@pytest.mark.parametrize("model", ["dominance", "rules"])
def test_pause_rests(model):
    al = phrase("HH:0.08 AA:0.2 L:0.07 OW:0.2 _:0.6 W:0.07 AA:0.2 T:0.08")
    v, times, c = run(al, model)
    ramp = pauses.settings()["rest"]["ramp"]
    a, b = al.phones[3].end, al.phones[4].start
    inside = (times >= a + ramp) & (times <= b - ramp)
    assert inside.sum() > 30
    assert c[inside].max() == 0.0
    # ... and speech is still shown right up to the pause.
    assert c[(times > al.phones[3].start) & (times < a - 0.05)].max() > 0.3


def test_gaps_and_envelope():
    g = pauses.gaps([(0.2, 0.5), (0.55, 0.9), (1.5, 2.0)], 2.4, 0.15)
    assert g == [(0.0, 0.2), (0.9, 1.5), (2.0, 2.4)]
    t = np.arange(0, 2.4, 0.01)
    env = pauses.rest_envelope(t, g, 0.05, 2.4)
    assert env[0] == 0.0 and env[-1] == 0.0                      # no ramp at the clip's ends
    assert env[np.searchsorted(t, 1.2)] == 0.0
    assert env[np.searchsorted(t, 0.7)] == 1.0
    assert 0.0 < env[np.searchsorted(t, 0.92)] < 1.0             # ramping after the last phone


@pytest.mark.parametrize("model", ["dominance", "rules"])
def test_no_closed_lips_inside_open_vowels(model):
    al = phrase("AA:0.15 B:0.06 AA:0.15 M:0.07 AE:0.12 P:0.05 AA:0.15")
    v, times, c = run(al, model)
    mbp = v.index("MBP")
    closure = coarticulation.closure_track(times, [(p.phone, p.start, p.end) for p in al.phones])
    for p in al.phones:
        inside = (times >= p.start) & (times <= p.end)
        if p.phone in ("B", "M", "P"):
            assert closure[inside].max() == 1.0 and c[inside, mbp].max() >= 0.85
        else:
            # Every vowel frame (a frame on the boundary belongs to the next
            # phone): lips neither closed by the track nor by the MBP viseme.
            inside = (times >= p.start) & (times < p.end - 1e-9)
            assert closure[inside].max() < 0.5, p
            assert c[inside, mbp].max() < 0.5, p
