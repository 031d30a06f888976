"""Concentric circles detector (Seedahmed, seed 003) against exact synthetic truth (fixed seeds throughout)."""

import itertools
import zlib

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aerofid import synth
from aerofid.detect import circles
from detector_checks import assert_contract, assert_rejects_noise_flat_and_edges, sigma_ratio
from detector_checks import synthetic_marks as _marks

STYLES = ("ring_x_dot", "ring_cross", "bullseye")


def _ring_radii(size):
    """Nominal radii of the outer ring of the synth marks: its inner and outer edge."""
    r, w = size / 2.0, max(1.0, size / 20.0)
    return (r - w, r)


def _params(size=None):
    """Default parameters, with the outer ring's nominal radii when ``size`` is given."""
    return circles.CirclesParams(radii=_ring_radii(size) if size is not None else None)


def _seed(*key):
    """A fixed seed from a readable key (``hash`` is salted per process)."""
    return zlib.crc32(repr(key).encode()) % 2 ** 16


# --- Gauss-Helmert adjustment ---------------------------------------------------------------------------

def _circle_points(x0, y0, radii, n, rng, arc=(0.0, 2 * np.pi)):
    xs, ys, lab = [], [], []
    for k, r in enumerate(radii):
        a = rng.uniform(*arc, n)
        xs.append(x0 + r * np.cos(a))
        ys.append(y0 + r * np.sin(a))
        lab.append(np.full(n, k))
    return np.concatenate(xs), np.concatenate(ys), np.concatenate(lab)


def test_gauss_helmert_exact_points_recovers_centre_and_radii():
    rng = np.random.default_rng(0)
    x, y, lab = _circle_points(12.345, -7.89, (5.5, 11.25), 40, rng)
    fit = circles.fit_concentric_circles(x, y, lab, centre=(13.0, -7.0))
    assert fit.converged
    assert fit.x0 == pytest.approx(12.345, abs=1e-9) and fit.y0 == pytest.approx(-7.89, abs=1e-9)
    assert fit.radii == pytest.approx((5.5, 11.25), abs=1e-9)
    assert fit.sigma0 < 1e-9 and fit.redundancy == 80 - 4


def test_gauss_helmert_fixed_radii_model_of_the_seed():
    rng = np.random.default_rng(1)
    x, y, lab = _circle_points(3.0, 4.0, (2.0, 6.0), 25, rng)
    fit = circles.fit_concentric_circles(x, y, lab, radii=(2.0, 6.0), centre=(3.4, 3.7), fix_radii=True)
    assert (fit.x0, fit.y0) == pytest.approx((3.0, 4.0), abs=1e-9)
    assert fit.cov.shape == (2, 2) and fit.redundancy == 50 - 2


@settings(max_examples=40, deadline=None)
@given(x0=st.floats(-50, 50), y0=st.floats(-50, 50), r1=st.floats(2.0, 30.0), dr=st.floats(1.0, 30.0),
       n=st.integers(4, 60), start=st.floats(0, 2 * np.pi), span=st.floats(np.pi / 2, 2 * np.pi),
       seed=st.integers(0, 2 ** 16))
def test_gauss_helmert_property_exact_points(x0, y0, r1, dr, n, start, span, seed):
    """Exact points on any two concentric circles (even on arcs of a quarter turn) give back the model."""
    rng = np.random.default_rng(seed)
    x, y, lab = _circle_points(x0, y0, (r1, r1 + dr), n, rng, arc=(start, start + span))
    fit = circles.fit_concentric_circles(x, y, lab, centre=(x0 + 0.3, y0 - 0.2), radii=(r1 + 0.2, r1 + dr - 0.1))
    assert fit is not None
    assert fit.x0 == pytest.approx(x0, abs=1e-6) and fit.y0 == pytest.approx(y0, abs=1e-6)
    assert fit.radii == pytest.approx((r1, r1 + dr), abs=1e-6)


