import pytest

from addon.engine.language import lts
from addon.engine.errors import TranscriptError
from addon.engine.language.phonemes import strip_stress
from addon.engine.language.pronounce import Lexicon, _SortedDictionary, cmudict_path
from addon.engine.language.text import Word, normalize


def pron(word, lexicon=None):
    return (lexicon or Lexicon()).pronounce(Word(word, word))


def test_cmu_dictionary_without_stress():
    p = pron("hello")
    assert p.source == "cmudict"
    assert p.phones == ["HH", "AH", "L", "OW"]


@pytest.mark.parametrize("word, expected", [
    ("beauty's", ["B", "Y", "UW", "T", "IY", "Z"]),
    ("tatter'd", ["T", "AE", "T", "ER", "D"]),
    ("feel'st", ["F", "IY", "L", "S", "T"]),
    ("thriftless", ["TH", "R", "IH", "F", "T", "L", "AH", "S"]),
])
def test_unknown_words_derived_from_known_parts(word, expected):
    p = pron(word)
    assert p.source == "derived"
    assert p.phones == expected


def test_letter_to_sound_for_made_up_words():
    p = pron("blorptastic")
    assert p.source == "rules"
    assert p.phones[:4] == ["B", "L", "AO", "R"]
    assert "P" in p.phones and p.phones[-1] == "K"


@pytest.mark.parametrize("word, first", [("knight", "N"), ("photo", "F"), ("cheese", "CH"), ("gnome", "N")])
def test_letter_to_sound_rules(word, first):
    assert lts.spell(word)[0] == first


def test_every_word_gets_a_pronunciation():
    lx = Lexicon()
    for w in normalize("Zxqv grplfnk ooo aaa xyzzy"):
        assert lx.pronounce(w).phones


def test_inline_override_wins():
    w = normalize("hello{HH EH1 L OW0}")[0]
    p = Lexicon().pronounce(w)
    assert (p.source, p.phones) == ("inline", ["HH", "EH", "L", "OW"])


def test_inline_override_with_bad_phone_is_named():
    w = normalize("hello{HH XX L OW}")[0]
    with pytest.raises(TranscriptError, match="XX"):
        Lexicon().pronounce(w)


def test_user_dictionary_file(tmp_path):
    f = tmp_path / "user.dict"
    f.write_text(";;; my words\nquokka K W AA1 K AH0\nhello HH EH L OW\n", encoding="utf-8")
    lx = Lexicon.with_user_file(f)
    assert pron("quokka", lx).phones == ["K", "W", "AA", "K", "AH"]
    assert pron("hello", lx).source == "user"


def test_user_dictionary_errors_name_line(tmp_path):
    f = tmp_path / "bad.dict"
    f.write_text("fine F AY N\nbroken B R Q K\n", encoding="utf-8")
    with pytest.raises(TranscriptError, match="line 2.*Q"):
        Lexicon.with_user_file(f)
    with pytest.raises(TranscriptError, match="not found"):
        Lexicon.with_user_file(tmp_path / "missing.dict")


def _full_table(path):
    table = {}
    for line in open(path, encoding="utf-8").read().splitlines():
        word, _, phones = line.partition(" ")
        if "(" not in word:
            table.setdefault(word, [strip_stress(p) for p in phones.split()])
    return table


def test_cmu_dictionary_looked_up_in_place_matches_reading_it_whole():
    d = _SortedDictionary(cmudict_path())
    table = _full_table(cmudict_path())
    words = sorted(table)
    sample = words[:: max(1, len(words) // 2000)] + ["a", "the", words[0], words[-1]]
    assert [d.get(w) for w in sample] == [[table[w]] for w in sample]
    for missing in ("zzzzzzz", "", "aaaaaaaaa", "naïve"):
        assert missing not in d and d.get(missing) is None


def test_alternates_do_not_shadow_the_main_entry(tmp_path):
    path = tmp_path / "sorted.dict"
    path.write_text("a AH\na(2) EY1\na's EY1 Z\nab AE1 B\nab(2) EY1 B IY1\nabc EY1 B IY1 S IY1\n", encoding="utf-8")
    d = _SortedDictionary(path)
    assert d.get("a") == [["AH"]] and d.get("a's") == [["EY", "Z"]]
    assert d.get("ab") == [["AE", "B"]] and d.get("abc") == [["EY", "B", "IY", "S", "IY"]]
    assert d.get("aa") is None and d.get("abcd") is None


def test_an_unsorted_dictionary_is_read_into_a_table(tmp_path):
    path = tmp_path / "unsorted.dict"
    words = [f"w{i:03d}" for i in range(200)][::-1]
    path.write_text("".join(f"{w} M AA1\n" for w in words), encoding="utf-8")
    d = _SortedDictionary(path)
    assert all(d.get(w) == [["M", "AA"]] for w in words)
