"""frame.layout's hypotheses: every (pair of features, pair of fiducials) whose distances agree at the pixel size,
in the order the search scores them, against the definition written out plainly."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from aerofid.frame import layout


def plain_hypotheses(features: np.ndarray, fiducials_mm: np.ndarray, s: float) -> np.ndarray:
    """The definition: all pairs i < k, strong pairs first (by i + k, then k), each with every ordered fiducial
    pair (j, l) in row-major order whose distance agrees within SCALE_TOLERANCE."""
    out = []
    pairs = sorted(((i, k) for i in range(len(features)) for k in range(i + 1, len(features))),
                   key=lambda p: (p[0] + p[1], p[1]))
    for i, k in pairs:
        d_px = float(np.hypot(*(features[k] - features[i]))) * s
        for j in range(len(fiducials_mm)):
            for m in range(len(fiducials_mm)):
                if j != m:
                    d_mm = float(np.hypot(*(fiducials_mm[m] - fiducials_mm[j])))
                    if abs(d_px - d_mm) <= layout.SCALE_TOLERANCE * d_mm:
                        out.append((i, k, j, m))
    return np.array(out, dtype=int).reshape(-1, 4)


@settings(max_examples=40, deadline=None)
@given(n=st.integers(2, 40), seed=st.integers(0, 2**16), s=st.floats(0.01, 0.05), grid=st.booleans())
def test_hypotheses_are_the_definition(n, seed, s, grid):
    rng = np.random.default_rng(seed)
    fiducials = np.array([[-106, -106], [106, 106], [-106, 106], [106, -106], [0, 110], [110, 0], [-110, 0],
                          [0, -110]], float)
    features = rng.uniform(0, 12000, size=(n, 2))
    if grid:                                   # many equal distances: ties in the order
        features = np.round(features / 2000) * 2000 + rng.integers(0, 2, size=(n, 2))
    got = layout._hypotheses(layout._Pairs.of(features), fiducials, s)
    np.testing.assert_array_equal(got, plain_hypotheses(features, fiducials, s))
