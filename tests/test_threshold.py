"""Reddi's optimum threshold of many windows at once against each window's own (seed 001, thesis Appendix B)."""

from __future__ import annotations

import struct

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from aerofid.detect import threshold
from aerofid.detect.threshold import (
    N_BINS,
    Threshold,
    _cumulative_sums,
    _reddi_iteration,
    _row_class_means,
    optimum_threshold,
    optimum_thresholds,
    tile_thresholds,
)


def _windows(rng: np.random.Generator, kind: int, n: int, pixels: int) -> np.ndarray:
    """Windows of one of four kinds: uniform, Gaussian of three spreads (some homogeneous), a few grey levels
    (cycles of the iteration), a bright third on a noisy ground."""
    if kind == 0:
        return rng.random((n, pixels))
    if kind == 1:
        return rng.normal(0.5, rng.choice([0.001, 0.01, 0.1]), (n, pixels))
    if kind == 2:
        return np.round(rng.random((n, pixels)) * rng.integers(2, 20)) / 20
    w = rng.normal(0.3, 0.02, (n, pixels))
    w[:, : pixels // 3] += rng.random() * 0.5
    return w


def _bits(t: Threshold | None) -> tuple[bytes, ...] | None:
    """A threshold's fields as their bits (-0.0 is not 0.0 here)."""
    if t is None:
        return None
    return (*(struct.pack("<d", v) for v in (t.value, t.mean_dark, t.mean_bright, t.bright_fraction)),
            struct.pack("<q", t.iterations))


def _same(batch, i: int, window: np.ndarray, **kw) -> bool:
    one = optimum_threshold(window, **kw)
    if one is None:
        return batch.threshold(i) is None and not batch.found[i] and batch.iterations[i] == 0
    return _bits(batch.threshold(i)) == _bits(one)


def _ended_by_a_cycle(window: np.ndarray) -> bool:
    """Whether the window's iteration ended on a cycle (the k kept leaves |e| >= 0.5 bin)."""
    v = np.asarray(window, np.float64).ravel()
    lo, hi = v.min(), v.max()
    c0, c1 = _cumulative_sums(v[None], np.array([lo]), np.array([(hi - lo) / N_BINS]), N_BINS)
    got = _reddi_iteration(lambda k: _row_class_means(c0[0], c1[0], k), N_BINS, 50)
    if got is None:
        return False
    m_dark, m_bright = _row_class_means(c0[0], c1[0], got[0])
    return abs((m_dark + m_bright) / 2.0 + 0.5 - got[0]) >= 0.5


def test_the_thresholds_of_many_windows_are_each_windows_own_to_the_bit(monkeypatch):
    calls = {"alone": 0, "cycle": 0}

    def counted(name, f):
        def g(*args):
            calls[name] += 1
            return f(*args)
        return g

    monkeypatch.setattr(threshold, "_reddi_iteration", counted("alone", threshold._reddi_iteration))
    monkeypatch.setattr(threshold, "_closest", counted("cycle", threshold._closest))
    rng = np.random.default_rng(0)
    checked = cycles = 0
    for trial in range(600):
        n, pixels = int(rng.integers(1, 40)), int(rng.integers(2, 300))
        w = _windows(rng, trial % 4, n, pixels)
        w = w.astype(np.float32) if trial % 2 else w
        batch = optimum_thresholds(w)
        for i in range(n):
            assert _same(batch, i, w[i]), (trial, i)
        checked += n
        cycles += sum(_ended_by_a_cycle(x) for x in w) if trial % 4 == 2 else 0
    assert checked > 10_000
    assert cycles > 10                  # windows whose iteration ends on the cycle rule
    assert calls["cycle"] > 10          # ... resolved by whole-array steps
    assert calls["alone"] > 1_000       # windows finished alone (stragglers, and calls of a few windows)


def test_a_cycle_keeps_the_first_visited_of_the_ks_that_came_equally_close():
    # 14 bins over 0..13: from k = 7 the iteration visits 7 and 6, both |e| = 0.5 bin (not below it), and would
    # return to 7; the first visited of the two, k = 7, is kept (the dict's minimum), not the smaller k
    w = np.tile(np.array([0.0, 10.0, 13.0, 13.0]), (5, 1))
    batch = optimum_thresholds(w, n_bins=14)
    assert all(_same(batch, i, w[i], n_bins=14) for i in range(5))
    assert batch.value[0] == pytest.approx(7 * 13 / 14)


@settings(max_examples=200, deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(1, 12), st.integers(2, 60)),
              elements=st.sampled_from([0.0, 0.05, 0.1, 0.3, 0.31, 0.5, 0.9, 1.0])))
