"""Vowels held for seconds and said otherwise than the dictionary says (alignment/held.py)."""

import json

import numpy as np
import pytest

from addon.engine.alignment import held
from addon.engine.alignment.model import AlignedPhone, AlignedWord, Alignment
from addon.engine.audio import Audio
from addon.engine.errors import PresetError
from addon.engine.language import assimilation

RATE = 16000
MONTREAL = ["M", "AH", "N", "T", "R", "IY", "AO", "L"]


def voiced(t0, t1, total=8.0):
    """A vowel-like sound (120 Hz and its harmonics) from t0 to t1 s, silence around it."""
    t = np.arange(int(total * RATE)) / RATE
    x = np.zeros_like(t)
    on = (t >= t0) & (t < t1)
    x[on] = sum(0.2 / k * np.sin(2 * np.pi * 120 * k * t[on]) for k in range(1, 20))
    return Audio(x.astype(np.float32), RATE)


def aligned(words):
    """An alignment of ``words``: [(text, [(phone, start, end)])]."""
    out, phones = [], []
    for k, (text, ph) in enumerate(words):
        out.append(AlignedWord(text, ph[0][1], ph[-1][2], [p for p, _, _ in ph]))
        phones += [AlignedPhone(p, a, b, k) for p, a, b in ph]
    return Alignment(out, phones, 8.0)


def squeezed_then_held():
    """'montreal forced' as the aligner gives it when the held vowel is not the dictionary's: the
    first phones squeezed, AO held over the vowel, and the word's later sound (4.7-6.2 s) left off."""
    first = [(p, 1.0 + 0.03 * i, 1.03 + 0.03 * i) for i, p in enumerate(MONTREAL[:6])]
    return aligned([("montreal", first + [("AO", 1.18, 4.5), ("L", 4.5, 4.6)]),
                    ("forced", [("F", 6.2, 6.3), ("AO", 6.3, 6.6), ("R", 6.6, 6.7), ("S", 6.7, 6.8),
                                ("T", 6.8, 6.9)])])


def laid_on_the_speech():
    starts = [1.0, 1.1, 4.5, 4.7, 4.9, 5.0, 5.5, 6.1]
    ends = starts[1:] + [6.2]
    return aligned([("montreal", [(p, a, b) for p, a, b in zip(["M", "AA"] + MONTREAL[2:], starts, ends)]),
                    ("forced", [("F", 6.2, 6.3), ("AO", 6.3, 6.6), ("R", 6.6, 6.7), ("S", 6.7, 6.8),
                                ("T", 6.8, 6.9)])])


def test_a_vowel_held_for_seconds_is_found_and_a_slow_line_is_not():
    assert held.held_words(squeezed_then_held()) == [0]
    # A consonant held as long is not a vowel said otherwise.
    hum = aligned([("hmm", [("HH", 1.0, 1.1), ("M", 1.1, 4.0)]), ("so", [("S", 4.0, 4.1), ("OW", 4.1, 4.2)])])
    assert held.held_words(hum) == []
    # A line said slowly all through: every phone long, none held against the rest.
    slow = aligned([("so", [("S", 0.0, 0.5), ("OW", 0.5, 1.1)]), ("far", [("F", 1.1, 1.6), ("AA", 1.6, 2.2),
                                                                          ("R", 2.2, 2.7)])])
    assert held.held_words(slow) == []


def test_each_vowel_of_the_group_may_be_said_as_another():
    v = held.widened(MONTREAL, {"AA": ("AH", "AO"), "AH": ("AA", "AO"), "AO": ("AA", "AH")})
    assert list(v) == MONTREAL
    assert ["M", "AA", "N", "T", "R", "IY", "AO", "L"] in v.variants
    assert ["M", "AO", "N", "T", "R", "IY", "AO", "L"] in v.variants
    assert ["M", "AH", "N", "T", "R", "IY", "AA", "L"] in v.variants
    assert all(sum(a != b for a, b in zip(x, MONTREAL)) == 1 for x in v.variants)   # one vowel at a time
    assert v.shown == v.variants


def test_the_shipped_group_is_read_and_a_broken_one_is_named(tmp_path):
    alike = assimilation.held_alike()
    assert set(alike["AH"]) == {"AA", "AO"}
    doc = json.loads(assimilation.DATA.read_text(encoding="utf-8"))
    doc["held"]["alike"] = [["AA"]]
    bad = tmp_path / "assimilation.json"
    bad.write_text(json.dumps(doc), encoding="utf-8")
    with pytest.raises(PresetError, match=r"held\.alike\[0\]"):
        assimilation.held_alike(bad)


