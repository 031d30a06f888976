"""frame.layout's hypotheses: every (pair of features, pair of fiducials) whose distances agree at the pixel size,
in the order the search scores them, against the definition written out plainly; and its fast tests of them (the
features near a prediction, :mod:`aerofid.frame.nearest`; the rotation limit) against the plain ones."""

from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aerofid.frame import layout, nearest


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
    got = hypotheses(features, fiducials, s)
    np.testing.assert_array_equal(got, plain_hypotheses(features, fiducials, s))


def hypotheses(features: np.ndarray, fiducials_mm: np.ndarray, s: float) -> np.ndarray:
    """The chunks of :func:`layout._hypothesis_chunks` joined, each (but the last) CHUNK long, their pair indices those
    of their features."""
    pairs = layout._Pairs.of(features)
    chunks = list(layout._hypothesis_chunks(pairs, fiducials_mm, s))
    assert all(len(h) == layout.CHUNK for h, _ in chunks[:-1]) and all(0 < len(h) <= layout.CHUNK for h, _ in chunks)
    for h, a in chunks:
        np.testing.assert_array_equal(h[:, :2], np.c_[pairs.i[a], pairs.k[a]])
    return np.vstack([h for h, _ in chunks]) if chunks else np.zeros((0, 4), int)


@settings(max_examples=40, deadline=None)
@given(n=st.integers(2, 40), seed=st.integers(0, 2**16), s=st.floats(0.01, 0.05), chunk=st.integers(1, 300),
       block=st.integers(1, 200), most=st.integers(1, 3000))
def test_hypotheses_are_the_definition_in_chunks_of_any_size_and_cut_anywhere(n, seed, s, chunk, block, most):
    """Chunks, blocks of pairs and the cut at MAX_HYPOTHESES of any size give the definition's first hypotheses."""
    rng = np.random.default_rng(seed)
    fiducials = np.array([[-106, -106], [106, 106], [-106, 106], [106, -106], [0, 110], [110, 0]], float)
    features = np.round(rng.uniform(0, 12000, size=(n, 2)) / 2000) * 2000 + rng.integers(0, 2, size=(n, 2))
    with mock.patch.multiple(layout, CHUNK=chunk, PAIR_BLOCK=block, MAX_HYPOTHESES=most):
        got = hypotheses(features, fiducials, s)
    np.testing.assert_array_equal(got, plain_hypotheses(features, fiducials, s)[:most])


@given(seed=st.integers(0, 2**31 - 1), n=st.integers(2, 9), ulps=st.integers(0, 4), round_mm=st.booleans())
@settings(max_examples=100, deadline=None)
def test_the_distance_band_is_the_test_of_every_pair_at_its_edges(seed, n, ulps, round_mm):
    """:class:`layout._DistanceBand` finds by bisection the fiducial pairs that the test of every pair finds, in its
    order, for distances on the band's edges and a few ulps either side, zero, and fiducials that coincide or lie at
    equal distances (a square layout, rounded coordinates)."""
    rng = np.random.default_rng(seed)
    fiducials = rng.uniform(-120, 120, (n, 2))
    if round_mm:
        fiducials = np.round(fiducials / 40) * 40                     # equal distances, coinciding fiducials
    j, l = layout._fiducial_pairs(n)
    d_mm = np.hypot(*(fiducials[l] - fiducials[j]).T)
    band = layout.SCALE_TOLERANCE * d_mm
    edges = np.r_[d_mm - band, d_mm + band, d_mm, 0.0, rng.uniform(0, 400, 50)]
    d = [edges]
    for step in (np.inf, -np.inf):
        near = edges
        for _ in range(ulps):
            near = np.nextafter(near, step)
            d.append(near)
    d = np.abs(np.concatenate(d))
    a, b = layout._DistanceBand(d_mm)(d)
    a0, b0 = np.nonzero(np.abs(d[:, None] - d_mm) <= band)
    np.testing.assert_array_equal(a, a0)
    np.testing.assert_array_equal(b, b0)


