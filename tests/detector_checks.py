"""Checks shared by the tests of the single-mark detectors (tests/test_circles.py, tests/test_lines.py):
the same synthetic marks, sigma honesty, the Detection contract and the rejection of featureless windows."""

import numpy as np

from aerofid import synth
from aerofid.detect.result import Detection


def synthetic_marks(style, n, seed, rotate=False):
    """n synthetic marks: random sub-pixel centre, size 20-60 px, blur 0.5-1.0, noise 0.01-0.03."""
    rng = np.random.default_rng(seed)
    for _ in range(n):
        size = rng.uniform(20, 60)
        s = synth.mark_scene(style, size, window=int(size * 1.6) + 8, rng=rng, blur_sigma=rng.uniform(0.5, 1.0),
                             noise_sigma=rng.uniform(0.01, 0.03), angle_deg=rng.uniform(0, 90) if rotate else 0.0)
        yield s, size


SIGMA_BAND = (0.7, 1.5)
"""An honest sigma: observed per-axis RMS error / mean reported sigma within this band (issue 8)."""


def sigma_ratio(detect, styles, n, seed):
    """Observed per-axis RMS error over the mean reported sigma, on ``n`` marks of each style (all found)."""
    err2, sig = [], []
    for style in styles:
        for s, _ in synthetic_marks(style, n, seed):
            m = s.marks[0]
            d = detect(s.image)
            assert d.found, (style, d.reason)
            err2 += [(d.x - m.x) ** 2, (d.y - m.y) ** 2]
            sig.append(d.sigma)
    return float(np.sqrt(np.mean(err2)) / np.mean(sig))


def assert_sigma_honest(ratio, band=SIGMA_BAND):
    """``ratio`` (:func:`sigma_ratio`) within ``band``: the reported sigma neither flatters nor hides the error."""
    lo, hi = band
    assert lo <= ratio <= hi, f"observed error / reported sigma = {ratio:.2f}, outside {lo}-{hi}"


def assert_contract(d, method, fields):
    """A found answer of ``method``: a :class:`Detection` subclass (its own typed result), a score in [0, 1], a
    positive sigma, each of the typed diagnostic ``fields`` set (not None), and plain scalars in ``to_dict``."""
    assert isinstance(d, Detection) and type(d) is not Detection and d.method == method and d.found
    assert 0 <= d.score <= 1 and d.sigma > 0
    for name in fields:
        assert getattr(d, name) is not None, name
    assert set(d.to_dict()) >= {"status", "x", "y", "score", "sigma", "method", "reason"}


def half_plane(angle_deg, rng, n=64):
    """A single straight edge through the window (bright half-plane), blurred and noisy."""
    t = np.deg2rad(angle_deg)
    c = (n / 2 - 0.3 - 32 * np.sin(t), n / 2 + 0.2 + 32 * np.cos(t))  # a bar 64 wide, one edge through the middle
    img = synth.paint(np.full((n, n), 0.1, np.float32), synth.coverage((n, n), c, synth.bar(400, 64, angle_deg)),
                      0.8)
    return synth.add_gaussian_noise(synth.blur(img, 0.7), 0.02, rng)


def assert_rejects_noise_flat_and_edges(detect):
    """Pure noise, a homogeneous window and a straight edge at four angles: not found, with a reason."""
    rng = np.random.default_rng(3)
    for _ in range(3):
        noise = np.clip(0.1 + rng.normal(0, 0.03, (64, 64)), 0, 1).astype(np.float32)
        assert detect(noise).status == "not_found"
    d = detect(np.full((64, 64), 0.1, np.float32))
    assert not d.found and "homogeneous" in d.reason
    for ang in (0, 20, 45, 90):
        img = half_plane(ang, rng)
        assert 0.2 < img.mean() < 0.7  # the edge is in the window
        d = detect(img)
        assert not d.found and d.reason, ang