def test_the_line_is_aligned_again_and_kept_where_its_words_cover_the_speech():
    snd = voiced(1.0, 6.9)
    asked = []

    def realign(stand_in):
        asked.append(stand_in)
        return laid_on_the_speech()

    al, wider = held.said_otherwise(snd, squeezed_then_held(), [MONTREAL, ["F", "AO", "R", "S", "T"]], realign)
    assert len(asked) == 1 and list(asked[0]) == [0]
    assert ["M", "AA", "N", "T", "R", "IY", "AO", "L"] in asked[0][0].variants
    assert al.words[0].start == 1.0 and al.words[0].end == 6.2        # the word on the whole of its sound
    assert list(wider) == [0]


def test_a_second_alignment_that_covers_no_more_is_not_kept():
    snd = voiced(1.0, 6.9)
    first = squeezed_then_held()
    al, wider = held.said_otherwise(snd, first, [MONTREAL, ["F", "AO", "R", "S", "T"]],
                                    lambda stand_in: squeezed_then_held())
    assert al is first and wider == {}


def test_no_second_alignment_without_a_held_vowel_or_uncovered_speech():
    def realign(stand_in):
        raise AssertionError("aligned again")

    # The held vowel's word covers its speech: nothing to mend.
    snd = voiced(1.0, 4.6)
    first = squeezed_then_held()
    assert held.said_otherwise(snd, first, [MONTREAL, ["F", "AO", "R", "S", "T"]], realign) == (first, {})
    # No held vowel.
    plain = laid_on_the_speech()
    plain.phones[1].end = plain.phones[2].start = 1.3
    assert held.said_otherwise(voiced(1.0, 6.9), plain, [MONTREAL, ["F", "AO", "R", "S", "T"]], realign) == (plain, {})


def test_speech_left_off_elsewhere_or_a_drawn_out_hesitation_is_not_mended():
    def realign(stand_in):
        raise AssertionError("aligned again")

    # Speech left off the words, but seconds away from the word that holds the vowel.
    first = laid_on_the_speech()
    t = np.arange(int(8.0 * RATE)) / RATE
    x = voiced(1.0, 6.2).samples.copy()
    far = (t >= 7.2) & (t < 7.9)
    x[far] = 0.2 * np.sin(2 * np.pi * 150 * t[far])
    assert held.said_otherwise(Audio(x, RATE), first, [MONTREAL, ["F", "AO", "R", "S", "T"]], realign) == (first, {})
    # A hesitation drawn out beside speech left off: "uh" is long by nature.
    uh = aligned([("uh", [("AH", 1.0, 4.5)]), ("so", [("S", 6.2, 6.4), ("OW", 6.4, 6.9)])])
    assert held.held_words(uh) == []


def test_a_mended_word_s_held_vowel_is_not_searched_for_speech_around_the_script(monkeypatch):
    """After the line is aligned with the word's vowel its own, the checks of the take do not ask
    recognition whether words hide in that vowel (speech before or after the script pulling it)."""
    from addon.engine.alignment import edges
    from addon.engine.alignment.model import AlignSettings

    asked = []
    monkeypatch.setattr(edges, "words_heard", lambda snd, spans, settings: asked.append(spans) or [False] * len(spans))
    al = laid_on_the_speech()
    snd = voiced(1.0, 6.9)
    assert edges.edges(snd, al, [MONTREAL, ["F", "AO", "R", "S", "T"]], AlignSettings(), held={0}) is None
    assert asked == []
    assert edges.edges(snd, al, [MONTREAL, ["F", "AO", "R", "S", "T"]], AlignSettings()) is None
    assert len(asked) == 1 and (1.1, 4.5) in asked[0]        # without it, recognition is asked


def test_only_words_aligned_with_their_own_phones_are_said_otherwise():
    """A word aligned with stand-ins for another language's sounds keeps them."""
    def realign(stand_in):
        raise AssertionError("aligned again")

    snd = voiced(1.0, 6.9)
    first = squeezed_then_held()
    got = held.said_otherwise(snd, first, [MONTREAL, ["F", "AO", "R", "S", "T"]], realign, own={1})
    assert got == (first, {})


def test_a_long_take_is_not_aligned_again_whole_for_one_word():
    def realign(stand_in):
        raise AssertionError("aligned again")

    first = squeezed_then_held()
    long = Audio(np.concatenate([voiced(1.0, 6.9).samples, np.zeros(int((held.LONGEST - 7.0) * RATE), np.float32)]),
                 RATE)
    assert long.duration > held.LONGEST
    assert held.said_otherwise(long, first, [MONTREAL, ["F", "AO", "R", "S", "T"]], realign) == (first, {})