def test_gauss_helmert_sigma_matches_monte_carlo():
    """The a-posteriori cofactors describe the scatter of the centre under isotropic point noise."""
    rng = np.random.default_rng(2)
    est, sig = [], []
    for _ in range(300):
        x, y, lab = _circle_points(0.0, 0.0, (8.0, 15.0), 30, rng)
        x, y = x + rng.normal(0, 0.1, x.size), y + rng.normal(0, 0.1, y.size)
        fit = circles.fit_concentric_circles(x, y, lab)
        est.append((fit.x0, fit.y0))
        sig.append(fit.sigma_xy)
        assert fit.sigma0 == pytest.approx(0.1, rel=0.35)
    ratio = np.std(np.array(est), axis=0) / np.mean(np.array(sig), axis=0)
    assert np.all((ratio > 0.8) & (ratio < 1.25)), ratio


def _pope_iteration(x, y, lab, x0, y0, radii, iterations=200):
    """Pope's rigorous iteration of the Gauss-Helmert model (linearised at the corrected observations), run far past
    convergence: the adjustment's solution by the textbook route."""
    R = np.array(radii, float)
    ex, ey = np.zeros_like(x), np.zeros_like(y)
    for _ in range(iterations):
        dx, dy = x + ex - x0, y + ey - y0
        bx, by, rk = 2 * dx, 2 * dy, R[lab]
        m = bx * bx + by * by
        A = np.zeros((x.size, 2 + R.size))
        A[:, 0], A[:, 1] = -bx, -by
        A[np.arange(x.size), 2 + lab] = -2 * rk
        w = dx * dx + dy * dy - rk * rk - (bx * ex + by * ey)
        step = -np.linalg.solve(A.T @ (A / m[:, None]), (A / m[:, None]).T @ w)
        kk = -(A @ step + w) / m
        ex, ey = bx * kk, by * kk
        x0, y0, R = x0 + step[0], y0 + step[1], R + step[2:]
    return x0, y0, R


@settings(max_examples=30, deadline=None)
@given(r1=st.floats(3.0, 25.0), dr=st.floats(1.5, 20.0), noise=st.floats(0.02, 0.8), span=st.floats(np.pi, 2 * np.pi),
       seed=st.integers(0, 2 ** 16))
def test_the_adjustment_is_the_gauss_helmert_solution(r1, dr, noise, span, seed):
    """fit_concentric_circles solves the model by Gauss-Newton on the orthogonal distances: on noisy points it
    reaches the solution of Pope's iteration, and its corrections put every point on its circle."""
    rng = np.random.default_rng(seed)
    x, y, lab = _circle_points(4.0, -3.0, (r1, r1 + dr), 30, rng, arc=(0.0, span))
    x, y = x + rng.normal(0, noise, x.size), y + rng.normal(0, noise, y.size)
    fit = circles.fit_concentric_circles(x, y, lab, centre=(4.5, -3.5), radii=(r1 + 0.5, r1 + dr - 0.5))
    assert fit is not None and fit.converged
    x0, y0, radii = _pope_iteration(x, y, lab, 4.5, -3.5, (r1 + 0.5, r1 + dr - 0.5))
    assert (fit.x0, fit.y0) == pytest.approx((x0, y0), abs=1e-8)
    assert fit.radii == pytest.approx(tuple(radii), abs=1e-8)
    on = np.hypot(x + fit.residuals[:, 0] - fit.x0, y + fit.residuals[:, 1] - fit.y0) - np.array(fit.radii)[lab]
    assert np.abs(on).max() < 1e-9


def test_gauss_helmert_degenerate_input_returns_none():
    assert circles.fit_concentric_circles(np.array([1.0, 2.0]), np.array([1.0, 2.0]), np.array([0, 1])) is None


# --- detector on synthetic marks ------------------------------------------------------------------------

