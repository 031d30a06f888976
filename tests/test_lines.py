"""Crossing-lines detector (Sohn et al., seed 004) and local dynamic thresholding, against exact truth."""

import zlib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from matplotlib.figure import Figure

from aerofid import synth
from aerofid.detect import hough_lines, lines
from aerofid.detect.lines import LineFit, LinesParams, LinesResult
from aerofid.detect.threshold import fill_tiles, local_dynamic_threshold
from aerofid.errors import AerofidInputError
from detector_checks import assert_contract, assert_rejects_noise_flat_and_edges, sigma_ratio
from detector_checks import synthetic_marks as _marks

# --- local dynamic thresholding -------------------------------------------------------------------------

def test_local_dynamic_threshold_separates_the_mark_and_ignores_noise():
    rng = np.random.default_rng(0)
    s = synth.mark_scene("cross", 30, width=2, window=48, rng=rng, blur_sigma=0.7, noise_sigma=0.02)
    truth = synth.coverage((48, 48), (s.marks[0].x, s.marks[0].y), synth.cross_shape(30, 2)) > 0.5
    b, t = local_dynamic_threshold(s.image, 8, return_thresholds=True)
    assert b.dtype == bool and b.shape == s.image.shape and np.isfinite(t).all()
    assert (b & truth).sum() >= 0.9 * truth.sum()          # the bars are foreground
    assert (b & ~truth).sum() <= 0.5 * truth.sum()         # and little else (blurred flanks)
    noise = np.clip(0.1 + rng.normal(0, 0.03, (48, 48)), 0, 1).astype(np.float32)
    assert local_dynamic_threshold(noise).sum() == 0
    assert local_dynamic_threshold(np.full((20, 20), 0.3, np.float32)).sum() == 0


def test_local_dynamic_threshold_follows_a_ramp():
    """A strong density ramp under the mark does not turn half the window to foreground."""
    rng = np.random.default_rng(1)
    s = synth.mark_scene("cross", 30, width=2, window=48, rng=rng, noise_sigma=0.01)
    ramp = np.linspace(0, 0.3, 48, dtype=np.float32)[None, :]
    b = local_dynamic_threshold(np.clip(s.image + ramp, 0, 1))
    assert b.sum() < 0.2 * b.size


# --- Hough lines ----------------------------------------------------------------------------------------

def test_hough_lines_peaks_at_the_drawn_lines():
    img = np.zeros((40, 40), bool)
    img[17, 3:37] = True          # y = 17: theta = 90 deg, rho = 17
    img[5:35, 9] = True           # x = 9: theta = 0, rho = 9
    acc, thetas, rhos = lines.hough_transform(img, theta_step=1.0)
    (i1, j1, _), (i2, j2, _), _ = lines.two_peaks(acc, thetas, 30.0)
    got = sorted([(np.rad2deg(thetas[i]), rhos[j]) for i, j in ((i1, j1), (i2, j2))])
    # a 34 px line fills the same rho cell from 89 to 91 degrees: the peak is one of them
    assert got[0] == pytest.approx((0, 9), abs=1.01) and got[1] == pytest.approx((90, 17), abs=1.01)
    c = hough_lines.intersection(thetas[i1], rhos[j1], thetas[i2], rhos[j2])
    assert c == pytest.approx([9, 17], abs=0.6)


def test_hough_cells_are_centred_on_multiples_of_rho_step():
    """Seed 004's cells: rho = 12 falls in the cell centred on 12 (the accumulator of hough_lines.py with its
    lower edge half a cell below)."""
    img = np.zeros((30, 30), bool)
    img[3:27, 12] = True
    acc, thetas, rhos = lines.hough_transform(img, theta_step=1.0, rho_step=1.0)
    assert rhos[np.argmax(acc[0])] == 12.0 and acc[0].max() == 24


def test_bar_half_width_of_a_ridge_on_a_plateau():
    prof = np.zeros((1, 41))
    prof[0, 10:31] = 2.0                  # a ring's plateau under the bar
    prof[0, 19:22] = 10.0                 # a bar 3 cells wide
    assert lines.bar_half_width(prof, 0, 20, 1.0) == pytest.approx(1.5)


