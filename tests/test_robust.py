"""aerofid.robust: the medians and percentiles are numpy's (of all the values, or along an axis)."""

import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from aerofid.robust import MAD_TO_SIGMA, median, percentile, percentiles, robust_std

_FLOATS = st.sampled_from([np.float32, np.float64])
_SHAPES = st.tuples(st.integers(1, 40), st.integers(1, 7))


@given(arrays(_FLOATS, _SHAPES, elements=st.floats(-1e3, 1e3, width=32)))
def test_median_is_numpys_in_value_and_type(values):
    ours, numpys = median(values), np.median(values)
    assert ours == numpys and type(ours) is type(numpys)


@given(arrays(_FLOATS, st.tuples(st.integers(0, 6), st.integers(0, 9), st.integers(1, 5)),
              elements=st.floats(-1e3, 1e3, width=32) | st.just(np.nan)), st.integers(-3, 2))
def test_median_along_an_axis_is_numpys_in_values_and_type(values, axis):
    with warnings.catch_warnings():                 # numpy warns of an empty slice, whose median is nan
        warnings.simplefilter("ignore", RuntimeWarning)
        numpys = np.median(values, axis=axis)
    ours = median(values, axis=axis)
    assert ours.dtype == numpys.dtype and ours.shape == numpys.shape
    np.testing.assert_array_equal(ours, numpys)


@given(arrays(np.int64, _SHAPES, elements=st.integers(-100, 100)))
def test_median_of_integers_is_numpys_float64(values):
    ours = median(values)
    assert ours == np.median(values) and type(ours) is np.float64


@given(arrays(_FLOATS, _SHAPES, elements=st.floats(-1e3, 1e3, width=32)))
def test_robust_std_is_the_scaled_median_absolute_deviation(values):
    v = values.astype(np.float64)
    assert robust_std(values) == MAD_TO_SIGMA * np.median(np.abs(v - np.median(v)))


def test_ties_around_the_median_and_nan():
    # many values equal to the median: the deviations below and above it tie at 0
    v = np.array([5.0, 5.0, 5.0, 5.0, 1.0, 9.0, 5.0, 2.0])
    assert robust_std(v) == MAD_TO_SIGMA * np.median(np.abs(v - np.median(v))) == 0.0
    assert robust_std(np.array([])) == 0.0
    assert np.isnan(median(np.array([1.0, np.nan, 3.0]))) and np.isnan(robust_std(np.array([1.0, np.nan])))
    assert np.isnan(median(np.array([], np.float32)))


@given(arrays(_FLOATS, st.integers(1, 60),
              elements=st.floats(-1e6, 1e6, width=32) | st.sampled_from([0.0, -0.0, np.inf, -np.inf, np.nan]))
       | arrays(st.sampled_from([np.int64, np.int8, np.uint8]), st.integers(1, 60), elements=st.integers(0, 9)),
       st.integers(0, 100) | st.floats(0, 100) | st.sampled_from([25, 90, 99, 100, 0.5, 99.5]))
def test_percentile_is_numpys_to_the_bit(values, q):
    """Floating values of both widths (and integers, which go to numpy), repeated values, zeros of either sign,
    infinities and nan, any q: the same number, sign of zero included (numpy's selection, the interpolation from the
    nearer neighbour; the last value's weight counted from index -1 above the end)."""
    with warnings.catch_warnings():                 # inf - inf in numpy's interpolation
        warnings.simplefilter("ignore", RuntimeWarning)
        numpys = float(np.percentile(values, q))
        ours = percentile(values, q)
    assert (ours == numpys or (np.isnan(ours) and np.isnan(numpys))) and np.signbit(ours) == np.signbit(numpys)


@given(arrays(_FLOATS, st.integers(1, 60),
              elements=st.floats(-1e6, 1e6, width=32) | st.sampled_from([0.0, -0.0, np.inf, -np.inf, np.nan]))
       | arrays(st.sampled_from([np.int64, np.uint8]), st.integers(1, 60), elements=st.integers(0, 9)),
       st.lists(st.integers(0, 100) | st.floats(0, 100) | st.sampled_from([1.0, 50.0, 99.0, 100]), min_size=1,
                max_size=4))