@pytest.mark.parametrize("style", STYLES)
@pytest.mark.parametrize("given_radii", [False, True], ids=["estimated", "given"])
def test_detect_accuracy(style, given_radii):
    """Measured (tests/test_circles.py, 20 marks per case): RMS 0.012-0.024 px, max <= 0.06 px."""
    errs, scores = [], []
    for s, size in _marks(style, 20, seed=_seed(style, given_radii)):
        m = s.marks[0]
        d = circles.detect(s.image, _params(size if given_radii else None))
        assert d.found, (style, size, d.reason)
        errs.append(np.hypot(d.x - m.x, d.y - m.y))
        scores.append(d.score)
    errs = np.array(errs)
    assert np.sqrt(np.mean(errs ** 2)) <= 0.06
    assert errs.max() <= 0.15
    assert min(scores) >= 0.5


def test_sigma_is_honest():
    """Observed per-axis RMS error over the mean reported sigma, 15 marks of each style (measured 0.94)."""
    ratio = sigma_ratio(circles.detect, STYLES, 15, seed=11)
    assert 0.7 <= ratio <= 1.5, ratio


def test_detection_contract_and_typed_results():
    s, size = next(_marks("ring_x_dot", 1, seed=5))
    d = circles.detect(s.image)
    assert_contract(d, "circles", ())
    assert isinstance(d, circles.CirclesResult) and len(d.circles) == 2 and d.fit is not None
    assert d.edge_points is not None and d.edge_points.edge_map.shape == s.image.shape
    assert d.accumulator is not None and d.centre_votes is not None
    assert d.points is not None and d.labels is not None and len(d.points) == len(d.labels)
    assert d.extent == pytest.approx(max(r for _, _, r in d.circles) + 1.0)
    assert abs(d.extent - size / 2) < 2.5
    assert min(d.coverage) >= 0.6 and set(d.score_parts) == {"coverage", "fit", "concentric"}
    assert circles.CirclesResult.not_found("circles", "x").extent is None


def test_plot_draws_edges_circles_and_centre():
    from matplotlib.figure import Figure

    s, _ = next(_marks("bullseye", 1, seed=5))
    d = circles.detect(s.image)
    fig = Figure()
    d.plot(fig, s.image)
    assert len(fig.axes) == 1 and len(fig.axes[0].lines) >= 3


@pytest.mark.parametrize("bad", [{"radii": (5.0,)}, {"radii": (-1.0, 4.0)}, {"radii": (3.0, float("nan"))},
                                 {"n_circles": 1}, {"canny_sigma": -1}, {"canny_low_ratio": 1.5},
                                 {"min_radius": 0}, {"max_radius": 1.0}, {"dehough_tol": 0}, {"radial_cos": 2},
                                 {"min_coverage": float("nan")}, {"competitor_ratio": 0},
                                 {"fix_radii": True}, {"fix_radii": "no"}])
def test_bad_parameters_are_refused_with_one_line(bad):
    with pytest.raises((TypeError, ValueError)) as e:
        circles.CirclesParams(**bad)
    assert "\n" not in str(e.value)


def test_radii_are_normalised_to_a_tuple_of_floats():
    assert circles.CirclesParams(radii=[9, np.float32(10.5)]).radii == (9.0, 10.5)
    assert hash(circles.CirclesParams(radii=[9, 10])) == hash(circles.CirclesParams(radii=(9.0, 10.0)))


# --- the bull's-eye false negative ----------------------------------------------------------------------

# (seed, index) of synthetic_marks("bullseye", 20, seed) refused with the given radii before the fix: the given
# radii's Hough peak lay 1.4 px off (on the ring where the middle ring's edges vote) and the adjustment settled
# on a mixture of rings (refused for coverage, a competing circle, edge scatter)
BULLSEYE_REFUSED = ((370, 8), (403, 6), (460, 4))


