"""detect.spline: a shifted grid of a cubic spline equals scipy's point-by-point interpolation, and the coefficients and
moving means written without scipy equal scipy's."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from aerofid.detect.spline import (
    EDGE_PAD,
    NEAR_REACH,
    PREFILTER_REACH,
    SplinePart,
    cubic_coefficients,
    cubic_prefilter,
    grid_differences,
    grid_values,
    near,
    square_grid,
)
from aerofid.detect.symmetry import moving_mean, point_symmetry_centre


@settings(max_examples=60, deadline=None)
@given(x0=st.floats(-3.0, 40.0), y0=st.floats(-3.0, 30.0), nx=st.integers(1, 25), ny=st.integers(1, 25),
       seed=st.integers(0, 2**16))
def test_grid_values_equal_map_coordinates(x0, y0, nx, ny, seed):
    coeffs = ndimage.spline_filter(np.random.default_rng(seed).normal(size=(50, 60)), order=3)
    got = grid_values(coeffs, x0, y0, (ny, nx))
    inside = x0 >= 1 and y0 >= 1 and np.floor(x0) + nx + 2 <= 60 and np.floor(y0) + ny + 2 <= 50
    assert (got is not None) == bool(inside)
    if got is not None:
        yy, xx = np.mgrid[0:ny, 0:nx].astype(float)
        want = ndimage.map_coordinates(coeffs, [yy + y0, xx + x0], order=3, mode="nearest", prefilter=False)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(x0=st.floats(-3.0, 40.0), y0=st.floats(-3.0, 30.0), nx=st.integers(1, 25), ny=st.integers(1, 25),
       seed=st.integers(0, 2**16))
def test_grid_differences_equal_grids_half_a_pixel_either_side(x0, y0, nx, ny, seed):
    """The value and the central differences at +-1/2 px from one set of passes equal five grids of grid_values
    (and scipy's map_coordinates, by the test above); None exactly where one of the five grids reaches outside."""
    coeffs = ndimage.spline_filter(np.random.default_rng(seed).normal(size=(50, 60)), order=3)
    got = grid_differences(coeffs, x0, y0, (ny, nx))
    grids = [grid_values(coeffs, x0 + dx, y0 + dy, (ny, nx))
             for dx, dy in ((0.0, 0.0), (0.5, 0.0), (-0.5, 0.0), (0.0, 0.5), (0.0, -0.5))]
    assert (got is None) == any(g is None for g in grids)
    if got is not None:
        g0, gxp, gxm, gyp, gym = grids
        for a, b in zip(got, (g0, gxp - gxm, gyp - gym)):  # type: ignore[operator]
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)


def test_point_symmetry_centre_finds_the_centre_of_a_symmetric_pattern_near_the_edge_too():
    """The refinement on whole grids, in the middle of the window and where the spline's support reaches its edge:
    both reach the centre of a pattern symmetric about a known sub-pixel point."""
    yy, xx = np.mgrid[0:64, 0:64].astype(float)
    for cx, cy, r in ((31.3, 30.6, 12), (12.4, 12.7, 12)):
        img = np.exp(-((xx - cx) ** 2 + 0.5 * (yy - cy) ** 2) / 30.0) + 0.3 * np.exp(-((xx - cx) ** 2) / 4.0
                                                                                   - ((yy - cy) ** 2) / 60.0)
        got = point_symmetry_centre(img, cx + 0.3, cy - 0.2, r)
        assert got is not None and abs(got[0] - cx) < 1e-3 and abs(got[1] - cy) < 1e-3


@settings(max_examples=40, deadline=None)
@given(xc=st.floats(0.0, 59.0), yc=st.floats(0.0, 49.0), r=st.integers(1, 30), order=st.sampled_from([1, 3]),
       seed=st.integers(0, 2**16))
def test_square_grid_equals_map_coordinates_with_nearest_edges(xc, yc, r, order, seed):
    """Whole grids, edge pixels repeated as scipy's mode="nearest" does, inside the image and across its edge."""
    img = np.random.default_rng(seed).normal(size=(50, 60)).astype(np.float32)
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1].astype(float)
    want = ndimage.map_coordinates(img.astype(float), [yy + yc, xx + xc], order=order, mode="nearest")
    np.testing.assert_allclose(square_grid(img, xc, yc, r, order), want, rtol=0, atol=1e-6)


@settings(max_examples=60, deadline=None)
@given(r=st.integers(1, 60), fx=st.floats(0.0, 1.0, exclude_max=True), fy=st.floats(0.0, 1.0, exclude_max=True),
       dx=st.integers(-8, 8), dy=st.integers(-8, 8), seed=st.integers(0, 2**16))
def test_inner_square_of_a_larger_grid_is_the_smaller_grid(r, fx, fy, dx, dy, seed):
    """symmetry's final checks take the (2r + 1)-square about the centre from the (2r + 3)-square its covariance
    resamples: the same values, to the last bit where r >= EDGE_PAD (the grids' origins are then exact) and the
    centre lies inside the part as the method's search range keeps it, within 1e-14 of the grey levels below."""
    n = 2 * (r + 1 + NEAR_REACH) + 21
    img = np.random.default_rng(seed).random((n, n)).astype(np.float32)
    xc, yc = n // 2 + dx + fx, n // 2 + dy + fy
    part, x0, y0 = near(img, xc, yc, r + 1 + NEAR_REACH)
    coeffs = cubic_coefficients(part)
    inner = square_grid(part, xc - x0, yc - y0, r + 1, 3, coeffs)[1:-1, 1:-1]
    alone = square_grid(part, xc - x0, yc - y0, r, 3, coeffs)
    if r >= EDGE_PAD:
        np.testing.assert_array_equal(inner, alone)
    else:
        np.testing.assert_allclose(inner, alone, rtol=0, atol=1e-14)