def test_percentiles_are_numpys_to_the_bit(values, qs):
    """Several percentiles at once: numpy's one selection at all their indices and its float64 interpolation, the
    same numbers as ``np.percentile(values, qs)``, signs of zero included."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        numpys = [float(v) for v in np.percentile(values, tuple(qs))]
        ours = percentiles(values, tuple(qs))
    assert len(ours) == len(numpys)
    for o, n in zip(ours, numpys, strict=True):
        assert (o == n or (np.isnan(o) and np.isnan(n))) and np.signbit(o) == np.signbit(n)


def test_percentiles_of_a_grey_window_and_their_errors():
    """The colour policy's percentiles of a float32 window (1, 50, 99: numpy's float64 interpolation) and the errors
    of :func:`percentile`."""
    grey = np.random.default_rng(3).random((61, 67)).astype(np.float32)
    assert percentiles(grey, (1.0, 50.0, 99.0)) == tuple(np.percentile(grey, (1.0, 50.0, 99.0)).tolist())
    with pytest.raises(ValueError, match="no values"):
        percentiles(np.array([]), (50,))
    with pytest.raises(ValueError, match="not in"):
        percentiles(np.array([1.0]), (50, 101))


def test_percentile_places_zeros_of_either_sign_as_numpy_does():
    """numpy's sort and its partition order 0.0 and -0.0 differently: the same selection as numpy's call."""
    values = np.array([0.0, 0.0, 0.0, 0.0, -0.0])
    assert np.signbit(percentile(values, 90)) == np.signbit(np.percentile(values, 90))


def test_percentile_of_no_values_or_beyond_0_to_100_is_an_error():
    with pytest.raises(ValueError, match="no values"):
        percentile(np.array([]), 50)
    for q in (-1, 100.5):
        with pytest.raises(ValueError, match="not in"):
            percentile(np.array([1.0, 2.0]), q)


_MANY = st.integers(2048, 9000)


@given(arrays(_FLOATS, _MANY, elements=st.floats(-1e3, 1e3, width=32) | st.sampled_from([0.0, -0.0, 0.5])),
       st.sampled_from([1e-30, 1.0, 1e30]))
def test_median_and_mad_of_many_values_are_numpys(values, scale):
    """From SELECT_FROM values on, the order statistics are selected through a histogram: the same values as numpy's,
    with ties, zeros of either sign, tiny and huge spans (a few distinct values make most bins empty)."""
    values = (values * scale).astype(values.dtype)
    _same_bits(median(values), np.median(values))
    v = values.astype(np.float64)
    assert robust_std(values) == MAD_TO_SIGMA * np.median(np.abs(v - np.median(v)))


@pytest.mark.parametrize("extra", [np.inf, -np.inf, 3e38, np.nan])
def test_median_of_many_values_with_extremes(extra):
    rng = np.random.default_rng(1)
    for dtype in (np.float32, np.float64):
        values = rng.normal(size=5001).astype(dtype)
        values[[7, 4000]] = extra
        values[100] = -3e38 if extra == 3e38 else values[100]      # a span that overflows float32
        numpys = np.median(values)
        ours = median(values)
        assert (np.isnan(ours) and np.isnan(numpys)) or (ours == numpys and type(ours) is type(numpys))
        v = values.astype(np.float64)
        mad = MAD_TO_SIGMA * np.median(np.abs(v - np.median(v)))
        assert (np.isnan(mad) and np.isnan(robust_std(values))) or robust_std(values) == mad


def test_median_of_many_skewed_values():
    """One far value puts nearly every value in the first bin: the selection still reads the right one."""
    rng = np.random.default_rng(2)
    values = np.concatenate([rng.normal(size=40000), [1e12]])
    assert median(values) == np.median(values)
    assert median(values.reshape(1, -1)) == np.median(values)
    assert median(np.arange(10001)) == 5000.0


def test_median_of_many_tied_values():
    """A clean scan's differences are mostly exactly 0: the nested histograms end on a bin of equal values."""
    rng = np.random.default_rng(3)
    for share in (0.3, 0.8, 0.999):
        values = np.where(rng.random(30001) < share, 0.0, rng.normal(size=30001)).astype(np.float32)
        assert median(values) == np.median(values)
        v = values.astype(np.float64)
        assert robust_std(values) == MAD_TO_SIGMA * np.median(np.abs(v - np.median(v)))


def _same_bits(ours, numpys):
    """The same value to the bit (zeros of either sign told apart) and the same type."""
    assert type(ours) is type(numpys) and np.asarray(ours).tobytes() == np.asarray(numpys).tobytes(), (ours, numpys)


@pytest.mark.parametrize("values", [
    np.arange(3000) * 1e-310,                                                  # a span of subnormals
    np.linspace(0.0, 1e-305, 3001),                                            # its deviations' span underflows
    np.longdouble(1) + np.arange(5001, dtype=np.longdouble) * np.longdouble(2.0) ** -70,   # one float64 apart
    np.arange(1, 3002, dtype=np.longdouble) * np.longdouble("1e-4000"),
    np.full(3001, -0.0), np.r_[-np.ones(1500), -0.0, np.ones(1500)], np.array([-0.0, -0.0, 1.0]),
    np.where(np.random.default_rng(0).random(3000) < 0.3, 0.0, -0.0),
    np.full(3000, 40000, np.float16), np.full(3, 40000, np.float16),             # float16 averaged in float32
    np.r_[np.zeros(50000, np.float32), np.random.default_rng(1).normal(size=30000).astype(np.float32)],
    np.r_[np.random.default_rng(2).normal(size=9000) * 1e-15, 1.0, 1e-4, 1e-8, 1e-12],   # nested far values
])
def test_median_and_mad_to_the_bit_where_binning_is_delicate(values):
    """A reviewer's cases: spans too small for float64 to bin, long doubles float64 does not resolve, zeros of either
    sign (numpy's median averages from +0.0), float16 (averaged in float32), ties, far values."""
    _same_bits(median(values), np.median(values))
    v = values.astype(np.float64)
    _same_bits(np.float64(robust_std(values)), np.float64(MAD_TO_SIGMA * np.median(np.abs(v - np.median(v)))))


def test_median_along_an_axis_averages_as_numpy():
    values = np.array([[-0.0, -0.0, -0.0, -0.0], [40000, 40000, 40000, 1], [-0.0, 2, -0.0, 3]], np.float16)
    for axis in (0, 1):
        ours, numpys = median(values, axis=axis), np.median(values, axis=axis)
        assert ours.dtype == numpys.dtype and ours.tobytes() == numpys.tobytes()
    assert median(np.full((2, 4), -0.0), axis=1).tobytes() == np.median(np.full((2, 4), -0.0), axis=1).tobytes()
