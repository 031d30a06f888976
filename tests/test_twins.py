"""detect.twins: a mark's own image, turned, finds a turned copy of it; hough.detector.verify_like fits that copy."""

import numpy as np
import pytest

from aerofid import synth
from aerofid.detect import hough
from aerofid.detect.auto import AutoParams
from aerofid.detect.hough.detector import Verified, verify_like
from aerofid.detect.twins import match_peaks, turned_matches


def _two_crosses(turn):
    """Two '+' of 9 px on a noisy plain ground, the second turned by ``turn`` degrees; (image, first, second)."""
    rng = np.random.default_rng(4)
    ground = np.full((120, 160), 0.3, np.float32)
    first, second = (40.3, 50.6), (118.7, 71.2)
    img = synth.panel_scene(rng, centre=first, size=9.0, angle_deg=12.0, contrast=0.4, ground=ground).image
    img = synth.panel_scene(rng, centre=second, size=9.0, angle_deg=12.0 + turn, contrast=0.4, ground=img).image
    return img, first, second


@pytest.mark.parametrize("turn", [0.0, 23.0, 61.0, 135.0])
def test_the_turned_copy_is_the_best_match_and_its_fit_is_the_copys_centre(turn):
    img, (x1, y1), (x2, y2) = _two_crosses(turn)
    found = hough.detect(img[int(y1) - 20:int(y1) + 21, int(x1) - 20:int(x1) + 21], hough.HoughParams(mark="panel"))
    assert found.found and found.refinement is not None
    x, y = found.x + int(x1) - 20, found.y + int(y1) - 20
    matches = turned_matches(img, img, x, y, 7)
    assert matches is not None
    (score, px, py, angle), *_ = match_peaks(matches, x, y, 12.0, 0.5, 3)
    assert np.hypot(px - x2, py - y2) <= 1.0 and score > 0.8
    got = verify_like(img, px, py, found.refinement, angle)
    assert isinstance(got, Verified), got
    assert np.hypot(got.x - x2, got.y - y2) < 0.05


def test_the_mark_itself_and_places_below_the_minimum_are_not_peaks():
    img, (x1, y1), _ = _two_crosses(0.0)
    matches = turned_matches(img, img, x1, y1, 7)
    assert matches is not None
    peaks = match_peaks(matches, x1, y1, 12.0, 0.5, 10)
    assert peaks and all(np.hypot(px - x1, py - y1) > 12.0 and s >= 0.5 for s, px, py, _ in peaks)
    assert [p[0] for p in peaks] == sorted((p[0] for p in peaks), reverse=True)


def test_no_template_where_its_turned_square_leaves_the_image_or_is_flat():
    """A square of half-size 7 turned needs 7 sqrt 2 + 1 = 11 px around its centre: 11 px of room is enough."""
    img, _, _ = _two_crosses(0.0)
    assert turned_matches(img, img, 10.0, 60.0, 7) is None
    assert turned_matches(img, img, 11.0, 60.0, 7) is not None
    assert turned_matches(img, img[:10, :10], 80.0, 60.0, 7) is None
    assert turned_matches(np.full((60, 60), 0.3, np.float32), img, 30.0, 30.0, 7) is None


@pytest.mark.parametrize("bad", [{"twin_fits": 0}, {"twin_fits": 2.5}, {"twin_match": 1.5}, {"twin_match": -0.1},
                                 {"twin_slack": 0.0}])
def test_twin_parameters_are_checked(bad):
    with pytest.raises(ValueError):
        AutoParams(**bad)
