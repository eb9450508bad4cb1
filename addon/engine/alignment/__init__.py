"""Forced alignment of a transcript to speech with pocketsphinx, offline.

pocketsphinx aligns in two passes (words, then phones).  With its default
beams it fails on real recordings in three known ways: the last word can be
dropped, long clips end with "Final result does not match the grammar", and
the phone pass gives up with "Failed to set up sub-word alignment" on clips
with long pauses or quiet, fast speech.  All three come from pruning: the
right path through the grammar is cut off where the acoustic model fits the
speech poorly.  This module therefore:

1. searches with beams far wider than the defaults (1e-200: almost no
   pruning).  A forced alignment holds only the transcript's own words, so
   the search stays small, and it then succeeds on whole clips of a minute;
2. aligns a clip in one forced pass.  A clip longer than
   :attr:`AlignSettings.split_above` (10 s) is cut into an even number of
   pieces of about 7 s, aligned two at a time in two processes: a quick
   forced word pass over the whole clip, scoring every third frame only,
   finds the pauses between words near the cuts' even shares of the clip,
   and the cuts go there (a pass's cost grows faster than its length, so four
   pieces cost less than two halves).  A clip longer than
   :attr:`AlignSettings.stream_above` (90 s) is aligned window by
   window instead, so that memory stays bounded (:mod:`.stream`);
3. checks every pass word by word against the transcript (each word is a
   unique token in a dictionary holding only the clip's words);
4. where forced alignment still fails (audio that does not hold the
   transcript, say), falls back to smaller pieces: the audio is cut at its
   pauses into chunks, words are assigned to chunks by grammars that let the
   acoustic model take a prefix (or a suffix) of the words, and a stretch
   that still cannot be aligned has its phonemes placed by estimate: the words are spread over the stretch's
   speech (pauses skipped) in proportion to their expected length, each
   phone taking a share of its word by its typical duration.  Such words and
   phonemes carry ``estimated = True``.  When only the phone pass fails, the
   word times of the first pass are kept and only the phones inside each
   word are estimated.

The modules: :mod:`.model` (settings and results), :mod:`.speech` (where
the speech and pauses are), :mod:`.decoding` (pocketsphinx passes),
:mod:`.pieces`, :mod:`.stream` and :mod:`.chunks` (how a clip is divided),
:mod:`.estimate` (placing by estimate), :mod:`.fillers` (a hesitation
may be a filler sound), :mod:`.bursts` (a stop after silence starts at its
release burst), :mod:`.reduced` (a reduced /ð/ keeps its usual length),
:mod:`.onsets` (a word of another language starts where its sound rises),
:mod:`.boundaries` (each boundary corrected by the classes of the phones it
joins), :mod:`.core` (:func:`align`), :mod:`.transcript`
(:func:`align_audio`: a written transcript rather than phones),
:mod:`.verify` (the transcript checked against the take: words not said,
speech not scripted) and :mod:`.recognize` (speech with no transcript,
:func:`.recognize.recognize`).
"""

from .core import align, check_transcript_matches
from .model import (FRAME, TYPICAL_DURATION, AlignedPhone, AlignedWord, AlignSettings, Alignment,
                    typical_duration)
from .speech import frame_levels, pauses, speech_mask, unspoken_speech
from .chunks import plan_chunks
from .transcript import align_audio, align_file

__all__ = ["align", "align_audio", "align_file", "check_transcript_matches", "AlignSettings", "Alignment",
           "AlignedWord", "AlignedPhone", "FRAME", "TYPICAL_DURATION", "typical_duration", "frame_levels",
           "speech_mask", "pauses",
           "unspoken_speech", "plan_chunks"]
