"""Words as they are said: assimilations that change what the lips do are
offered to the aligner as other pronunciations, and it chooses by the
sound."""

from __future__ import annotations

import json

import pytest

from addon.engine import audio as audio_mod
from addon.engine.alignment import core, transcript
from addon.engine.alignment.model import AlignedPhone, AlignedWord, Alignment, Variants
from addon.engine.errors import PresetError
from addon.engine.language import Lexicon, assimilation, normalize
from addon.engine.language.pronounce import Pronunciation
from conftest import SAMPLE


def test_a_nasal_after_a_labial_stop_may_be_said_with_the_lips_shut():
    assert assimilation.variants([["HH", "AE", "P", "AH", "N"]], "en") == [[(["HH", "AE", "P", "M"],) * 2]]
    assert assimilation.variants([["R", "IH", "B", "AH", "N"]], "nl") == [[(["R", "IH", "B", "M"],) * 2]]
    # Not after other sounds, and not in a language the rule does not name.
    assert assimilation.variants([["S", "EH", "V", "AH", "N"]], "nl") == [[]]
    assert assimilation.variants([["L", "AE", "P", "AH", "N"]], "fr") == [[]]


def test_german_en_after_a_labial_stop_is_always_said_with_the_lips_shut():
    """German '-en' after /p b/ ends a syllable as [m]: 'Lappen' [lapm], 'Abend' [a:bmt], their stand-ins
    and shown phones alike, and is no longer a choice; before a vowel of the word it stays ('benutzen')."""
    lappen, liegt = ["L", "AE", "P", "AH", "N"], ["L", "IY", "K", "T"]
    said = assimilation.said([lappen, liegt, ["AE", "B", "AH", "N", "T"]], "de",
                             [["L", "AA", "P", "AH", "N"], liegt, ["AA", "B", "AH", "N", "T"]])
    assert said == [(["L", "AE", "P", "M"], ["L", "AA", "P", "M"]), (liegt, liegt),
                    (["AE", "B", "M", "T"], ["AA", "B", "M", "T"])]
    # At the end of a word whatever follows, vowel or not.
    assert assimilation.said([lappen, ["AY", "N"]], "de")[0][0] == ["L", "AE", "P", "M"]
    benutzen = ["B", "AH", "N", "UH", "T", "S", "AH", "N"]
    assert assimilation.said([benutzen], "de") == [(benutzen, benutzen)]
    assert assimilation.variants([lappen, liegt], "de") == [[], []]
    # English 'happen' is not always said so: it stays a choice the sound makes.
    assert assimilation.said([["HH", "AE", "P", "AH", "N"]], "en")[0][0] == ["HH", "AE", "P", "AH", "N"]


def test_a_german_line_is_aligned_and_shown_with_the_lips_shut_in_lappen():
    lex = Lexicon.with_user_file(None, "de")
    prons = transcript.always_said([lex.pronounce(w) for w in normalize("Der Lappen liegt", lex.language)], "de")
    assert prons[1].aligned[-1] == "M" and prons[1].phones[-1] == "M" and "N" not in prons[1].phones
    # Written out by the user, a word keeps its phones.
    written = transcript.always_said([Pronunciation("lappen", ["L", "AA", "P", "AH", "N"], "inline")], "de")
    assert written[0].phones == ["L", "AA", "P", "AH", "N"]


def test_n_before_a_labial_may_be_said_m_within_a_word_and_across_words():
    (input_,) = assimilation.variants([["IH", "N", "P", "UH", "T"]], "en")
    assert input_ == [(["IH", "M", "P", "UH", "T"],) * 2]
    in_, bonn = assimilation.variants([["IH", "N"], ["B", "AO", "N"]], "es")
    assert in_ == [(["IH", "M"],) * 2] and bonn == []
    assert assimilation.variants([["IH", "N"], ["D", "AO", "N"]], "es") == [[], []]


def test_the_rules_together_and_a_studios_own_file(tmp_path):
    # Dutch "lobben" [lobm] beside "n" before "b"; English "button" with a syllabic nasal.
    assert (["L", "AO", "B", "M", "B"],) * 2 in assimilation.variants([["L", "AO", "B", "AH", "N", "B"]], "nl")[0]
    assert assimilation.variants([["B", "AH", "T", "AH", "N"]], "en") == [[(["B", "AH", "T", "N"],) * 2]]
    bad = tmp_path / "rules.json"
    bad.write_text(json.dumps({"rules": [{"name": "no match"}]}))
    with pytest.raises(PresetError, match=r"rules\[0\].*'match' and 'becomes'"):
        assimilation.rules(bad)
    bad.write_text(json.dumps({"rules": [{"match": ["N"], "becomes": ["M"], "always": "yes"}]}))
    with pytest.raises(PresetError, match=r"rules\[0\]\.always.*true or false"):
        assimilation.rules(bad)


def test_pronunciations_written_out_are_said_as_written():
    lex = Lexicon()
    prons = [lex.pronounce(w) for w in normalize("happen /hæpən/", lex.language)]
    given = transcript.said_as(prons, "en")
    assert isinstance(given[0], Variants) and given[0].variants == [["HH", "AE", "P", "M"]]
    assert not isinstance(given[1], Variants)


def test_the_aligner_chooses_the_pronunciation_that_fits_the_sound():
    """'name' offered as a wrong pronunciation and the right one: the word is aligned, and shown, as the
    one its sound holds."""
    snd = audio_mod.load(SAMPLE / "hello.wav")
    lex = Lexicon()
    words = normalize("Hello! My name is Bob.", lex.language)
    phones = [lex.pronounce(w).phones for w in words]
    k = [w.text for w in words].index("name")
    phones[k] = Variants(["S", "UW", "P"], [["N", "EY", "M"]])
    al = core.align(snd.within(0.0, 2.1), phones, texts=[w.text for w in words])
    assert al.words[k].phones == ["N", "EY", "M"]
    assert [p.phone for p in al.phones if p.word_index == k] == ["N", "EY", "M"]


def test_a_word_read_from_ipa_shows_the_phones_of_the_pronunciation_chosen():
    """German 'Lappen' aligned by English stand-ins: where the aligner chose [lapm], the mouth shows the
    word's own phones of that pronunciation."""
    pron = Pronunciation("lappen", ["L", "AA", "P", "AH", "N"], "espeak", ["L", "AE", "P", "AH", "N"])
    given = Variants(pron.aligned, [["L", "AE", "P", "M"]], [["L", "AA", "P", "M"]])
    phones = [AlignedPhone(p, 0.1 * i, 0.1 * (i + 1), 0) for i, p in enumerate(["L", "AE", "P", "M"])]
    al = Alignment([AlignedWord("lappen", 0.0, 0.4, list(pron.aligned), "espeak")], phones, 0.4)
    transcript._show(al, [pron], [given])
    assert [p.phone for p in al.phones] == ["L", "AA", "P", "M"] and al.words[0].phones == ["L", "AA", "P", "M"]