def test_fill_tiles_interpolates_unknown_tiles():
    t = np.full((3, 3), np.nan)
    t[0, 0], t[2, 2] = 0.2, 0.4
    f = fill_tiles(t)
    assert np.isfinite(f).all() and f[0, 0] == 0.2 and f[2, 2] == 0.4 and 0.2 < f[1, 1] < 0.4


def _line_fit(theta, arms=(10, 10), **kw):
    args = dict(theta=theta, rho=0.0, sigma_offset=0.02, sigma_slope=0.001, rms=0.05, expected_rms=0.04,
                n_slices=20, arms=arms, half_width=1.0, contrast=20.0, side_foreground=0.0)
    args.update(kw)
    return LineFit(**args)


@pytest.mark.parametrize("change,words", [
    ({}, None),
    ({"side_foreground": 0.6}, "bright area"),
    ({"contrast": 2.0}, "hardly stands out"),
    ({"arms": (1, 12)}, "one side"),
    ({"arms": (4, 20)}, "one side"),
])
def test_line_refusal(change, words):
    reason = lines.line_refusal([_line_fit(0.0), _line_fit(np.pi / 2, **change)], LinesParams())
    assert reason is None if words is None else words in reason


def test_centre_covariance_of_orthogonal_lines_is_their_offsets():
    cov = lines.centre_covariance([_line_fit(0.0, sigma_offset=0.03), _line_fit(np.pi / 2, sigma_offset=0.04)],
                                  offset_floor=0.0)
    assert cov == pytest.approx(np.diag([0.03 ** 2, 0.04 ** 2]), abs=1e-12)


# --- detector on synthetic marks ------------------------------------------------------------------------

@pytest.mark.parametrize("style,rotate", [("cross", False), ("cross", True), ("ring_cross", False),
                                          ("ring_x_dot", False)])
def test_detect_accuracy(style, rotate):
    """Measured (20 marks per case): RMS 0.03-0.06 px, max <= 0.2 px."""
    errs, scores = [], []
    for s, size in _marks(style, 20, seed=zlib.crc32(f"{style}-{rotate}".encode()), rotate=rotate):
        m = s.marks[0]
        d = lines.detect(s.image)
        assert d.found, (style, size, d.reason)
        errs.append(np.hypot(d.x - m.x, d.y - m.y))
        scores.append(d.score)
    errs = np.array(errs)
    assert np.sqrt(np.mean(errs ** 2)) <= 0.1
    assert errs.max() <= 0.3
    assert np.median(scores) >= 0.8


def test_sigma_is_honest():
    """Observed per-axis RMS error over the mean reported sigma: measured 0.80 for this seed (0.60-0.86 for
    seeds 1-3: ``offset_floor`` makes sigma somewhat pessimistic on tilted lines, by design)."""
    ratio = sigma_ratio(lines.detect, ("cross", "ring_cross", "ring_x_dot"), 12, seed=21)
    assert 0.7 <= ratio <= 1.5, ratio


def test_detection_contract():
    s, _ = next(_marks("cross", 1, seed=5))
    d = lines.detect(s.image)
    assert_contract(d, "lines", ())
    assert isinstance(d, LinesResult)
    assert d.binary is not None and d.binary.shape == s.image.shape and d.thresholds is not None
    assert d.peaks is not None and d.hough_centre is not None and d.score_parts is not None
    assert len(d.lines) == 2 and len(d.fitted_lines) == 2 and d.covariance.shape == (2, 2)
    assert d.extent == max(max(f.arms) for f in d.lines) + 1.0
    assert d.score == pytest.approx(min(d.score_parts.arms, d.score_parts.angle, d.score_parts.peaks,
                                        d.score_parts.fit))
    fig = Figure()
    d.plot(fig, s.image)
    assert len(fig.axes) == 1 and len(fig.axes[0].lines) == 5      # 2 Hough lines, 2 refined lines, the centre
    assert LinesResult.not_found("lines", "homogeneous window").extent is None


def test_not_found_keeps_what_was_computed():
    d = lines.detect(synth.add_gaussian_noise(np.full((48, 48), 0.2, np.float32), 0.02, np.random.default_rng(1)))
    assert not d.found and d.reason and d.binary is not None and d.lines == ()
    fig = Figure()
    d.plot(fig, np.zeros((48, 48)))
    assert len(fig.axes) == 1


