"""Reduced phones (the /ð/ of "the") keep only their usual length (alignment.reduced)."""

import pytest

from addon.engine.alignment import reduced
from addon.engine.alignment.reduced import shorten_reduced


@pytest.fixture
def cap_dh(monkeypatch):
    monkeypatch.setattr(reduced, "_longest", lambda: {"DH": 0.03})


def test_long_dh_gives_its_start_to_the_word_before(cap_dh):
    # "so the": pocketsphinx's DH took the end of the OW before it.
    result = [[("S", 1.70, 1.81), ("OW", 1.81, 1.86)], [("DH", 1.86, 1.93), ("AH", 1.93, 1.99)]]
    shorten_reduced(result, [False, False])
    assert result[1][0] == ("DH", pytest.approx(1.90), 1.93)
    assert result[0][1] == ("OW", 1.81, pytest.approx(1.90))
    assert result[1][1] == ("AH", 1.93, 1.99)


def test_inside_a_word_the_phone_before_is_extended(cap_dh):
    result = [[("AH", 0.40, 0.47), ("DH", 0.47, 0.55), ("ER", 0.55, 0.70)]]
    shorten_reduced(result, [False])
    assert [p for p, _, _ in result[0]] == ["AH", "DH", "ER"]
    assert result[0][0][2] == pytest.approx(0.52) and result[0][1][1] == pytest.approx(0.52)


def test_after_a_pause_only_the_start_moves(cap_dh):
    result = [[("M", 10.16, 10.33)], [("DH", 10.51, 10.58), ("AH", 10.58, 10.62)]]
    shorten_reduced(result, [False, False])
    assert result[0] == [("M", 10.16, 10.33)]
    assert result[1][0] == ("DH", pytest.approx(10.55), 10.58)


def test_short_phones_other_phones_and_estimates_are_left_alone(cap_dh):
    result = [[("DH", 0.10, 0.12), ("AH", 0.12, 0.20)], [("Z", 0.20, 0.35)], [("DH", 0.35, 0.50)]]
    before = [list(w) for w in result]
    shorten_reduced(result, [False, False, True])
    assert result == before
    # A measured DH after an estimated word does not stretch that word.
    result = [[("AH", 0.0, 0.2)], [("DH", 0.2, 0.3), ("AH", 0.3, 0.4)]]
    shorten_reduced(result, [True, False])
    assert result[0] == [("AH", 0.0, 0.2)] and result[1][0] == ("DH", pytest.approx(0.27), 0.3)


def test_the_shipped_setting_caps_dh():
    assert reduced._longest() == {"DH": pytest.approx(0.03)}
    result = [[("OW", 0.0, 0.1)], [("DH", 0.1, 0.2), ("IH", 0.2, 0.3)]]
    shorten_reduced(result, [False, False])
    assert result[1][0][1] == pytest.approx(0.17)
