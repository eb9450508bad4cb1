"""Forced alignment of a transcript to speech: the names the rest of the
engine uses, from the :mod:`.alignment` package, where the aligner lives
(see its docstring for the method)."""

from .alignment import *  # noqa: F401,F403
from .alignment import __all__  # noqa: F401
from .alignment.chunks import _align_chunked, _Chunk, _cover_speech, _run_middle, _run_side, _trusted  # noqa: F401
from .alignment.decoding import _decode, _decoder, _grammar, _phone_pass, _whole  # noqa: F401
from .alignment.estimate import _clean, _estimate  # noqa: F401
from .alignment.pieces import _align_pieces, _choose_cuts, _segments  # noqa: F401
from .alignment.parallel import _Inline, _pool  # noqa: F401
from .alignment.speech import _close_runs, _longest_run, _speech_spans  # noqa: F401
