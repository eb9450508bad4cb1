"""From written words to the phones a mouth shows.

Everything the engine knows about language lives in this package, and the
rest of the engine asks it through the names below:

* :mod:`.text` turns a dialogue script into the words that are heard
  (numbers spelled out, stage directions dropped, pause hints kept) and reads
  transcript files in any common encoding;
* :mod:`.pronounce` gives each word its phones: inline overrides, a user
  dictionary, the CMU dictionary, then :mod:`.lts` letter-to-sound rules;
  :mod:`.numbers` spells numbers;
* :mod:`.phonemes` is the phone inventory the engine speaks (ARPAbet without
  stress, plus ``SIL``), with each phone's class and manner, and reads the
  labels other tools write (IPA, SAMPA, ARPAbet with stress);
* :mod:`.ipa` maps IPA of any language to those phones by articulatory
  features (tables in ``data/ipa.json``);
* :mod:`.languages` names the languages a transcript can be in (table in
  ``data/languages.json``) and :mod:`.espeak` reads every one but English
  with eSpeak NG, its IPA mapped by :mod:`.ipa`.
"""

from .phonemes import (CLASSES, MANNER, PHONEMES, SILENCE, VOWELS, is_vowel, phone_class, strip_stress,
                       to_arpabet)
from .languages import Language, resolve as resolve_language, supported as supported_languages
from .pronounce import Lexicon, Pronunciation, cmudict
from .text import Word, describe_skipped, normalize, read_text_file, skipped_words, stage_direction_gaps

__all__ = ["CLASSES", "MANNER", "PHONEMES", "SILENCE", "VOWELS", "Language", "Lexicon", "Pronunciation", "Word",
           "cmudict", "resolve_language", "supported_languages",
           "describe_skipped", "is_vowel", "normalize", "phone_class", "read_text_file", "skipped_words",
           "stage_direction_gaps",
           "strip_stress", "to_arpabet"]
