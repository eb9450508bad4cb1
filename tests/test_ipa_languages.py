"""IPA phone labels of many languages, as multilingual forced aligners write
them, imported from generated TextGrids and shown with sensible visemes."""

import pytest

from addon.engine import visemes
from addon.engine.errors import UnknownLabelError
from addon.engine.importers import read_textgrid
from addon.engine.language.ipa import to_arpabet

# One short phrase per language, phone by phone, in Montreal Forced Aligner's
# IPA phone sets (length, tone letters, palatalisation and nasal marks kept).
PHRASES = {
    "german": "ɡ uː t ə n m ɔ ʁ ɡ ə n ç ʏ ʃ øː n ə yː b ʊ ŋ ts v aɪ",
    "french": "b ɔ̃ ʒ u ʁ m ɛ̃ t y ɑ̃ p œ̃ ɥ i ø ʃ a",
    "spanish": "b u e n o s ð i a s ɾ a β a ɣ o r o x",
    "portuguese": "b õ j d i ɐ̃ w̃ ʎ ɲ ɾ ʁ ɨ ɛ ɔ ʃ ʒ",
    "italian": "p a pː a m aː mː a tʃː ɔ dʒ ʎː i ɲː o ts",
    "japanese": "k o ɲ ɲ i tɕ i w a ɯ ɕ i ɴ ɸ ɯ dʑ i ɾʲ a i̥ mʲ a",
    "mandarin": "n i˨˩ x au˨˩ ʈʂʰ ɤ˥ ɕ j e˥˩ tɕʰ y˧˥ m a˥ p a˥˩",
    "russian": "p rʲ i vʲ e t ʂ ɨ ɕː ɐ dʲ æ lʲ ɫ o tʲ sʲ ʊ m",
}


def grid(labels: list[str], step: float = 0.1) -> str:
    n = len(labels)
    rows = "".join(f"{k * step:.3f}\n{(k + 1) * step:.3f}\n\"{lab}\"\n" for k, lab in enumerate(labels))
    return ("File type = \"ooTextFile\"\nObject class = \"TextGrid\"\n\n0\n"
            f"{n * step:.3f}\n<exists>\n1\n\"IntervalTier\"\n\"phones\"\n0\n{n * step:.3f}\n{n}\n" + rows)


@pytest.fixture(scope="module")
def vset():
    return visemes.load("default")


@pytest.mark.parametrize("language", sorted(PHRASES))
def test_textgrid_of_each_language_imports(tmp_path, language, vset):
    labels = PHRASES[language].split()
    f = tmp_path / f"{language}.TextGrid"
    f.write_text(grid(labels), encoding="utf-8")
    al = read_textgrid(f)
    assert len(al.phones) >= len(labels)
    for p in al.phones:
        assert vset.of(p.phone), p.phone
    # Every bilabial stop or nasal closes the lips; nothing else does.
    closing = [lab for lab in labels if lab.rstrip("ːʲ")[:1] in "pbm"]
    assert sum(p.phone in ("P", "B", "M") for p in al.phones) == len(closing)


def viseme(label: str, vset) -> list[str]:
    return [v for p in to_arpabet(label) for v in vset.of(p)]


def test_rounded_vowels_are_rounded(vset):
    for label in ("y", "yː", "ʏ", "u", "ʉ", "ø", "øː", "o", "ɔ̃", "œ̃", "ɥ", "w"):
        assert set(viseme(label, vset)) & {"UUU", "OHH"}, label
    for label in ("i", "iː", "e", "ɛ", "a", "ɑ̃", "ɯ", "ɨ", "ɐ̃", "ɛ̃"):
        assert not set(viseme(label, vset)) & {"UUU", "OHH"}, label


def test_nasal_vowels_are_open(vset):
    for label in ("ɑ̃", "ɛ̃", "ɔ̃", "œ̃", "ɐ̃", "õ"):
        assert viseme(label, vset)[0] in {"AHH", "EH", "OHH"}, label


def test_lip_closures_and_what_is_not_one(vset):
    for label in ("m", "mː", "mʲ", "p", "pː", "b", "bʲ", "ɓ"):
        assert viseme(label, vset) == ["MBP"], label
    for label in ("ʁ", "ʀ", "χ", "ɾ", "r", "ç", "x", "ɣ", "ɴ", "ŋ", "ɲ", "ʎ", "β", "ɸ"):
        assert "MBP" not in viseme(label, vset), label
    assert viseme("f", vset) == viseme("ɱ", vset) == ["FV"]


def test_affricates_diphthongs_geminates_and_tones():
    assert to_arpabet("t͡ʃ") == to_arpabet("tʃ") == to_arpabet("ʧ") == ["CH"]
    assert to_arpabet("tɕʰ") == ["CH"] and to_arpabet("dʑ") == ["JH"]
    assert to_arpabet("aɪ") == to_arpabet("aj") == ["AY"]
    assert to_arpabet("tː") == to_arpabet("tt") == ["T"]
    assert to_arpabet("a˥˩") == to_arpabet("a51") == to_arpabet("ˈaː") == ["AA"]
    assert to_arpabet("ɚ") == to_arpabet("ə˞") == ["ER"]
    assert to_arpabet("x") == ["HH"]


def test_a_word_written_in_ipa_keeps_every_written_segment():
    # One phone label is one segment: its affricate, diphthong or doubled symbol is one phone.  A word
    # is segmented as written: two symbols are one phone only when tied or written as one ligature.
    def word(ipa: str) -> list[str]:
        return to_arpabet(ipa, word=True)

    assert word("daja") == ["D", "AA", "Y", "AA"] and to_arpabet("daja") == ["D", "AY", "AA"]
    assert word("tʃa") == ["T", "SH", "AA"]
    assert word("t͡ʃa") == word("ʧa") == ["CH", "AA"]
    assert word("baɪ") == ["B", "AA", "IH"] and word("ba͡ɪ") == ["B", "AY"]
    assert word("ɔ̀ɔ́m") == ["AO", "AO", "M"] and word("matta") == ["M", "AA", "T", "T", "AA"]
    assert word("maːt") == ["M", "AA", "T"]          # length is a mark, not a segment
    assert word("kʰɛsəbə") == to_arpabet("kʰɛsəbə")
    assert word("k͡pa") == ["K", "P", "AA"]           # a tie that makes no English phone: both shown


def test_a_labialised_consonant_in_a_written_word_rounds_the_lips_after_it():
    # Columbia-Wenatchi "t'əkʷp": the lips round through the release of kʷ before the p closes them.
    assert to_arpabet("tʼəkʷp", word=True) == ["T", "AH", "K", "W", "P"]
    assert to_arpabet("ŋʷa", word=True) == ["NG", "W", "AA"]
    assert to_arpabet("wʷa", word=True) == ["W", "AA"]    # rounded already: no second W
    assert to_arpabet("kʷ") == ["K"]                       # a phone label stays one phone


def test_a_symbol_that_is_not_ipa_is_named_with_file_and_time(tmp_path):
    f = tmp_path / "bad.TextGrid"
    f.write_text(grid(["ʁ", "aQ", "n"]), encoding="utf-8")
    with pytest.raises(UnknownLabelError, match=r"'aQ' in bad.TextGrid at 0.100 s: 'Q' is not an IPA symbol"):
        read_textgrid(f)