@given(seed=st.integers(0, 2**31 - 1), scale=st.floats(1e-3, 1e3))
@settings(max_examples=100, deadline=None)
def test_the_directions_prefilter_keeps_every_hypothesis_within_the_rotation_limit(seed, scale):
    """:func:`layout._may_turn_within` keeps every similarity :func:`layout._within_rotation` keeps (it only saves
    computing the others): pairs turned by angles all round and within a few ulps of the limit, in any direction."""
    rng = np.random.default_rng(seed)
    limit = np.radians(layout.MAX_ROTATION_DEG)
    turn = np.r_[rng.uniform(-np.pi, np.pi, 300), limit, -limit, np.nextafter(limit, 0), np.nextafter(limit, 1),
                 limit * (1 + rng.uniform(-1e-8, 1e-8, 200)), -limit * (1 + rng.uniform(-1e-8, 1e-8, 200))]
    dc = scale * rng.uniform(0.5, 2.0, len(turn)) * np.exp(1j * rng.uniform(-np.pi, np.pi, len(turn)))
    dp = dc * np.exp(1j * turn) * rng.uniform(0.9, 1.1, len(turn)) * 1000
    kept = layout._may_turn_within(np.angle(dp), np.angle(dc))
    exact = layout._within_rotation(dp / dc)
    assert not (exact & ~kept).any()
    assert not (kept & (np.abs(turn) > limit + 1e-6)).any()


@given(n=st.integers(2, 120), seed=st.integers(0, 2**16), asks=st.lists(st.integers(0, 10**4), max_size=6))
@settings(max_examples=60, deadline=None)
def test_the_pairs_distances_and_directions_as_far_as_asked_are_those_of_every_pair(n, seed, asks):
    """:class:`layout._Pairs` computes its pairs' distances and directions as the search reaches them: asked in any
    order and range, they are those of every pair at once."""
    features = np.random.default_rng(seed).uniform(0, 1e4, (n, 2))
    pairs = layout._Pairs.of(features)
    dx, dy = (features[pairs.k] - features[pairs.i]).T
    for ask in asks:
        a0 = ask % pairs.count
        np.testing.assert_array_equal(pairs.distances(a0, a0 + 37), np.hypot(dx, dy)[a0:a0 + 37])
        some = np.random.default_rng(ask).integers(0, pairs.count, 5)
        np.testing.assert_array_equal(pairs.directions(some), np.arctan2(dy, dx)[some])
    np.testing.assert_array_equal(pairs.directions(np.arange(pairs.count)), np.arctan2(dy, dx))


def plain_nearest(features: np.ndarray, points: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """The definition: each point's nearest feature by dx^2 + dy^2 < tol^2 (nothing for a tolerance that is not
    positive), of equals the first; its distance the square root; ``inf`` and ``len(features)`` where there is none."""
    d, idx = np.full(len(points), np.inf), np.full(len(points), len(features))
    for m, p in enumerate(points):
        dx, dy = (p - features).T
        square = dx * dx + dy * dy
        if tol > 0 and len(features) and square.min() < tol * tol:
            idx[m] = int(np.argmin(square))
            d[m] = np.sqrt(square[idx[m]])
    return d, idx


def assert_as_the_tree(features: np.ndarray, points: np.ndarray, tol: float, d: np.ndarray, idx: np.ndarray) -> None:
    """``d, idx`` are the nearest features within ``tol`` as defined (:func:`plain_nearest`) and, for a positive
    tolerance, at the distances scipy's k-d tree gives, with its index wherever no other feature is as near."""
    from scipy.spatial import cKDTree
    d1, idx1 = plain_nearest(features, points, tol)
    assert np.array_equal(d, d1) and np.array_equal(idx, idx1)
    if tol > 0:
        d0, idx0 = cKDTree(features).query(points, distance_upper_bound=tol)
        assert np.array_equal(d, d0)
        for m in np.flatnonzero(idx != idx0):                   # the tree's own choice between features as near
            dx, dy = points[m] - features[idx0[m]]
            assert np.sqrt(dx * dx + dy * dy) == d[m]           # the distance as the tree computes it


@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 60), tol=st.sampled_from([0.5, 1.0, 3.0, 7.25, 40.0]),
       cells=st.sampled_from([None, 1]))
@settings(max_examples=150, deadline=None)
def test_the_nearest_features_within_a_tolerance(seed, n, tol, cells):
    """:class:`nearest.NearestWithin` gives every point the nearest feature within ``tol`` (distance and index;
    ``inf`` and ``n`` where there is none; of features as near, the first) as defined, and as cKDTree's bounded query
    does: points on a coarse grid, so that distances equal to ``tol`` and features as near occur, points far outside
    the features' extent, and without a grid (``cells``: GRID_CELLS of 1)."""
    rng = np.random.default_rng(seed)
    features = rng.integers(0, 40, (n, 2)) * 0.5
    points = np.vstack([rng.integers(-20, 60, (300, 2)) * 0.5, rng.uniform(-1e4, 1e4, (20, 2))])
    with mock.patch.object(nearest, "GRID_CELLS", cells or nearest.GRID_CELLS):
        d, idx = nearest.NearestWithin(features, tol)(points)
    assert_as_the_tree(features, points, tol, d, idx)