@pytest.mark.parametrize("seed,index", BULLSEYE_REFUSED)
def test_small_bullseye_with_given_radii_is_found(seed, index):
    s, size = next(itertools.islice(_marks("bullseye", 20, seed), index, None))
    assert 20 < size < 21
    m = s.marks[0]
    d = circles.detect(s.image, _params(size))
    assert d.found, d.reason
    assert np.hypot(d.x - m.x, d.y - m.y) < 0.1


def test_bullseye_found_rate_over_many_seeds():
    """60 bull's-eyes of 20-60 px, radii estimated and given: all found (600 seeds x 20 marks x 2: no refusal
    after the fix, 3 before)."""
    found = [circles.detect(s.image, _params(size if given else None)).found
             for seed in range(3) for s, size in _marks("bullseye", 20, seed=1000 + seed) for given in (False, True)]
    assert all(found), found.count(False)


# --- pipeline steps -------------------------------------------------------------------------------------

def test_hough_circles_peaks_at_the_centre_of_a_known_radius():
    """Seed 003 section 3: every point on a circle of radius R votes for the centres R away."""
    t = np.linspace(0, 2 * np.pi, 90, endpoint=False)
    acc = circles.hough_circles(20 + 8 * np.cos(t), 17 + 8 * np.sin(t), 8.0, (40, 40))
    assert np.unravel_index(np.argmax(acc), acc.shape) == (17, 20)


def _edge_points(x: np.ndarray, y: np.ndarray, angle: np.ndarray) -> circles.EdgePoints:
    ones = np.ones_like(x)
    return circles.EdgePoints(x, y, np.cos(angle), np.sin(angle), ones, np.rint(x).astype(int),
                              np.rint(y).astype(int), np.zeros((1, 1), bool), 0.01)


@given(n=st.integers(0, 60), h=st.integers(3, 40), w=st.integers(3, 40), r_min=st.floats(0.5, 10.0),
       span=st.floats(0.0, 25.0), seed=st.integers(0, 2**31 - 1))
@settings(max_examples=60, deadline=None)
def test_centre_votes_are_each_points_votes_inside_the_window(n, h, w, r_min, span, seed):
    """Every edge point votes 1/d for the pixel nearest each point at distance d = r_min .. r_max (0.5 px
    steps) on its gradient line, both sides; votes that fall outside the window are dropped (edge points near
    or beyond the window's edge included)."""
    rng = np.random.default_rng(seed)
    x, y = rng.uniform(-10, w + 10, n), rng.uniform(-10, h + 10, n)
    ep = _edge_points(x, y, rng.uniform(0, 2 * np.pi, n))
    expected = np.zeros((h, w))
    d = np.arange(r_min, r_min + span + 0.5, 0.5)
    for k in range(n):
        for s in np.concatenate([-d, d]):
            c, r = int(np.rint(x[k] + s * ep.nx[k])), int(np.rint(y[k] + s * ep.ny[k]))
            if 0 <= r < h and 0 <= c < w:
                expected[r, c] += 1.0 / abs(s)
    got = circles.hough_centres(ep, r_min, r_min + span, (h, w))
    np.testing.assert_allclose(got, expected / (2 * np.pi), rtol=1e-12, atol=1e-15)


def test_de_hough_labels_points_by_circle_and_leaves_tangential_edges_out():
    rng = np.random.default_rng(12)
    x, y, lab = _circle_points(30.0, 30.0, (6.0, 12.0), 30, rng)
    a = np.arctan2(y - 30, x - 30)
    n = x.size
    ep = circles.EdgePoints(x, y, np.cos(a), np.sin(a), np.ones(n), x.astype(int), y.astype(int),
                            np.zeros((60, 60), bool), 0.01)
    assert (circles.de_hough(ep, 30.0, 30.0, [6.0, 12.0]) == lab).all()
    tangential = circles.EdgePoints(x, y, -np.sin(a), np.cos(a), np.ones(n), x.astype(int), y.astype(int),
                                    np.zeros((60, 60), bool), 0.01)
    assert (circles.de_hough(tangential, 30.0, 30.0, [6.0, 12.0]) == -1).all()


