"""The aligner's pocketsphinx decoders are kept from one line to the next
(alignment.decoding): a line comes out exactly as from a decoder made afresh,
whatever was aligned before it."""

import threading

from conftest import FIXTURES, SAMPLE
from addon.engine import audio as audio_mod
from addon.engine.alignment import AlignSettings, decoding
from addon.engine.pipeline import analyze


def _phones(snd, text):
    al = analyze(snd, text).alignment
    return [(p.phone, p.start, p.end, p.word_index) for p in al.phones], [w.fit for w in al.words]


def _fresh():
    decoding._KEPT.kept = None


def test_a_line_aligns_alike_after_other_lines():
    bob = audio_mod.load(FIXTURES / "bob_map.wav")
    hello = audio_mod.load(SAMPLE / "hello.wav")
    bob_text = (FIXTURES / "bob_map.txt").read_text()
    hello_text = (SAMPLE / "hello.txt").read_text()
    _fresh()
    first = _phones(bob, bob_text)          # the first line of a process: every decoder made afresh
    assert decoding._KEPT.kept.free         # ... and kept afterwards
    uses = decoding._KEPT.kept.uses
    _phones(hello, hello_text)              # other speech, other words, noise removal learning from it
    _phones(bob, "Bob")                     # the same audio, other words
    again = _phones(bob, bob_text)
    assert decoding._KEPT.kept.uses > uses
    assert again == first


def test_one_decoder_is_kept_a_configuration():
    _fresh()
    settings = AlignSettings()
    a = decoding._decoder([["HH", "AH"]], 0, settings)
    b = decoding._decoder([["HH", "AH"]], 0, settings)     # in use at once: another decoder
    assert a._decoder is not b._decoder
    kept_a = a._decoder
    del a, b
    free = decoding._KEPT.kept.free
    assert sum(len(v) for v in free.values()) == 1
    c = decoding._decoder([["B", "AA", "B"]], 0, settings)
    assert c._decoder is kept_a
    other = decoding._decoder([["B"]], 0, settings, wip=1e-3)  # another configuration: its own decoder
    assert other._decoder is not kept_a


def test_words_of_each_use_keep_their_names_and_pronunciations():
    """Every use names its words w0, w1...; each is aligned with its own phones, not an earlier use's."""
    _fresh()
    snd = audio_mod.load(FIXTURES / "bob_map.wav")
    pcm = snd.pcm16(0, snd.duration)
    settings = AlignSettings()
    for prons in ([["B", "AA", "B"], ["B", "AO", "T"], ["AH"], ["M", "AE", "P"]],
                  [["M", "AE", "P"], ["AH"], ["B", "AA", "B"], ["B", "AO", "T"]]):
        dec = decoding._decoder(prons, 0, settings)
        tokens = [f"w{k}" for k in range(len(prons))]
        first = decoding._word_pass(dec, pcm, "all", tokens, "all")
        assert first[0] == "words" and first[3] == tokens
        phones = decoding._phone_pass(dec, pcm, tokens)
        assert [[p for p, *_ in w] for w in phones] == prons
        del dec


def test_an_entry_without_phones_or_with_unknown_ones_is_passed_over():
    """As when pocketsphinx reads a dictionary file (a word added with no phones would crash it)."""
    _fresh()
    snd = audio_mod.load(FIXTURES / "bob_map.wav")
    dec = decoding._decoder([["B", "AA", "B"]], 0, AlignSettings(), more=["x0", "x1 QQ", "x2 AH"])
    assert dec._names == {"w0", "x2"}
    dec.set_align_text("w0")
    dec.start_utt()
    dec.process_raw(snd.pcm16(0, 0.4), full_utt=True)
    dec.end_utt()
    assert [sg.word for sg in dec.seg() if sg.word.startswith("w")] == ["w0"]


def test_each_thread_keeps_its_own():
    _fresh()
    mine = decoding._decoder([["AH"]], 0, AlignSettings())._decoder
    theirs = []
    t = threading.Thread(target=lambda: theirs.append(decoding._decoder([["AH"]], 0, AlignSettings())._decoder))
    t.start()
    t.join()
    assert theirs and theirs[0] is not mine


def test_kept_decoders_are_set_aside_when_their_dictionary_grows_large(monkeypatch):
    _fresh()
    monkeypatch.setattr(decoding, "MOST_WORDS", 3)
    a = decoding._decoder([["AH"], ["B"]], 0, AlignSettings())
    first = a._decoder
    del a
    b = decoding._decoder([["AH"], ["B"]], 0, AlignSettings())     # 4 words added in all now
    assert b._decoder is first
    del b
    c = decoding._decoder([["AH"]], 0, AlignSettings())
    assert c._decoder is not first
