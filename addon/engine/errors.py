"""Errors the engine raises.  Each says what is wrong in words a user can act on."""

from __future__ import annotations


class LipSyncError(Exception):
    """Base class: every error the engine raises on bad input derives from it."""


class AudioError(LipSyncError):
    """The audio is missing, unreadable, or holds no speech."""


class TranscriptError(LipSyncError):
    """The transcript is empty or cannot be turned into phonemes."""


class AlignmentError(LipSyncError):
    """The transcript does not match the audio."""


class UnknownLabelError(LipSyncError):
    """A phone or mouth-shape label in an imported file is not recognised."""

    def __init__(self, label: str, phoneset: str = "auto", where: str = "", symbol: str | None = None):
        self.label = label
        self.phoneset = phoneset
        self.symbol = symbol
        place = f" in {where}" if where else ""
        what = f": {symbol!r} is not an IPA symbol" if symbol and symbol != label else ""
        super().__init__(
            f"unknown phone label {label!r}{place}{what} (phone set: {phoneset}); "
            "use ARPAbet, IPA or SAMPA labels"
        )


class ImportFormatError(LipSyncError):
    """An alignment file to import is malformed."""


class SettingError(LipSyncError):
    """A line's setting has a value it cannot take (see :mod:`.settings`);
    ``option`` names the setting (``emotion_fade``), so a program can name
    its own option for it (``--emotion-fade``)."""

    def __init__(self, option: str, message: str):
        self.option = option
        super().__init__(message)


class PresetError(LipSyncError):
    """A preset or viseme-set file is malformed; the message names the field."""

    def __init__(self, source: str, field: str, problem: str):
        self.source = source
        self.field = field
        self.problem = problem
        super().__init__(f"{source}: field '{field}' {problem}")