@pytest.mark.parametrize("cells", [None, 1])
def test_points_that_are_not_finite_are_misses(cells):
    features = np.array([[0.0, 0.0], [10.0, 5.0]])
    with mock.patch.object(nearest, "GRID_CELLS", cells or nearest.GRID_CELLS):
        near = nearest.NearestWithin(features, 5.0)
    d, idx = near(np.array([[np.nan, 0.0], [np.inf, 5.0], [-np.inf, np.nan], [1, 1]]))
    assert d[:3].tolist() == [np.inf] * 3 and idx.tolist() == [2, 2, 2, 0]
    with pytest.raises(ValueError, match="finite"):
        nearest.NearestWithin(np.array([[0.0, np.nan]]), 5.0)
    with pytest.raises(ValueError, match="finite"):
        nearest.nearest_other(np.array([[0.0, 0.0], [np.inf, 1.0]]))


def test_features_far_from_the_origin_are_found_on_the_grid():
    """Coordinates whose rounding step is larger than a cell: the features' own cells, counted from the least."""
    features = np.array([[1e17, 1e17], [1e17 + 64, 1e17], [1e17, 1e17 + 4096]])
    points = np.vstack([features, features + [0.0, 16.0]])
    d, idx = nearest.NearestWithin(features, 20.0)(points)
    assert_as_the_tree(features, points, 20.0, d, idx)
    assert idx.tolist() == [0, 1, 2, 0, 1, 2]


@given(seed=st.integers(0, 2**31 - 1), n=st.integers(0, 60), twice=st.integers(0, 3),
       shape=st.sampled_from(["grid", "columns", "rows", "spread"]), neighbours=st.sampled_from([1, 2, 16]))
@settings(max_examples=150, deadline=None)
def test_each_features_nearest_other(seed, n, twice, shape, neighbours):
    """:func:`nearest.nearest_other`: each point's distance to its nearest other, 0 for one given twice or alone, as
    the k-d tree's second neighbour: points on a coarse grid, in a few columns or rows (a frame's border: the
    neighbours in one order are all in the column), spread, and with few neighbours compared (every point then
    compared with all)."""
    from scipy.spatial import cKDTree
    rng = np.random.default_rng(seed)
    a, b = rng.integers(0, 30, n) * 0.5 + rng.choice([0.0, 1e-9], n), rng.uniform(0, 1e4, n)
    points = {"grid": np.c_[a, rng.integers(0, 30, n) * 0.5], "columns": np.c_[np.floor(a / 10) * 1e3, b],
              "rows": np.c_[b, np.floor(a / 10) * 1e3], "spread": np.c_[b, rng.uniform(0, 1e4, n)]}[shape]
    for _ in range(twice if n else 0):
        i, k = rng.integers(0, n, 2)
        points[i] = points[k]
    with mock.patch.object(nearest, "NEIGHBOURS", neighbours):
        got = nearest.nearest_other(points)
    assert np.array_equal(got, cKDTree(points).query(points, k=2)[0][:, 1] if n > 1 else np.zeros(n))


@given(seed=st.integers(0, 2**31 - 1), scale=st.floats(1e-3, 1e3))
@settings(max_examples=100, deadline=None)
def test_the_rotation_limit_reads_as_the_angle(seed, scale):
    """:func:`layout._within_rotation` keeps exactly the similarities ``np.angle`` puts within MAX_ROTATION_DEG: angles
    spread all round, and angles within a few ulps of the limit either side."""
    rng = np.random.default_rng(seed)
    limit = np.radians(layout.MAX_ROTATION_DEG)
    angles = np.r_[rng.uniform(-np.pi, np.pi, 500), limit, -limit,
                   np.nextafter(limit, 0), np.nextafter(limit, 1), limit * (1 + rng.uniform(-1e-8, 1e-8, 200))]
    z = scale * rng.uniform(0.5, 2.0, len(angles)) * np.exp(1j * angles)
    special = np.array([0j, complex(-0.0, 0.0), complex(np.inf, np.inf), complex(np.inf, 0), complex(np.nan, 0),
                        complex(100 * 5e-324, 7 * 5e-324), complex(1e-300, 7e-302), complex(5e-324, 0)])
    z = np.r_[z, special]
    assert np.array_equal(layout._within_rotation(z), np.abs(np.angle(z)) <= limit)


