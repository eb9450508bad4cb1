"""Transcripts in other languages: language codes, spelling to phones with
eSpeak NG, words written in IPA, the --language option and the manifest's
language column, and lines spoken by eSpeak NG aligned end to end."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from addon.engine import LineSettings, analyze, batch
from addon.engine.audio import from_samples
from addon.engine.errors import LipSyncError, TranscriptError
from addon.engine.language import Lexicon, espeak, languages, normalize, resolve_language, skipped_words
from conftest import write_wav

ROOT = Path(__file__).resolve().parent.parent
FIX = ROOT / "tests" / "fixtures"


def phones(text: str, language: str) -> list[tuple[str, list[str]]]:
    lex = Lexicon.with_user_file(None, language)
    return [(w.text, lex.pronounce(w).phones) for w in normalize(text, language)]


def spoken(text: str, voice: str, pad: float = 0.3):
    """``text`` spoken by eSpeak NG's voice, with silence around it, as the engine's Audio."""
    samples, rate = espeak.synthesize(text, voice)
    silence = np.zeros(int(pad * rate), np.float32)
    line = np.concatenate([silence, samples.astype(np.float32) / 32768.0, silence])
    # A room's noise floor (-60 dBFS): digital silence is not what a microphone records.
    line += np.random.default_rng(0).normal(0.0, 1e-3, line.size).astype(np.float32)
    return from_samples(line, rate)


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "addon", *map(str, args)], cwd=ROOT, capture_output=True,
                          text=True, timeout=300)


# -- codes -------------------------------------------------------------------

@pytest.mark.parametrize("code, expected", [
    ("de", "de"), ("deu", "de"), ("ger", "de"), ("DE-at", "de"), ("de_CH", "de"),
    ("pt-BR", "pt-BR"), ("pt_br", "pt-BR"), ("pt", "pt"), ("por", "pt"), ("pt-PT", "pt"),
    ("zh", "zh"), ("cmn", "zh"), ("zh-Hant-TW", "zh"), ("zh-yue", "yue"), ("ja", "ja"), ("jpn", "ja"),
    ("en", "en"), ("en-GB", "en"), ("eng", "en"), (None, "en"), ("", "en"), ("es-MX", "es-419"),
])
def test_codes_as_users_write_them(code, expected):
    assert resolve_language(code).code == expected


def test_unknown_code_lists_the_supported_ones():
    with pytest.raises(LipSyncError) as err:
        resolve_language("klingonish")
    msg = str(err.value)
    assert "unknown language 'klingonish'" in msg
    assert "de (German)" in msg and "ja (Japanese)" in msg and "zh (Mandarin Chinese)" in msg
    assert "\n" not in msg


def test_every_language_of_the_table_is_read_by_espeak():
    table = languages.table()
    assert len(table) >= 30
    for code in "de fr es it pt ru pl nl sv tr ja zh ko ar hi".split():
        assert code in table
    for code, lang in table.items():
        if lang.is_english:
            continue
        # Digits are read as words of the language: never empty, never letters spelled out in English.
        assert len(espeak.pronounce("7", lang.espeak, lang.phone_fixes)) >= 2, code


# -- spelling to phones, per language family ----------------------------------

def test_germanic_spelling_and_numbers():
    got = dict(phones("Mein Bruder baut 23 Boote.", "de"))
    assert got["mein"] == ["M", "AY", "N"]
    assert got["baut"] == ["B", "AW", "T"]
    # 23 is "dreiundzwanzig": drei ... zwanzig, in German.
    assert got["23"][:2] == ["D", "AY"] and " T S V AA N T S IH SH" in " ".join(got["23"])
    assert dict(phones("Mijn moeder", "nl"))["moeder"][:2] == ["M", "UW"]
    assert dict(phones("Mamma bor i Malmö.", "sv"))["mamma"] == ["M", "AA", "M", "AA"]


def test_romance_spelling_and_numbers():
    es = dict(phones("Mi madre bebe 5 botellas.", "es"))
    assert es["5"] == ["TH", "IY", "N", "K", "OW"]          # cinco, Castilian
    assert dict(phones("5", "es-MX"))["5"][0] == "S"        # cinco, Latin American
    assert es["bebe"][0] == "B" and es["botellas"][:2] == ["B", "OW"]
    fr = dict(phones("Mon père mange du pain.", "fr"))
    assert fr["mon"] == ["M", "AO"] and fr["pain"][0] == "P" and fr["du"] == ["D", "UW"]
    assert dict(phones("Mio padre", "it"))["padre"] == ["P", "AA", "D", "R", "EH"]
    assert dict(phones("Minha mãe", "pt-BR"))["minha"][0] == "M"


def test_slavic_turkic_semitic_and_indic_scripts():
    assert dict(phones("Мама мыла раму.", "ru"))["мама"] == ["M", "AA", "M", "AA"]
    assert dict(phones("Mój brat", "pl"))["brat"] == ["B", "R", "AA", "T"]
    assert dict(phones("Benim babam", "tr"))["babam"] == ["B", "AA", "B", "AA", "M"]
    assert dict(phones("بابا", "ar"))["بابا"] == ["B", "AA", "B", "AA"]
    hi = dict(phones("मेरा भाई पानी पीता है", "hi"))
    assert hi["पानी"] == ["P", "AA", "N", "IY"] and hi["भाई"][0] == "B"


def test_east_asian_scripts():
    ko = dict(phones("엄마 밥", "ko"))
    assert ko["밥"] == ["P", "AH", "P"] and "M" in ko["엄마"]
    # A run of Han characters between punctuation is one word in Chinese; Japanese is cut into words.
    zh = phones("妈妈买面包。你好！", "zh")
    assert [w for w, _ in zh] == ["妈妈买面包", "你好"]
    assert zh[0][1][:4] == ["M", "AA", "M", "AA"] and zh[0][1][-2] == "P"
    ja = phones("ママはパンをたべます。", "ja")
    assert ja[0] == ("ママ", ["M", "AA", "M", "AA"]) and ja[2] == ("パン", ["P", "AA", "NG"])
    assert "".join(w for w, _ in ja) == "ママはパンをたべます" and "B" in ja[-1][1]


def test_japanese_is_cut_into_words_and_kanji_read():
    lex = Lexicon.with_user_file(None, "ja")
    words = normalize("私の名前はマリです。東京に行きました", "ja")
    assert [w.text for w in words] == ["私", "の", "名前", "は", "マリ", "です", "東京", "に", "行き", "ました"]
    got = {w.text: lex.pronounce(w).phones for w in words}
    assert got["私"] == ["W", "AA", "T", "AA", "SH", "IY"]          # watashi
    assert got["名前"][:4] == ["N", "AA", "M", "AA"]                # namae
    assert got["は"] == ["W", "AA"]                                 # the topic particle is "wa"
    assert got["マリ"][0] == "M"


def test_japanese_kanji_without_pykakasi_ask_for_their_reading(monkeypatch):
    from addon.engine.language import japanese

    monkeypatch.setattr(japanese, "_kakasi", lambda: None)
    monkeypatch.setattr(japanese, "_KAKASI", None)
    from addon.engine.language import pronounce

    monkeypatch.setattr(pronounce, "_SPOKEN", {})
    words = normalize("日本語です。ママ", "ja")
    assert [w.text for w in words] == ["日本語です", "ママ"]        # without it a run is one word
    lex = Lexicon.with_user_file(None, "ja")
    with pytest.raises(TranscriptError, match="kanji need their reading, and pykakasi is not installed"):
        lex.pronounce(words[0])
    assert lex.pronounce(words[1]).phones == ["M", "AA", "M", "AA"]


def test_pause_punctuation_stage_directions_and_symbols_in_other_languages():
    words = normalize("Hola, (se ríe) ¿qué tal? 😀 Bien.", "es")
    assert [w.text for w in words] == ["hola", "qué", "tal", "bien"]
    assert [w.pause_after for w in words] == [0.4, 0.0, 1.0, 1.0]
    assert skipped_words("Hola 😀", "es") == [("😀", "an emoji or symbol, not a word")]
    assert [w.pause_after for w in normalize("你好，我是。", "zh")] == [0.4, 1.0]


def test_user_dictionary_and_inline_phones_shadow_espeak(tmp_path):
    d = tmp_path / "dict.txt"
    d.write_text("tschüss T SH UW S\n", encoding="utf-8")
    lex = Lexicon.with_user_file(d, "de")
    w = normalize("Tschüss Papa{P AA P AA1}", "de")
    assert [(p.phones, p.source) for p in map(lex.pronounce, w)] == [
        (["T", "SH", "UW", "S"], "user"), (["P", "AA", "P", "AA"], "inline")]


# -- IPA between slashes ------------------------------------------------------

@pytest.mark.parametrize("language", ["en", "de", "ja"])
def test_a_word_between_slashes_is_its_ipa(language):
    words = normalize("ok /pɛs/ /kʰɛsəbə/, /bɛ:t'/", language)
    lex = Lexicon.with_user_file(None, language)
    got = [(w.text, lex.pronounce(w).phones, lex.pronounce(w).source) for w in words[1:]]
    assert got == [("/pɛs/", ["P", "EH", "S"], "ipa"),
                   ("/kʰɛsəbə/", ["K", "EH", "S", "AH", "B", "AH"], "ipa"),
                   ("/bɛ:t'/", ["B", "EH", "T"], "ipa")]   # ':' is length, "'" the ejective mark
    assert words[2].pause_after == 0.4


def test_slashes_that_are_not_ipa_words():
    # Between words they are not IPA.
    assert [w.text for w in normalize("either/or")] == ["either", "or"]
    with pytest.raises(TranscriptError, match=r"'/p@s/' is not IPA: '@'"):
        normalize("say /p@s/")


def test_english_is_the_default_and_unchanged():
    text = (FIX / "bob_map.txt").read_text()
    default = analyze(FIX / "bob_map.wav", text)
    english = analyze(FIX / "bob_map.wav", text, LineSettings.of(language="eng"))
    assert default.to_dict() == english.to_dict()
    assert default.to_dict()["language"] == "en"
    assert [w.source for w in default.alignment.words] == ["cmudict"] * 4


# -- whole lines --------------------------------------------------------------

LINES = [
    ("de", "de", "Guten Morgen, mein Name ist Paul und ich bin müde."),
    ("es", "es", "Buenos días, me llamo Pablo y vivo en Madrid."),
    ("ja", "ja", "こんにちは、わたしのなまえはまりです。"),
    ("ja", "ja", ("私の名前はマリです。毎晩パンを食べます。", "わたしのなまえわまりです。まいばんぱんをたべます。")),
    ("zh", "cmn", "你好，我叫马明，我们吃饭吧。"),
    ("ru", "ru", "Мама мыла раму, а папа пил молоко."),
]


@pytest.mark.parametrize("code, voice, text", LINES, ids=[f"{c}{k}" for k, (c, _, _) in enumerate(LINES)])
def test_a_spoken_line_is_aligned_and_the_lips_close(code, voice, text):
    text, said = text if isinstance(text, tuple) else (text, text)   # kanji: eSpeak NG speaks the kana
    snd = spoken(said, voice)
    result = analyze(snd, text, LineSettings.of(language=code, fps=100))
    doc = result.to_dict()
    assert doc["language"] == code
    words = normalize(text, code)
    assert [w["word"] for w in doc["words"]] == [w.text for w in words]
    assert not any(w["estimated"] for w in doc["words"])
    # Each word shows the phones of its mouth, whatever stand-in the English acoustic model looked for
    # ([e] is aligned as EY, [a] as AE, and shown as EH, AA).
    lex = Lexicon.with_user_file(None, code)
    for k, w in enumerate(words):
        assert [p.phone for p in result.alignment.phones if p.word_index == k] == lex.pronounce(w).phones
    assert {"EH", "AA"} & {p.phone for p in result.alignment.phones} and not \
        {"EY", "AE"} & {p.phone for p in result.alignment.phones}
    # The words follow each other inside the speech.
    starts = [w["start"] for w in doc["words"]]
    assert starts == sorted(starts) and starts[0] >= 0.2 and doc["words"][-1]["end"] <= snd.duration - 0.2
    # The lips close during each /p b m/.
    closing = [p for p in result.alignment.phones if p.phone in ("P", "B", "M")]
    assert closing
    for p in closing:
        inside = (result.times >= p.start - 0.03) & (result.times <= p.end + 0.03)
        assert result.closure[inside].max() >= 0.5, (p.phone, p.start)


def test_cli_language_option_and_its_errors(tmp_path):
    wav = tmp_path / "de.wav"
    snd = spoken("Mama baut ein Boot.", "de")
    write_wav(wav, snd.samples, snd.rate)
    out = tmp_path / "de.json"
    r = _cli("analyze", wav, "--text", "Mama baut ein Boot.", "--language", "deu", "--json", out, "--quiet")
    assert r.returncode == 0, r.stderr
    doc = json.loads(out.read_text())
    assert doc["language"] == "de" and [w["word"] for w in doc["words"]] == ["mama", "baut", "ein", "boot"]
    r = _cli("analyze", wav, "--text", "Mama", "--language", "xx-YY", "--json", tmp_path / "x.json")
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert r.stderr.startswith("error: --language: unknown language 'xx-YY'") and "de (German)" in r.stderr
    assert not (tmp_path / "x.json").exists()
    r = _cli("list")
    assert "languages:" in r.stdout and "pt-BR (Portuguese (Brazil))" in r.stdout


def test_batch_language_column(tmp_path):
    for name, voice, text in (("de", "de", "Mein Bruder baut Boote."), ("es", "es", "Mi madre bebe mucho."),
                              ("en", "en-us", "Bob bought a map.")):
        snd = spoken(text, voice)
        write_wav(tmp_path / f"{name}.wav", snd.samples, snd.rate)
    (tmp_path / "m.csv").write_text(
        "audio,text,language\n"
        "de.wav,Mein Bruder baut Boote.,de\n"
        "es.wav,Mi madre bebe mucho.,\n"               # the command's --language
        "en.wav,Bob bought a map.,en\n"
        "de.wav,Mein Bruder baut Boote.,xx\n", encoding="utf-8")
    r = _cli("batch", tmp_path / "m.csv", "--language", "spa", "--out", tmp_path / "out", "--workers", "1")
    assert r.returncode == 1, r.stderr
    failed = [ln for ln in r.stderr.splitlines() if ln.startswith("failed:")]
    assert len(failed) == 1 and failed[0].startswith("failed: line 5") and "unknown language 'xx'" in failed[0]
    docs = {n: json.loads((tmp_path / "out" / f"{n}.json").read_text()) for n in ("de", "es", "en")}
    assert {n: d["language"] for n, d in docs.items()} == {"de": "de", "es": "es", "en": "en"}
    assert [w["word"] for w in docs["es"]["words"]] == ["mi", "madre", "bebe", "mucho"]
    assert docs["de"]["produced_by"]["row"]["language"] == "de"
    assert docs["es"]["produced_by"]["settings"]["language"] == "spa"
    assert "language" not in docs["en"]["produced_by"]["settings"]
    # A second run finds every line up to date; another --language redoes the line that follows it.
    lines = batch.read_manifest(tmp_path / "m.csv", out_dir=str(tmp_path / "out"))
    spanish = LineSettings.of(language="spa")
    assert [batch.up_to_date(ln, spanish) for ln in lines[:3]] == [True, True, True]
    assert [batch.up_to_date(ln, LineSettings.of(language="pt")) for ln in lines[:3]] == [True, False, True]


def test_unknown_manifest_columns_are_errors(tmp_path):
    (tmp_path / "m.csv").write_text("audio,text,lang,speaker\na.wav,hallo,de,Ann\n", encoding="utf-8")
    with pytest.raises(LipSyncError) as err:
        batch.read_manifest(tmp_path / "m.csv")
    assert "unknown columns 'lang', 'speaker'" in str(err.value) and "language" in str(err.value)
    r = _cli("batch", tmp_path / "m.csv")
    assert r.returncode == 1 and r.stderr.startswith("error: manifest ") and "'lang'" in r.stderr
    (tmp_path / "m.jsonl").write_text('{"audio": "a.wav", "text": "hallo", "Lang": "de"}\n'
                                      '{"audio": "b.wav", "text": "hallo", "language": "de"}\n', encoding="utf-8")
    first, second = batch.read_manifest(tmp_path / "m.jsonl")
    assert first.problem.startswith("unknown field 'lang'")
    assert second.problem is None and second.language == "de"


def test_unscripted_speech_in_another_language_is_animated_without_english_words():
    scripted = "Morgen früh bringt meine Mutter Brot und Milch mit."
    adlib = "Danach gehen wir zusammen in den großen Park und spielen Fußball bis zum Abend."
    snd = spoken(scripted + " " + adlib, "de")
    said = spoken(scripted, "de").duration - 0.3        # where the scripted sentence ends
    r = analyze(snd, scripted, LineSettings.of(language="de"))
    al = r.alignment
    # The transcript's words stay on their own speech (speech after the script's end no longer pulls the last
    # of them seconds later: alignment.tail), and the ad-lib is unscripted.
    assert max(w.end for w in al.words if not w.recognized) <= said + 0.1
    grid = np.arange(said + 0.3, snd.duration - 0.4, 0.01)
    inside = np.zeros(len(grid), bool)
    for a, b, _ in al.unscripted:
        inside |= (grid >= a) & (grid < b)
    assert inside.mean() >= 0.9, inside.mean()
    assert all(text == "" for _, _, text in al.unscripted)
    heard = [w for w in al.words if w.recognized]
    assert heard and all(w.text == "" for w in heard)
    assert {p.word_index for p in al.phones} >= {al.words.index(w) for w in heard}   # their phones animate them
    assert any("English only" in w and "not in the transcript" in w for w in r.warnings)
    assert [w["word"] for w in r.to_dict()["words"] if not w.get("recognized")] == [
        "morgen", "früh", "bringt", "meine", "mutter", "brot", "und", "milch", "mit"]


def test_speech_before_the_script_does_not_pull_its_first_words():
    """An ad-lib (or a slate) before the line: the transcript's words stay on their own speech
    (alignment.edges), and the ad-lib is unscripted."""
    scripted = "Morgen früh bringt meine Mutter Brot und Milch mit."
    adlib = "Danach gehen wir zusammen in den großen Park und spielen Fußball bis zum Abend."
    snd = spoken(adlib + " " + scripted, "de")
    before = spoken(adlib, "de").duration - 0.3     # where the ad-lib ends, about
    r = analyze(snd, scripted, LineSettings.of(language="de"))
    words = [w for w in r.alignment.words if not w.recognized]
    assert [w.text for w in words][0] == "morgen" and words[0].start >= before - 0.1, words[0]
    grid = np.arange(0.4, before - 0.2, 0.01)
    inside = np.zeros(len(grid), bool)
    for a, b, _ in r.alignment.unscripted:
        inside |= (grid >= a) & (grid < b)
    assert inside.mean() >= 0.9, inside.mean()