@pytest.mark.parametrize("name,value", [
    ("theta_step", 0), ("theta_step", 0.0), ("theta_step", 1e-9), ("theta_step", float("nan")), ("rho_step", 0),
    ("rho_step", -1.0), ("rho_step", 1e-6), ("region", 0), ("region", 8.5), ("min_angle", 0), ("min_angle", 120),
    ("iterations", 0), ("min_peak_ratio", 1.5), ("band_margin", -1.0), ("min_arm", -1), ("taper", float("inf")),
    ("max_asymmetry", float("nan")), ("max_side_foreground", -0.1), ("offset_floor", "0.03"),
])
def test_bad_parameters_are_one_line_errors(name, value):
    with pytest.raises(ValueError) as e:
        LinesParams(**{name: value})
    assert name in str(e.value) and "\n" not in str(e.value)
    with pytest.raises(AerofidInputError) as e:
        LinesParams.from_mapping({name: value}, "lines")
    assert name in str(e.value) and "\n" not in str(e.value)


def test_parameters_reach_the_detector():
    """A finer Hough grid still finds the mark; min_angle above the mark's angle refuses it."""
    s, _ = next(_marks("cross", 1, seed=5))
    assert lines.detect(s.image, LinesParams(theta_step=1.0, rho_step=0.5)).found
    d = lines.detect(s.image, LinesParams(max_side_foreground=0.0, min_contrast=1e5))
    assert not d.found and d.reason


# --- rejections -----------------------------------------------------------------------------------------

def test_rejects_noise_homogeneous_and_a_straight_edge():
    assert_rejects_noise_flat_and_edges(lines.detect)


@pytest.mark.parametrize("angle", [0.0, 30.0])
@pytest.mark.parametrize("gap", [6.0, 12.0])
def test_rejects_two_parallel_lines(angle, gap):
    rng = np.random.default_rng(4)
    img = synth.film_border((64, 64), rng)
    t = np.deg2rad(angle)
    for off in (-gap / 2, gap / 2):
        c = (31.5 - off * np.sin(t), 32.2 + off * np.cos(t))
        img = synth.paint(img, synth.coverage((64, 64), c, synth.bar(50, 2, angle)), 0.85)
    img = synth.add_gaussian_noise(synth.blur(img, 0.7), 0.02, rng)
    d = lines.detect(img)
    assert not d.found and d.reason


@pytest.mark.parametrize("style", ["cross", "ring_cross", "ring_x_dot"])
def test_rejects_mark_cut_in_half(style):
    rng = np.random.default_rng(5)
    for size in (24, 40, 56):
        s = synth.mark_scene(style, size, window=int(size * 1.6) + 8, rng=rng)
        m = s.marks[0]
        for cut in (-2, 0, 1, 2):
            d = lines.detect(s.image[:, : int(m.x) + 1 + cut])
            assert not d.found, (style, size, cut, d.x - m.x, d.y - m.y)


def test_rejects_a_t_junction():
    rng = np.random.default_rng(6)
    img = synth.film_border((64, 64), rng)
    img = synth.paint(img, synth.coverage((64, 64), (31.7, 20.3), synth.bar(44, 2, 0.0)), 0.85)
    img = synth.paint(img, synth.coverage((64, 64), (31.7, 20.3 + 20), synth.bar(40, 2, 90.0)), 0.85)
    d = lines.detect(synth.add_gaussian_noise(synth.blur(img, 0.7), 0.02, rng))
    assert not d.found and "one side" in d.reason


def test_bad_inputs_are_not_found_not_exceptions():
    assert lines.detect(np.zeros((4, 4), np.float32)).status == "not_found"
    img = np.full((32, 32), 0.1, np.float32)
    img[3, 3] = np.nan
    assert lines.detect(img).status == "not_found"


