import sys
import wave
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
FIXTURES = Path(__file__).parent / "fixtures"
SAMPLE = ROOT / "sample_rigs" / "speech"


@pytest.fixture
def fixtures() -> Path:
    return FIXTURES


def write_wav(path, samples, rate=16000, channels=1):
    """``samples`` in [-1, 1] (interleaved when ``channels`` > 1) as 16-bit PCM WAV."""
    data = (np.clip(samples, -1, 1) * 32767).astype("<i2")
    with wave.open(str(path), "wb") as w:
        w.setnchannels(channels)
        w.setsampwidth(2)
        w.setframerate(rate)
        w.writeframes(data.tobytes())
