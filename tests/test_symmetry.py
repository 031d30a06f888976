"""Cho & Kim symmetry detector (seed 002) against synthetic marks with exact sub-pixel truth.

Measured with benchmarks/bench_symmetry.py (see its docstring): RMS radial error 0.01-0.04 px per style for
marks of 20-60 px, blur 0.5-1.0, noise 0.01-0.03; the thin '+' is worst (aliasing of a 1-3 px bar). The
bounds asserted here leave a margin of about 2x over what is achieved.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aerofid import synth
from aerofid.detect import detector
from aerofid.detect.symmetry import detect, fiducial_area, self_diagnosis, simplified_log

STYLES = ("cross", "ring_x_dot", "ring_cross", "dot", "bullseye")
RMS_BOUND = 0.1     # px, radial; achieved <= 0.045
MAX_BOUND = 0.3     # px, radial; achieved <= 0.1


def _scene(style, rng, **kw):
    kw.setdefault("size", rng.uniform(20, 60))
    kw.setdefault("blur_sigma", rng.uniform(0.5, 1.0))
    kw.setdefault("noise_sigma", rng.uniform(0.01, 0.03))
    return synth.mark_scene(style, rng=rng, **kw)


def _err(det, scene):
    m = scene.marks[0]
    return det.x - m.x, det.y - m.y


@pytest.fixture(scope="module")
def runs():
    """12 random marks per style (size 20-60, blur 0.5-1.0, noise 0.01-0.03, random sub-pixel centre)."""
    rng = np.random.default_rng(2024)
    out = {}
    for style in STYLES:
        out[style] = []
        for _ in range(12):
            s = _scene(style, rng)
            out[style].append((s, detect(s.image)))
    return out


def test_registry_points_here():
    assert detector("symmetry") is detect


@pytest.mark.parametrize("style", STYLES)
def test_found_and_accurate(runs, style):
    dets = runs[style]
    assert all(d.found for _, d in dets), [d.reason for _, d in dets if not d.found]
    e = np.array([np.hypot(*_err(d, s)) for s, d in dets])
    assert np.sqrt(np.mean(e ** 2)) < RMS_BOUND
    assert e.max() < MAX_BOUND
    for _, d in dets:
        assert d.method == "symmetry"
        assert 0.5 <= d.score <= 1.0
        assert np.isfinite(d.sigma) and d.sigma > 0


def test_sigma_is_honest(runs):
    """Observed RMS error per axis within a factor 3 of the mean reported sigma, pooled over styles; and
    within a factor 4 for every style alone (measured pooled ratio ~0.9, per style 0.4-2)."""
    ex, sg = [], []
    for style in STYLES:
        e = np.array([_err(d, s) for s, d in runs[style]]).ravel()
        s_ = np.array([d.sigma for _, d in runs[style]])
        ratio = np.sqrt(np.mean(e ** 2)) / s_.mean()
        assert 0.25 < ratio < 4.0, (style, ratio)
        ex.append(e)
        sg.append(s_)
    ratio = np.sqrt(np.mean(np.concatenate(ex) ** 2)) / np.concatenate(sg).mean()
    assert 1 / 3 < ratio < 3.0, ratio


def test_diagnostics_for_plots(runs):
    s, d = runs["ring_cross"][0]
    dg = d.diagnostics
    assert dg["log"].shape == s.image.shape
    for key in ("bounds", "profiles", "subpixel", "R_self", "R_parts", "radius", "noise_sigma"):
        assert key in dg
    b = dg["bounds"]
    assert b["L1"] <= s.marks[0].y <= b["L2"]
    assert set(dg["profiles"]) == {"x", "y"} and "I5" in dg["profiles"]["x"]
    assert d.to_dict()["status"] == "found"


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(fx=st.floats(0.0, 1.0), fy=st.floats(0.0, 1.0), style=st.sampled_from(STYLES),
       size=st.floats(20.0, 60.0), seed=st.integers(0, 2 ** 31))
def test_subpixel_position_property(fx, fy, style, size, seed):
    """Any sub-pixel phase of the centre is recovered to well under a pixel."""
    rng = np.random.default_rng(seed)
    s = synth.mark_scene(style, size, window=100, centre=(49.0 + fx, 50.0 + fy), rng=rng, blur_sigma=0.7,
                         noise_sigma=0.02)
    d = detect(s.image)
    assert d.found, d.reason
    assert np.hypot(*_err(d, s)) < MAX_BOUND


@pytest.mark.parametrize("polarity", ["bright", "dark", "either"])
def test_dark_on_bright(polarity):
    """A dark mark on bright ground gives the same centre whatever ``polarity`` says (the method is
    polarity-blind: absolute differences of linear filters and normalised correlations)."""
    rng = np.random.default_rng(7)
    for style in ("ring_x_dot", "dot", "cross"):
        s = _scene(style, rng, polarity="dark")
        d = detect(s.image, polarity=polarity)
        assert d.found, d.reason
        assert np.hypot(*_err(d, s)) < MAX_BOUND
        inv = detect(1.0 - s.image)
        assert inv.found and abs(inv.x - d.x) < 1e-6 and abs(inv.y - d.y) < 1e-6


def test_bad_polarity_is_a_programming_error():
    with pytest.raises(ValueError):
        detect(np.zeros((50, 50), np.float32), polarity="up")


def test_corner_area_with_diagonal_projection():
    """A corner fiducial area (bright L-shaped frame corner, symmetric about the main diagonal) with a
    ring_x_dot: found with the diagonal projection of seed 2.2, and the same mark without it."""
    rng = np.random.default_rng(3)
    n = 120
    c = (60.3, 59.6)
    img = synth.film_border((n, n), rng)
    frame = synth.union(lambda x, y: (x > -40) & (x < 70) & (y > -40) & (y < -34),
                        lambda x, y: (y > -40) & (y < 70) & (x > -40) & (x < -34))
    img = synth.paint(img, synth.coverage((n, n), c, frame, 4), 0.5)
    img = synth.paint(img, synth.coverage((n, n), c, synth.mark_shape("ring_x_dot", 30), 16), 0.9)
    img = np.clip(synth.add_gaussian_noise(synth.blur(img, 0.7), 0.02, rng), 0, 1)
    for diagonal in ("main", None):
        d = detect(img, diagonal=diagonal, radius=16)
        assert d.found, (diagonal, d.reason)
        assert np.hypot(d.x - c[0], d.y - c[1]) < MAX_BOUND


# --- rejection: every one must be an explicit not_found with a reason -----------------------------------

def _assert_rejected(img):
    d = detect(img)
    assert not d.found, f"made-up centre ({d.x:.2f}, {d.y:.2f}), score {d.score:.2f}"
    assert d.status == "not_found" and d.reason and d.method == "symmetry"
    assert np.isnan(d.x) and np.isnan(d.y)
    return d


def _paint_shape(shape, rng, n=120, level=0.8):
    img = synth.film_border((n, n), rng)
    cen = (n / 2 + rng.uniform(-3, 3), n / 2 + rng.uniform(-3, 3))
    img = synth.paint(img, synth.coverage((n, n), cen, shape, 8), level)
    return np.clip(synth.add_gaussian_noise(synth.blur(img, 0.7), 0.02, rng), 0, 1).astype(np.float32)


def _shifted(shape, dx, dy):
    return lambda x, y: shape(x - dx, y - dy)


def test_rejects_pure_noise():
    rng = np.random.default_rng(1)
    for _ in range(8):
        _assert_rejected(np.clip(rng.normal(rng.uniform(0.1, 0.9), rng.uniform(0.01, 0.05), (120, 120)),
                                 0, 1).astype(np.float32))


def test_rejects_homogeneous_window():
    d = _assert_rejected(np.full((120, 120), 0.4, np.float32))
    assert "homogeneous" in d.reason


def test_rejects_odd_windows_without_raising():
    assert not detect(np.zeros((5, 5), np.float32)).found
    assert not detect(np.zeros((3, 40, 40), np.float32)).found
    bad = np.full((60, 60), 0.5, np.float32)
    bad[3, 3] = np.nan
    assert not detect(bad).found


def test_rejects_straight_edge_and_straight_line():
    rng = np.random.default_rng(2)
    for _ in range(8):
        a = rng.uniform(0, 180)
        cen = tuple(60 + rng.normal(0, 5, 2))
        img = synth.paint(synth.film_border((120, 120), rng),
                          synth.coverage((120, 120), cen, synth.bar(400, 200, a), 4), 0.8)
        _assert_rejected(np.clip(synth.add_gaussian_noise(synth.blur(img, 0.7), 0.02, rng), 0, 1))
        _assert_rejected(_paint_shape(synth.bar(200, rng.uniform(2, 5), rng.uniform(0, 180)), rng))


def test_rejects_asymmetric_blobs():
    rng = np.random.default_rng(4)
    for s in rng.uniform(20, 50, 4):
        _assert_rejected(_paint_shape(synth.union(synth.disc(s / 2), _shifted(synth.disc(s / 4), s / 2, 0)),
                                      rng))                                                 # disc + bump
        _assert_rejected(_paint_shape(synth.union(synth.bar(s, 3, 0),
                                                  _shifted(synth.bar(s, 3, 90), 0, s / 2)), rng))  # 'T'
        _assert_rejected(_paint_shape(synth.union(_shifted(synth.bar(s, 3, 0), s / 2, 0),
                                                  _shifted(synth.bar(s, 3, 90), 0, s / 2)), rng))  # 'L'


def test_mark_cut_in_half_by_window_edge():
    """The centre lies on the window edge: no wrong centre may come back as found."""
    rng = np.random.default_rng(5)
    for i, style in enumerate(STYLES * 2):
        edge = [(0.3, 60.4), (119.2, 60.4), (60.2, 0.4), (60.2, 118.8)][i % 4]
        s = synth.mark_scene(style, rng.uniform(20, 60), centre=edge, rng=rng, noise_sigma=0.02)
        _assert_rejected(s.image)


def test_notch_dot_never_wrong():
    """Zeiss-like dot in a notch: the frame breaks assumption (2) of the seed, so with the default kernel
    (half the fiducial area) the method mostly declines; with the kernel set to the notch it often finds the
    dot. Either way no wrong centre is reported."""
    rng = np.random.default_rng(6)
    found = 0
    for _ in range(6):
        s = _scene("notch_dot", rng)
        for kw in ({}, {"radius": int(0.3 * s.marks[0].size)}):
            d = detect(s.image, **kw)
            if d.found:
                found += 1
                assert np.hypot(*_err(d, s)) < MAX_BOUND
    assert found >= 1


# --- building blocks -------------------------------------------------------------------------------------

def test_self_diagnosis_is_one_for_symmetric_and_low_for_noise():
    yy, xx = np.mgrid[-15:16, -15:16]
    ring = ((np.hypot(xx, yy) > 8) & (np.hypot(xx, yy) < 11)).astype(np.float32)
    r, parts = self_diagnosis(ring)
    assert r > 0.999 and parts["R34"] == pytest.approx(parts["R12"])
    r_noise, _ = self_diagnosis(np.random.default_rng(0).normal(size=(31, 31)).astype(np.float32))
    assert r_noise < 0.5


def test_simplified_log_is_zero_on_ramps_and_flat():
    yy, xx = np.mgrid[0:40, 0:40].astype(np.float32)
    assert np.abs(simplified_log(0.01 * xx + 0.02 * yy)[5:-5, 5:-5]).max() < 1e-5


def test_fiducial_area_brackets_the_mark():
    rng = np.random.default_rng(8)
    s = synth.mark_scene("ring_cross", 40, rng=rng, noise_sigma=0.01)
    b = fiducial_area(s.image)
    m = s.marks[0]
    assert b["L1"] < m.y < b["L2"] and b["p1"] < m.x < b["p2"]
    assert abs(b["L3"] - m.x) <= 1.5 and abs(b["y_mid"] - m.y) <= 2.5