@pytest.mark.parametrize("style,found", [("dot", 0), ("bullseye", 4)])
def test_marks_without_lines_get_no_confident_wrong_centre(style, found):
    """Chords through a dot or a bull's-eye cross off its centre; before the half-turn check ``lines`` answered
    13 of 30 dots and 8 of 30 bull's-eyes 1.5-4.5 px off (docs/benchmarks_marks.md). Measured here: no dot and
    4 of 12 bull's-eyes answered, all within 1 px of their centre."""
    n = 0
    for s, _ in _marks(style, 12, seed=31):
        m = s.marks[0]
        d = lines.detect(s.image)
        n += d.found
        assert not d.found or np.hypot(d.x - m.x, d.y - m.y) < 1.0, (d.x - m.x, d.y - m.y)
    assert n == found


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.floats(-1.5, 1.5), st.floats(0.0, 3.14))
def test_stretch_planes_equal_each_stretchs_own_least_squares(seed, ramp, theta):
    """The background planes solved together (normal equations, centred) are each stretch's own least-squares
    plane (numpy's lstsq through _plane), stretch by stretch, on windows with a density ramp and noise."""
    rng = np.random.default_rng(seed)
    h, w = rng.integers(12, 60, 2)
    yy, xx = np.mgrid[0:h, 0:w]
    window = 0.3 + ramp * 0.004 * xx - 0.002 * yy + rng.normal(0, 0.02, (h, w))
    fr = lines._frame(window, theta, float(rng.uniform(0, min(h, w))), np.inf)   # every pixel
    band = float(rng.uniform(1.0, 4.0))
    ring = (np.abs(fr.v) > band) & (np.abs(fr.v) <= band + lines.RING_WIDTH) & (rng.random(fr.v.size) > 0.2)
    if ring.sum() < 4:
        return
    uc = float(rng.uniform(0, max(h, w)))
    every = np.ones(fr.v.size, bool)
    got = lines._local_background(fr, ring, uc, band, every)
    some = rng.random(fr.v.size) > 0.6          # evaluated at some pixels only: the same numbers there, exactly
    np.testing.assert_array_equal(lines._local_background(fr, ring, uc, band, some), got[some])
    u = fr.u - uc
    seg = np.floor(u / lines.SLICE_LENGTH).astype(np.int64)
    want = lines._plane(fr.g[ring], fr.v[ring], u[ring], fr.v, u)
    for s in np.unique(seg):
        m, on = ring & (seg == s), seg == s
        if m.sum() >= 8 and np.ptp(fr.v[m]) > band:
            want[on] = lines._plane(fr.g[m], fr.v[m], u[m], fr.v[on], u[on])
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)


def test_a_stretch_of_one_row_gets_its_own_least_squares_plane():
    """A stretch whose ring samples lie on one row (u constant: its normal equations are singular) is fitted on its
    own, as numpy's lstsq gives it (the minimum-norm plane)."""
    yy, xx = np.mgrid[0:9, 0:40]
    window = 0.3 + 0.01 * xx + 0.02 * yy + 0.001 * np.sin(xx * yy)
    fr = lines._frame(window, 0.0, 20.0, np.inf)
    ring = np.abs(fr.v) > 2.0
    got = lines._local_background(fr, ring, 0.0, 2.0, np.ones(fr.v.size, bool))
    last = fr.u == 8.0                       # the second stretch: row 8 alone
    want = lines._plane(fr.g[ring & last], fr.v[ring & last], fr.u[ring & last], fr.v[last], fr.u[last])
    assert lines._stretch_planes((fr.u[ring] >= 8).astype(np.int64), fr.g[ring], fr.v[ring], fr.u[ring], 2.0,
                                 2).solo == (1,)
    np.testing.assert_allclose(got[last], want, rtol=0, atol=1e-12)


@pytest.mark.parametrize("style", ["cross", "ring_cross"])
def test_a_line_fit_reads_only_the_pixels_near_its_line_and_answers_as_on_the_whole_window(monkeypatch, style):
    """fit_line takes the window's pixels within its band and background strips (``_frame``'s reach): the answers,
    found or refused, are those made on every pixel of the window, to the bit (centre, covariance, score, both lines'
    fits and statistics, or the reason)."""
    scenes = [s.image for s, _ in _marks(style, 4, seed=5)]
    scenes += [np.roll(img, img.shape[1] // 3, axis=1) for img in scenes[:2]]     # cut by the window's edge
    whole_frame = lines._frame

    def answers() -> list[str]:
        return [repr((d.status, d.reason, d.x, d.y, d.sigma_x, d.sigma_y, d.cov_xy, d.score, d.lines))
                for d in map(lines.detect, scenes)]

    near = answers()
    monkeypatch.setattr(lines, "_frame", lambda window, theta, rho, reach: whole_frame(window, theta, rho, np.inf))
    assert near == answers()
    assert sum("'found'" in a for a in near) >= 4
