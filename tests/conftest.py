import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
FIXTURES = Path(__file__).parent / "fixtures"
SAMPLE = ROOT / "sample_rigs" / "speech"


@pytest.fixture
def fixtures() -> Path:
    return FIXTURES