@pytest.mark.parametrize("tol", [1e-20, 1e-160, 1e-170, 0.0, -1.0])
def test_a_tolerance_too_small_for_a_grid_or_not_positive(tol):
    """A tolerance too small for a grid compares the points with every feature; one whose square underflows, or that
    is not positive, holds nothing (the k-d tree squares a negative one)."""
    features = np.array([[0.0, 0.0], [10.0, 5.0], [2000.0, 3000.0]])
    points = np.array([[0.0, 0.0], [10.0, 5.0 + 1e-21], [7.0, 7.0], [2000.0, 3000.0]])
    d, idx = nearest.NearestWithin(features, tol)(points)
    assert_as_the_tree(features, points, tol, d, idx)
    assert (idx[[0, 3]].tolist() == [0, 2]) == (tol > 0 and tol * tol > 0)


@given(seed=st.integers(0, 2**31 - 1), n=st.integers(0, 30), twice=st.integers(0, 3),
       tol=st.sampled_from([1e-300, 1e-170, 1e-9, 0.5, 40.0, 300.0]))
@settings(max_examples=60, deadline=None)
def test_the_predictions_on_their_own_features_answer_as_the_tree(seed, n, twice, tol):
    """:meth:`layout._NearFeatures.query_predictions` gives every prediction of the search's hypotheses the nearest
    feature within ``tol`` as defined, and as cKDTree's bounded query of every point does (fiducials j and l,
    predicted on features i and k, are answered without a look-up): the layout's marks (turned, moved, a little off)
    among ``n`` chance features, some features given twice or a hair's breadth apart, and tolerances below the
    rounding of l's prediction."""
    rng = np.random.default_rng(seed)
    fiducials = np.array([[-106, -106], [106, 106], [-106, 106], [106, -106], [0, 110]], float)
    s = 0.05
    turn = np.radians(rng.uniform(-3, 3))
    rot = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    marks = fiducials / s @ rot.T + rng.uniform(3000, 6000, 2) + rng.normal(0, 2, (len(fiducials), 2))
    features = np.vstack([marks, rng.uniform(0, 9000, size=(n, 2))])
    for _ in range(twice):                                      # a feature twice, or a hair's breadth apart
        a, b = rng.integers(0, len(features), 2)
        features[a] = features[b] + rng.choice([0.0, 1e-12, 1e-3], size=2)
    near = layout._NearFeatures(features, tol)
    checked = 0
    for hyp, _ in layout._hypothesis_chunks(layout._Pairs.of(features), fiducials, s):
        pred, kept = layout._predict(features, fiducials / s, hyp)
        if pred is None:
            continue
        d, idx = near.query_predictions(pred, hyp[kept])
        assert_as_the_tree(features, pred.reshape(-1, 2), tol, d.ravel(), idx.ravel())
        checked += len(pred)
    assert checked >= len(fiducials) * (len(fiducials) - 1) // 2 or twice     # every pair of marks, the right way


def _layout(size: float, matched: int) -> layout.LayoutMatch:
    return mock.Mock(spec=layout.LayoutMatch, pixel_size_mm=size, n_matched=matched, complete=matched == 4)


def test_a_four_fiducial_camera_s_layouts_are_taken_nearest_the_usual_span_of_its_features_first():
    """Without a pixel size, a camera of 4 fiducials: its layouts nearest first to the size at which the fiducials span
    PRIOR_SPAN of the features' extent, one with a fiducial on no feature as if UNMATCHED_RATIO further (the RC20
    frame turned by 270 degrees: its true layout on 3 of its 4 corners, 1 % from the usual size, came after complete
    chance ones 10-55 % from it); of equals, the better fit (the ranking's order) first."""
    fid = np.array([[-106.0, -106.0], [106.0, -106.0], [106.0, 106.0], [-106.0, 106.0]])
    extent = (5828.0, 5344.0)
    prior = 212.0 / (layout.PRIOR_SPAN * 5828)                       # 0.0428 mm per px
    ranked = [_layout(0.0768, 4), _layout(0.0514, 4), _layout(0.0428, 3), _layout(0.0420, 4), _layout(0.0651, 4),
              _layout(0.0470, 4), _layout(0.0455, 3), _layout(0.0651, 4)]
    got = layout.by_prior(ranked, fid, extent)
    assert [(m.pixel_size_mm, m.n_matched) for m in got] == [(0.0420, 4), (0.0428, 3), (0.0470, 4), (0.0455, 3),
                                                             (0.0514, 4), (0.0651, 4), (0.0651, 4), (0.0768, 4)]
    assert got[5] is ranked[4] and got[6] is ranked[7]
    assert np.log(0.0428 / prior) + np.log(layout.UNMATCHED_RATIO) < np.log(0.0470 / prior)


