"""The poses learning writes: in the range a shape key shows, and pulled
toward the starting poses the more, the less the clips show a viseme."""

import numpy as np
import pytest

from addon.engine.learning.model import bounded_poses


def test_poses_stay_in_range_and_little_shown_visemes_keep_their_start():
    rng = np.random.default_rng(0)
    frames = 600
    C = np.zeros((frames, 3))
    C[:400, 0] = rng.uniform(0.5, 1.0, 400)       # shown for 400 frames
    C[400:404, 1] = 1.0                            # shown for 4 frames
    C[404:, 2] = rng.uniform(0.5, 1.0, frames - 404)
    truth = np.array([[0.9, 1.6], [0.9, 0.2], [0.1, -0.4]])   # visemes x tracks; some past [0, 1]
    Y = C @ truth + rng.normal(0, 0.01, (frames, 2))
    start = np.array([[0.3, 0.3], [0.1, 0.1], [0.5, 0.5]])
    M = bounded_poses([C], [Y], start, frames=4.0)
    assert M.min() >= 0.0 and M.max() <= 1.0
    assert M[0, 0] == pytest.approx(0.9, abs=0.02) and M[0, 1] == 1.0     # well shown: the data, held in range
    assert M[2, 1] == 0.0
    # Shown for as long as the pull is strong: half way between the start and the data.
    assert M[1, 0] == pytest.approx(0.5 * (0.1 + 0.9), abs=0.05)
    loose = bounded_poses([C], [Y], start, frames=0.01)
    assert loose[1, 0] == pytest.approx(0.9, abs=0.05)
