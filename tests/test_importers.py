import json

import pytest

from addon.engine.errors import ImportFormatError, UnknownLabelError
from addon.engine.importers import read_alignment, read_papagayo, read_rhubarb, read_textgrid

LONG = '''File type = "ooTextFile"
Object class = "TextGrid"

xmin = 0
xmax = 1.0
tiers? <exists>
size = 2
item []:
    item [1]:
        class = "IntervalTier"
        name = "words"
        xmin = 0
        xmax = 1.0
        intervals: size = 3
        intervals [1]:
            xmin = 0
            xmax = 0.1
            text = ""
        intervals [2]:
            xmin = 0.1
            xmax = 0.5
            text = "hello"
        intervals [3]:
            xmin = 0.5
            xmax = 1.0
            text = "map"
    item [2]:
        class = "IntervalTier"
        name = "phones"
        xmin = 0
        xmax = 1.0
        intervals: size = 8
        intervals [1]:
            xmin = 0
            xmax = 0.1
            text = "sil"
        intervals [2]:
            xmin = 0.1
            xmax = 0.2
            text = "HH"
        intervals [3]:
            xmin = 0.2
            xmax = 0.3
            text = "AH0"
        intervals [4]:
            xmin = 0.3
            xmax = 0.4
            text = "L"
        intervals [5]:
            xmin = 0.4
            xmax = 0.5
            text = "OW1"
        intervals [6]:
            xmin = 0.5
            xmax = 0.6
            text = "M"
        intervals [7]:
            xmin = 0.6
            xmax = 0.8
            text = "AE1"
        intervals [8]:
            xmin = 0.8
            xmax = 1.0
            text = "PT"
'''

SHORT_IPA = '''File type = "ooTextFile"
Object class = "TextGrid"

0
0.6
<exists>
1
"IntervalTier"
"phone"
0
0.6
4
0
0.1
""
0.1
0.3
"ʃ"
0.3
0.5
"iː"
0.5
0.6
"z"
'''


def test_long_textgrid_arpabet_with_stress_and_words(tmp_path):
    f = tmp_path / "a.TextGrid"
    f.write_text(LONG, encoding="utf-8")
    al = read_textgrid(f)
    assert [p.phone for p in al.phones] == ["HH", "AH", "L", "OW", "M", "AE", "P", "T"]
    assert [w.text for w in al.words] == ["hello", "map"]
    assert [p.word_index for p in al.phones] == [0, 0, 0, 0, 1, 1, 1, 1]
    # A merged label "PT" is split evenly over its interval.
    assert al.phones[-2].start == pytest.approx(0.8) and al.phones[-2].end == pytest.approx(0.9)
    assert al.duration == pytest.approx(1.0)


def test_short_textgrid_ipa_utf16(tmp_path):
    f = tmp_path / "b.TextGrid"
    f.write_bytes(b"\xff\xfe" + SHORT_IPA.encode("utf-16-le"))
    al = read_alignment(f)
    assert [p.phone for p in al.phones] == ["SH", "IY", "Z"]


def test_sampa_labels(tmp_path):
    f = tmp_path / "c.TextGrid"
    f.write_text(SHORT_IPA.replace('"ʃ"', '"S"').replace('"iː"', '"i:"'), encoding="utf-8")
    assert [p.phone for p in read_textgrid(f, "sampa").phones] == ["SH", "IY", "Z"]


def test_unknown_label_is_named(tmp_path):
    f = tmp_path / "d.TextGrid"
    f.write_text(SHORT_IPA.replace('"ʃ"', '"Ω!"'), encoding="utf-8")
    with pytest.raises(UnknownLabelError, match="'Ω!'.*0.100 s"):
        read_textgrid(f)


def test_not_a_textgrid(tmp_path):
    f = tmp_path / "e.TextGrid"
    f.write_text("hello", encoding="utf-8")
    with pytest.raises(ImportFormatError, match="not a Praat TextGrid"):
        read_textgrid(f)
    f.write_text(LONG[:400], encoding="utf-8")
    with pytest.raises(ImportFormatError, match="cut short"):
        read_textgrid(f)


def test_rhubarb_json_and_tsv(tmp_path):
    doc = {"metadata": {"soundFile": "x.wav", "duration": 1.0},
           "mouthCues": [{"start": 0.0, "end": 0.2, "value": "X"}, {"start": 0.2, "end": 0.4, "value": "A"},
                         {"start": 0.4, "end": 0.7, "value": "D"}, {"start": 0.7, "end": 1.0, "value": "X"}]}
    j = tmp_path / "r.json"
    j.write_text(json.dumps(doc))
    al = read_rhubarb(j)
    assert [(p.phone, p.start, p.end) for p in al.phones] == [("M", 0.2, 0.4), ("AA", 0.4, 0.7)]
    t = tmp_path / "r.tsv"
    t.write_text("0.00\tX\n0.20\tA\n0.40\tD\n0.70\tX\n")
    assert [p.phone for p in read_alignment(t).phones] == ["M", "AA"]
    t.write_text("0.00\tX\n0.20\tQ\n")
    with pytest.raises(UnknownLabelError, match="'Q'"):
        read_rhubarb(t)


PGO = """lipsync version 1
sound.wav
24
48
1
Voice 1
hello map
1
hello map
0
40
2
hello 2 20 4
2 etc
6 E
10 L
14 O
map 24 40 3
24 MBP
30 AI
36 MBP
"""


def test_papagayo(tmp_path):
    f = tmp_path / "p.pgo"
    f.write_text(PGO)
    al = read_papagayo(f)
    assert [w.text for w in al.words] == ["hello", "map"]
    assert [p.phone for p in al.phones] == ["K", "IY", "L", "AO", "M", "AA", "M"]
    assert al.phones[0].start == pytest.approx(2 / 24)
    assert al.duration == pytest.approx(2.0)
    f.write_text(PGO.replace("30 AI", "30 ZZZ"))
    with pytest.raises(UnknownLabelError, match="ZZZ"):
        read_papagayo(f)
    f.write_text("not papagayo")
    with pytest.raises(ImportFormatError):
        read_papagayo(f)