@given(n=st.integers(0, 40), seed=st.integers(0, 2**31 - 1), radii=st.lists(st.floats(0.0, 12.0), max_size=6))
@settings(max_examples=150, deadline=None)
def test_shells_are_the_points_within_one_px_of_each_radius(n, seed, radii):
    """``estimate_radii``'s runs of sorted distances are exactly the points ``|d - r| <= 1`` (its test as it reads),
    with distances on the radii's 0.5 px grid and a rounding step beside it (where ``d - r`` is 1 exactly or not):
    their median, the coverage of their angular sectors and the sign of their summed polarities."""
    rng = np.random.default_rng(seed)
    d = np.round(rng.uniform(0.0, 14.0, n) * 4) / 4
    d = np.where(rng.random(n) < 0.3, np.nextafter(d, rng.choice([-1.0, 30.0], n)), d)
    d.sort()
    sector = rng.integers(0, circles.N_SECTORS, n)
    outward = rng.choice([-1.0, 0.0, 1.0], n)
    shells = circles._Shells.about(d, sector, outward)
    r = np.round(np.asarray(radii, float) * 2) / 2
    lo, hi = shells.runs(r)
    got_r, cov, sign = shells.radii(r), shells.coverage(lo, hi), shells.polarity(lo, hi)
    for k, rk in enumerate(r):
        sel = np.abs(d - rk) <= 1.0
        assert (np.nonzero(sel)[0] == np.arange(lo[k], hi[k])).all()
        assert got_r[k] == (float(np.median(d[sel])) if sel.any() else rk)
        assert cov[k] == np.unique(sector[sel]).size / circles.N_SECTORS
        assert sign[k] == np.sign(outward[sel].sum())


def test_estimate_radii_finds_both_edges_of_a_ring():
    s = synth.mark_scene("ring_x_dot", 40, window=72, rng=np.random.default_rng(13), noise_sigma=0.01)
    m = s.marks[0]
    ep = circles.edges(s.image)
    radii = sorted(r for r, _ in circles.estimate_radii(ep, m.x, m.y, 2.5, 30.0))
    assert len(radii) == 2 and abs(radii[1] - 20) < 1.5 and abs(radii[0] - 18) < 1.5


def test_fit_single_circle_recovers_an_offset_ring():
    """Concentricity step: a ring whose centre is 1.5 px off the common centre is adjusted about its own."""
    rng = np.random.default_rng(14)
    x, y, _ = _circle_points(21.5, 20.0, (10.0,), 80, rng)
    a = np.arctan2(y - 20.0, x - 21.5)
    ep = circles.EdgePoints(x, y, np.cos(a), np.sin(a), np.ones(x.size), x.astype(int), y.astype(int),
                            np.zeros((40, 40), bool), 0.01)
    members = circles.de_hough(ep, 20.0, 20.0, [10.0], 1.5) == 0
    f = circles.fit_single_circle(ep, members, 20.0, 20.0, 0, [10.0])
    assert (f.x0, f.y0) == pytest.approx((21.5, 20.0), abs=1e-6)


# --- rejections -----------------------------------------------------------------------------------------

@pytest.mark.parametrize("radii", [None, (9.0, 10.0)])
def test_rejects_noise_homogeneous_and_straight_edges(radii):
    assert_rejects_noise_flat_and_edges(lambda img: circles.detect(img, circles.CirclesParams(radii=radii)))