@settings(max_examples=40, deadline=None)
@given(h=st.integers(1, 70), w=st.integers(1, 70), seed=st.integers(0, 2**16))
def test_cubic_prefilter_equals_scipy_spline_filter(h, w, seed):
    """The truncated inverse filter, mirrored at the edges, gives scipy's coefficients within its truncation bound
    (2.005e-8 of the largest grey level, :data:`aerofid.detect.spline.PREFILTER_REACH`), which a +-1 checkerboard
    nearly reaches: also for an image smaller than the filter's reach (mirrored more than once)."""
    img = np.random.default_rng(seed).normal(size=(h, w))
    want = ndimage.spline_filter(img, order=3, mode="mirror")
    np.testing.assert_allclose(cubic_prefilter(img), want, rtol=0, atol=2.005e-8 * np.abs(img).max())
    board = (-1.0) ** np.add.outer(np.arange(h + 40), np.arange(w + 40))
    error = np.abs(cubic_prefilter(board) - ndimage.spline_filter(board, order=3, mode="mirror")).max()
    assert error <= 2.005e-8


@settings(max_examples=40, deadline=None)
@given(n=st.integers(1, 80), d=st.integers(1, 12), seed=st.integers(0, 2**16))
def test_moving_mean_equals_scipy_uniform_filter(n, d, seed):
    p = np.random.default_rng(seed).normal(size=n)
    np.testing.assert_allclose(moving_mean(p, d), ndimage.uniform_filter1d(p, 2 * d + 1, mode="nearest"),
                               rtol=0, atol=1e-12)


def test_square_grid_far_outside_the_image_is_the_edge_value():
    """A centre far beyond the image (no part of it to cut out) gives the nearest edge pixel's value, as scipy's
    mode="nearest" does."""
    img = np.random.default_rng(5).normal(size=(40, 50))
    for xc, yc in ((-100.0, 20.0), (300.0, 10.0), (25.0, -80.0), (-90.0, 200.0)):
        want = ndimage.map_coordinates(img, [np.mgrid[-2:3, -2:3][0] + yc, np.mgrid[-2:3, -2:3][1] + xc], order=3,
                                       mode="nearest")
        np.testing.assert_allclose(square_grid(img, xc, yc, 2), want, rtol=0, atol=1e-6)


@settings(max_examples=80, deadline=None)
@given(xc=st.floats(0.0, 119.0), yc=st.floats(0.0, 99.0), dx=st.floats(-5.0, 5.0), dy=st.floats(-5.0, 5.0),
       r=st.integers(1, 30), reach=st.integers(20, 60), seed=st.integers(0, 2**16))
def test_a_part_s_coefficients_resample_as_the_window_s_to_the_last_bit(xc, yc, dx, dy, r, reach, seed):
    """A square resampled from the coefficients of a part made about another point (the refinement's start) is
    square_grid's of the window, bit for bit, wherever it answers: where every tap lies PREFILTER_REACH px inside
    the part (the whole part is the window's interior, or the window's edge is that far)."""
    img = np.random.default_rng(seed).random((100, 120)).astype(np.float32)
    part = SplinePart.about(img, xc + dx, yc + dy, reach)
    got = part.square(xc, yc, r)
    fx, fy = int(np.floor(xc)) - part.x0, int(np.floor(yc)) - part.y0
    h, w = part.coeffs.shape[0] - 4, part.coeffs.shape[1] - 4
    inside = min(fx, fy) - r - 1 >= PREFILTER_REACH and fx + r + 2 <= w - 1 - PREFILTER_REACH and (
        fy + r + 2 <= h - 1 - PREFILTER_REACH)
    assert (got is not None) == inside
    if got is not None:
        assert np.array_equal(got, square_grid(img, xc, yc, r, 3))


def test_a_part_s_coefficients_one_px_nearer_its_edge_are_not_the_window_s():
    """The bound of SplinePart.square is needed: a tap PREFILTER_REACH - 1 px inside the part has met its edge."""
    img = np.random.default_rng(5).random((100, 120)).astype(np.float32)
    part = SplinePart.about(img, 60.0, 50.0, 30)               # columns 30-90, rows 20-80
    r, xc, yc = 5, 30 + PREFILTER_REACH + 5 + 1 + 0.3, 50.2    # the first tap PREFILTER_REACH px inside
    assert np.array_equal(part.square(xc, yc, r), square_grid(img, xc, yc, r, 3))
    assert part.square(xc - 1, yc, r) is None
    nearer = grid_values(part.coeffs, xc - 1 - part.x0 - r + 2, yc - part.y0 - r + 2, (2 * r + 1, 2 * r + 1))
    assert not np.array_equal(nearer, square_grid(img, xc - 1, yc, r, 3))
