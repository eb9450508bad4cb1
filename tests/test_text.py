import pytest

from addon.engine.errors import TranscriptError
from addon.engine.language.text import normalize


def spoken(text):
    return " ".join(w.text for w in normalize(text))


@pytest.mark.parametrize("script, expected", [
    ("$5", "five dollars"),
    ("$1.01", "one dollar and one cent"),
    ("£20", "twenty pounds"),
    ("It cost $3.5m", "it cost three point five million dollars"),
    ("in 1999", "in nineteen ninety nine"),
    ("in 2005", "in two thousand five"),
    ("by 1900", "by nineteen hundred"),
    ("the 3rd time", "the third time"),
    ("her 21st birthday", "her twenty first birthday"),
    ("50% off", "fifty percent off"),
    ("1,234 people", "one thousand two hundred thirty four people"),
    ("3.14", "three point one four"),
    ("at 10:30", "at ten thirty"),
    ("Mr. Smith and Dr. Jones", "mister smith and doctor jones"),
    ("St. Paul lives on Baker St.", "saint paul lives on baker street"),
    ("rock & roll", "rock and roll"),
    ("a well-known fact", "a well known fact"),
])
def test_spelled_out(script, expected):
    assert spoken(script) == expected


def test_curly_quotes_become_apostrophes():
    assert spoken("It\u2019s Bob\u2019s \u201cthing\u201d") == "it's bob's thing"


def test_stage_directions_are_not_spoken():
    assert spoken("[sighs] Well (beat) fine. *laughs* OK") == "well fine ok"


def test_pause_hints_from_punctuation():
    words = normalize("Wait, what? No; never.")
    hints = {w.text: w.pause_after for w in words}
    assert hints["wait"] == pytest.approx(0.4)
    assert hints["what"] == 1.0
    assert hints["no"] == pytest.approx(0.6)
    assert hints["never"] == 1.0


def test_inline_pronunciation():
    words = normalize("A quokka{K W AA1 K AH0} and {HH M} hum")
    assert [w.text for w in words] == ["a", "quokka", "and", "{HH M}", "hum"]
    assert words[1].phones == ["K", "W", "AA1", "K", "AH0"]
    assert words[3].phones == ["HH", "M"]


def test_roman_numeral_heading_line():
    assert spoken("II\nWhen forty winters") == "two when forty winters"
    assert spoken("I said II things") == "i said ii things"  # only a line of its own is a heading


@pytest.mark.parametrize("text", ["", "   \n", "[laughs]", "...!?"])
def test_nothing_speakable_is_an_error(text):
    with pytest.raises(TranscriptError):
        normalize(text)