@pytest.mark.parametrize("style", STYLES)
def test_rejects_mark_cut_in_half(style):
    rng = np.random.default_rng(4)
    for size in (24, 40, 56):
        s = synth.mark_scene(style, size, window=int(size * 1.6) + 8, rng=rng)
        m = s.marks[0]
        for cut in (-2, 0, 1, 2):
            half = s.image[:, : int(m.x) + 1 + cut]
            for p in (_params(), _params(size)):
                d = circles.detect(half, p)
                assert not d.found, (style, size, cut, p.radii, d.x - m.x, d.y - m.y)


@pytest.mark.parametrize("r1,r2,off", [(15, 9, 3), (15, 9, 5), (15, 12, 8), (12, 12, 6), (15, 8, 2), (15, 8, 1)])
def test_rejects_non_concentric_circles(r1, r2, off):
    rng = np.random.default_rng(6)
    img = synth.film_border((64, 64), rng)
    c1 = (31.4, 30.7)
    c2 = (c1[0] + off, c1[1] + 0.3 * off)
    img = synth.paint(img, synth.coverage((64, 64), c1, synth.ring(r1 - 1.5, r1)), 0.85)
    img = synth.paint(img, synth.coverage((64, 64), c2, synth.ring(r2 - 1.5, r2)), 0.85)
    img = synth.add_gaussian_noise(synth.blur(img, 0.7), 0.02, rng)
    for radii in (None, (r1, r2)):
        d = circles.detect(img, circles.CirclesParams(radii=radii))
        assert not d.found, (radii, d.x, d.y)
        assert any(w in d.reason for w in ("concentric", "competes", "circumference")), d.reason


def test_bad_inputs_are_not_found_not_exceptions():
    assert circles.detect(np.zeros((4, 4), np.float32)).status == "not_found"
    img = np.full((32, 32), 0.1, np.float32)
    img[3, 3] = np.nan
    assert circles.detect(img).status == "not_found"
    with pytest.raises(ValueError, match="radii"):
        circles.CirclesParams(radii=(5.0,))


# --- real-scan situations (the Wild RC20 frame's notches, JPEG) -----------------------------------------

def _in_notch(rng, rim, offset, n=120, ring_rim=False):
    """A Wild ring+'+' mark (radius 20) at the window's centre inside a dark rounded notch of radius ``rim``
    whose centre is ``offset`` px away, bright image area outside; with ``ring_rim`` the notch is instead a
    thin bright ring (another mark's circle, not a step to the image area)."""
    c = (n / 2 + 0.37, n / 2 - 0.21)
    o = (c[0] + offset, c[1] + 0.5 * offset)
    if ring_rim:
        img = synth.paint(np.full((n, n), 0.06, np.float32), synth.coverage((n, n), o, synth.ring(rim - 1.5, rim)),
                          0.85)
    else:
        img = synth.paint(np.full((n, n), 0.7, np.float32), synth.coverage((n, n), o, synth.disc(rim)), 0.06)
    img = synth.paint(img, synth.coverage((n, n), c, synth.mark_shape("ring_cross", 40.0, 10.0, width=3.0)), 0.8)
    return synth.add_gaussian_noise(synth.blur(img, 0.8), 0.02, rng), c


def test_the_rounded_notch_around_a_mark_is_not_a_competing_circle():
    rng = np.random.default_rng(21)
    for rim, offset in ((38.0, 3.0), (44.0, 6.0)):
        img, (x, y) = _in_notch(rng, rim, offset)
        d = circles.detect(img)
        assert d.found, d.reason
        assert np.hypot(d.x - x, d.y - y) < 0.1


def test_an_enclosing_bright_ring_off_centre_still_competes():
    rng = np.random.default_rng(22)
    img, _ = _in_notch(rng, 38.0, 4.0, ring_rim=True)
    d = circles.detect(img)
    assert not d.found and any(w in d.reason for w in ("concentric", "competes")), d.reason