def test_a_padded_scan_s_layouts_are_taken_by_the_usual_span_of_its_picture():
    """A 4-fiducial camera's marks in a picture of 5908 x 5408 px padded by 300 px (a scanner's bed), and 4 clutter
    features that form a complete square at 0.0395 mm per px: the padded scan's longer side puts the usual size at
    0.0383, nearer the chance square (3 %) than the marks (10 %); the features lie on the picture, whose extent puts
    it at 0.0422, and the marks' layout is taken first. By the scan's size the chance square would be."""
    fid = np.array([[-106.0, -106.0], [106.0, -106.0], [106.0, 106.0], [-106.0, 106.0]])

    def square(s: float, cx: float, cy: float) -> np.ndarray:
        return np.array([[cx + x / s, cy - y / s] for x, y in fid])

    clutter = np.random.default_rng(1).uniform([300.0, 300.0], [6208.0, 5708.0], (30, 2))
    clutter[:2] = [[300.0, 300.0], [6208.0, 5708.0]]                 # the picture's corners
    features = np.vstack([square(0.0395, 3314.0, 2964.0), clutter, square(0.04233, 3254.0, 3004.0)])
    assert layout.features_extent(features) == pytest.approx((5908.0, 5427.5), abs=0.1)
    got = layout.layout_candidates(features, fid, position_error_px=24.0, scan_size=(6508, 6008))
    assert got[0].matched == (34, 35, 36, 37) and got[0].complete
    assert layout.by_prior(got, fid, (6508.0, 6008.0))[0].matched == (0, 1, 2, 3)


def test_a_layout_search_without_layouts_or_extent_ranks_nothing():
    """Coincident features hold no layout and have no extent: nothing to rank, no division by it."""
    fid = np.array([[-106.0, -106.0], [106.0, -106.0], [106.0, 106.0], [-106.0, 106.0]])
    assert layout.layout_candidates(np.array([[5.0, 5.0], [5.0, 5.0]]), fid) == []
    assert layout.by_prior([_layout(0.0420, 4)], fid, (0.0, 0.0))[0].pixel_size_mm == 0.0420


@pytest.mark.parametrize("larger", [1.021, 0.979])
def test_at_a_declared_pixel_size_a_layout_of_features_off_its_scale_ends_no_search(larger):
    """Four strong features beside each of a 4-fiducial camera's marks, outwards alike (the real RC20 frame's corner
    marks merged with their number dots at the screening's scale), form a complete layout 2.1 % off the scan's
    declared pixel size; the marks themselves, weaker, form it on that scale. The first ended the search; it ends none
    now, and the marks' layout is the one found (:func:`aerofid.frame.layout.on_declared_scale`); with the pixel
    size unknown, both are found."""
    fid = np.array([[-106.0, -106.0], [106.0, -106.0], [106.0, 106.0], [-106.0, 106.0]])
    s = 0.04233
    centre = np.array([2954.0, 2704.0])
    marks = centre + fid * [1.0, -1.0] / s + [2.0, -1.5]
    blobs = centre + (marks - centre) * larger
    features = np.vstack([blobs, marks])                       # the strong ones first: their pairs are tried first
    got = layout.layout_candidates(features, fid, pixel_size_mm=s, position_error_px=24.0, scan_size=(5908, 5408),
                                   first_complete=True)
    assert got and sorted(got[0].matched) == [4, 5, 6, 7]
    assert abs(got[0].pixel_size_mm / s - 1) < 1e-9
    assert layout.on_declared_scale(got[0].predicted, got[0].pixel_size_mm, s, 24.0)
    assert not layout.on_declared_scale(blobs, s / larger, s, 24.0)
