import json

import pytest

from addon.engine import visemes
from addon.engine.coarticulation import build_events
from addon.engine.errors import PresetError
from addon.engine.language.phonemes import PHONEMES, to_arpabet
from addon.engine.language.pronounce import Lexicon
from addon.engine.language.text import Word
import numpy as np


def test_figure_1_hello():
    """'hello' -> SAMPA h @ l @U -> GK AHH L OHH UUU, diphthong split, /h/ -> GK."""
    sampa = "h @ l @U".split()
    arpabet = [to_arpabet(s, "sampa")[0] for s in sampa]
    assert arpabet == Lexicon().pronounce(Word("hello", "hello")).phones
    vset = visemes.load("default")
    phones = [(p, k * 0.1, (k + 1) * 0.1) for k, p in enumerate(arpabet)]
    events = build_events(phones, np.ones(4), vset)
    assert [vset.visemes[e.viseme] for e in events] == ["GK", "AHH", "L", "OHH", "UUU"]
    ohh, uuu = events[3], events[4]
    assert ohh.start == pytest.approx(0.3) and uuu.end == pytest.approx(0.4)
    assert ohh.end == pytest.approx(uuu.start) == pytest.approx(0.35)


@pytest.mark.parametrize("name, count", [("default", 14), ("oculus", 15), ("preston_blair", 10),
                                         ("rhubarb", 9), ("arkit", 15)])
def test_builtin_sets_map_every_phoneme(name, count):
    vset = visemes.load(name)
    assert len(vset.visemes) == count
    assert set(vset.phonemes) >= PHONEMES
    assert ((0 <= vset.ranges) & (vset.ranges <= 1)).all()


def test_oculus_names():
    assert visemes.load("oculus").visemes == "sil PP FF TH DD kk CH SS nn RR aa E ih oh ou".split()


def test_arkit_visemes_drive_blendshape_mixes():
    vset = visemes.load("arkit")
    assert vset.mix("PP")["mouthClose"] == 1.0
    assert {"jawOpen", "mouthFunnel", "mouthPucker", "mouthStretchLeft"} <= {
        k for v in vset.visemes for k in vset.mix(v)}
    assert "jawOpen" in vset.mix("aa") and vset.mix("aa")["jawOpen"] > vset.mix("ih")["jawOpen"]


def test_user_set_from_file(tmp_path):
    doc = json.loads((visemes.DATA / "preston_blair.json").read_text())
    doc["name"] = "mine"
    path = tmp_path / "mine.json"
    path.write_text(json.dumps(doc))
    assert visemes.load(path).name == "mine"
    del doc["phonemes"]["ZH"]
    path.write_text(json.dumps(doc))
    with pytest.raises(PresetError, match="does not map ZH"):
        visemes.load(path)
    doc["phonemes"]["ZH"] = "nonsense"
    path.write_text(json.dumps(doc))
    with pytest.raises(PresetError, match="phonemes.ZH"):
        visemes.load(path)


def test_unknown_set_name_lists_builtins():
    with pytest.raises(PresetError, match="oculus"):
        visemes.load("nope")