def test_colour_jpeg_blocks_do_not_drown_the_circles_in_edges():
    """A red ring mark on a dark film border, saved as a colour JPEG (quality 90, chroma subsampled) and read
    back in its red channel, as on the real RC20 scan: the grey-level noise estimate sees about one grey level
    while the chroma blocks' gradients would make much of the window Canny edges (before the gradient-noise
    floor of :func:`circles.edges`, 0 of 6 found here)."""
    rng = np.random.default_rng(23)
    for _ in range(6):
        s = synth.mark_scene("ring_cross", size=44, window=120, rng=rng, noise_sigma=0.004, blur_sigma=1.0,
                             contrast=0.5, angle_deg=rng.uniform(0, 90))
        g = synth.to_uint8(s.image)
        bgr = np.dstack([np.full_like(g, 30), np.full_like(g, 34), g])
        ok, buf = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, 90])
        img = cv2.imdecode(buf, cv2.IMREAD_COLOR)[..., 2].astype(np.float32) / 255
        d = circles.detect(img)
        m = s.marks[0]
        assert d.found, d.reason
        assert np.hypot(d.x - m.x, d.y - m.y) < 0.1


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.floats(0.0, 5.0), st.floats(1.0, 60.0))
def test_the_histogram_of_sorted_distances_is_numpy_s(seed, low, span):
    """``_histogram`` of sorted values equals ``np.histogram`` with the same edges, values on the edges (the last
    one included) and outside them too."""
    rng = np.random.default_rng(seed)
    edges = np.arange(low, low + span + 0.5, 0.5)
    d = np.concatenate([rng.uniform(low - 2, low + span + 2, int(rng.integers(0, 400))),
                        rng.choice(edges, int(rng.integers(0, 20)))])
    d.sort(kind="stable")
    np.testing.assert_array_equal(circles._histogram(d, edges), np.histogram(d, bins=edges)[0])


# --- noisy windows: wider smoothing ---------------------------------------------------------------------

def _faint_ring(i, style="ring_cross", noise=0.1, size=40):
    """A 40 px ring of contrast 0.4 under white noise of 0.1 (the mark 4 noise sigmas above its ground)."""
    return synth.mark_scene(style, size=size, window=int(2.5 * size), rng=np.random.default_rng(1000 * i + 7),
                            noise_sigma=noise, contrast=0.4, blur_sigma=1.2)


def test_a_faint_ring_in_a_noisy_window_is_found_with_wider_smoothing():
    """Canny at 0.7 px finds no edge on these rings (0 of 10 were found); 1.4 or 2.8 px does (measured 9 of 10)."""
    found = []
    for i in range(10):
        s = _faint_ring(i)
        m = s.marks[0]
        d = circles.detect(s.image)
        if d.found:
            assert d.canny_sigma in circles.NOISY_CANNY_SIGMAS
            assert np.hypot(d.x - m.x, d.y - m.y) < 0.4
            found.append(i)
    assert len(found) >= 8, found


def test_a_clean_window_refused_is_not_measured_again(monkeypatch):
    """A '+' on clean film is no pair of circles: refused once, at the parameter's smoothing (the wider ones would
    only cost time)."""
    runs = []
    real_run = circles._run
    monkeypatch.setattr(circles, "_run", lambda w, p, t, start=None, pixel_noise=None:
                        runs.append(p.canny_sigma) or real_run(w, p, t, start, pixel_noise))
    s = synth.mark_scene("cross", 40, window=100, rng=np.random.default_rng(2), noise_sigma=0.02)
    d = circles.detect(s.image)
    assert not d.found and runs == [circles.CANNY_SIGMA], (d.reason, runs)


@pytest.mark.parametrize("style", ["ring_cross", "bullseye"])
def test_a_faint_ring_cut_in_half_is_refused_at_every_smoothing(style):
    for i in range(4):
        s = _faint_ring(i, style)
        m = s.marks[0]
        for cut in (-2, 0, 2):
            d = circles.detect(s.image[:, : int(m.x) + 1 + cut])
            assert not d.found, (style, i, cut, d.x - m.x, d.y - m.y)