def test_the_thresholds_of_few_grey_levels_are_each_windows_own(w):
    batch = optimum_thresholds(w)
    assert all(_same(batch, i, w[i]) for i in range(len(w)))


def test_a_homogeneous_window_and_one_of_a_single_pixel_have_none():
    batch = optimum_thresholds(np.array([[0.4] * 9, [0.4, 0.41] + [0.4] * 7]))
    assert not batch.found.any() and np.isnan(batch.value).all()
    assert not optimum_thresholds(np.array([[0.1], [0.9]])).found.any()


def _tiles_one_by_one(w: np.ndarray, region: int, min_sep: float, min_contrast: float = 0.02,
                      min_class: int = 2) -> np.ndarray:
    """:func:`tile_thresholds` by its definition, as it was written before its tiles were thresholded together."""
    h, wd = w.shape
    t = np.full((-(-h // region), -(-wd // region)), np.nan)
    for i in range(t.shape[0]):
        for j in range(t.shape[1]):
            tile = w[i * region:(i + 1) * region, j * region:(j + 1) * region]
            th = optimum_threshold(tile, min_contrast=min_contrast)
            if th is None:
                continue
            bright = tile >= th.value
            nb = int(bright.sum())
            if nb < min_class or tile.size - nb < min_class:
                continue
            if float(tile[bright].mean() - tile[~bright].mean()) >= min_sep:
                t[i, j] = th.value
    return t


@pytest.mark.parametrize("seed", range(4))
def test_tile_thresholds_are_every_tiles_own(seed):
    rng = np.random.default_rng(seed)
    for trial in range(150):
        h, wd = (int(v) for v in rng.integers(1, 90, 2))
        region = int(rng.integers(2, 12))
        w = rng.normal(0.3, rng.choice([0.005, 0.02, 0.1]), (h, wd))
        if trial % 3 == 0:                              # a bright block: bimodal tiles along its edges
            w[rng.integers(0, h):, :rng.integers(0, wd)] += 0.4
        if trial % 5 == 0:
            w = np.round(w * 20) / 20
        if trial % 7 == 0:                              # pixels without a finite value: their tiles alone
            w[rng.integers(0, h), rng.integers(0, wd)] = np.nan
            w[rng.integers(0, h), rng.integers(0, wd)] = np.inf
        w = w.astype((np.float32, np.float64, np.float16)[trial % 3])
        min_sep = float(rng.choice([0.02, 0.05, 0.1, 0.2]))
        assert np.array_equal(tile_thresholds(w, region, min_sep), _tiles_one_by_one(w, region, min_sep),
                              equal_nan=True), (seed, trial)


def test_a_tile_whose_classes_are_min_sep_apart_is_decided_as_its_own_mean_decides():
    w = np.tile(np.array([[0.25, 0.5], [0.5, 0.25]], np.float32), (8, 8))   # classes exactly 0.25 apart
    for min_sep in (0.25, np.nextafter(0.25, 1.0), np.nextafter(0.25, 0.0)):
        assert np.array_equal(tile_thresholds(w, 8, float(min_sep)), _tiles_one_by_one(w, 8, float(min_sep)),
                              equal_nan=True)
    assert np.isfinite(tile_thresholds(w, 8, 0.25)).all() and np.isnan(tile_thresholds(w, 8, 0.2501)).all()


def test_a_pixel_at_the_threshold_in_float32_is_bright_as_float32_compares_it():
    # the threshold (0.4968749889 in float64) lies above the 11 pixels of 0.496875 (0.4968749881 in float32) but
    # rounds to them in float32, where a Python float is compared with float32 pixels: they are bright, and the
    # classes' means are then 0.56 or more apart (in float64 they would be dark, and the tile not bimodal)
    values = np.repeat(np.array([0.1, 0.496875, 0.5773708, 0.9], np.float32), [22, 11, 13, 18]).reshape(8, 8)
    assert np.array_equal(tile_thresholds(values, 8, 0.56), _tiles_one_by_one(values, 8, 0.56), equal_nan=True)
    assert tile_thresholds(values, 8, 0.56)[0, 0] == pytest.approx(0.496875)
