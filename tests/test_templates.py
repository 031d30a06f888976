"""A roll's mark templates (aerofid.frame.templates): cut from the window a mark was measured on, they find the
same kind of mark again on another scan, reduced, to a reduced pixel; they find nothing where there is no mark;
their file form is read back exactly, and a malformed one is refused in one line."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aerofid import synth
from aerofid.detect.screen import Candidate
from aerofid.errors import AerofidInputError
from aerofid.find import Measurer
from aerofid.frame import marks as marks_module
from aerofid.frame.templates import MarkTemplate, cut_template, match_template, reduction_keeping
from aerofid.io.array import open_image
from aerofid.methods import make_detector

SIZE = 80.0                         # the ring-and-cross's extent: a radius of about 40 px


def _reduced(img: np.ndarray, f: int) -> np.ndarray:
    """Block means of ``img`` on the reduced scan's grid (reduced pixel i: full pixels f i .. f i + f - 1)."""
    h, w = (img.shape[0] // f) * f, (img.shape[1] // f) * f
    return img[:h, :w].reshape(h // f, f, w // f, f).mean(axis=(1, 3))


def _learnt(seed: int = 1) -> MarkTemplate:
    scene = synth.mark_scene("ring_x_dot", SIZE, window=200, centre=(100.3, 97.6), rng=np.random.default_rng(seed))
    t = cut_template(scene.image, (0, 0, 200, 200), 100.3, 97.6, SIZE / 2)
    assert t is not None
    return t


@settings(max_examples=25, deadline=None)
@given(x=st.floats(110, 290), y=st.floats(110, 290), seed=st.integers(0, 2**16))
def test_a_template_finds_the_mark_again_to_a_reduced_pixel(x, y, seed):
    """Learnt on one scene, matched on another (other noise, the mark anywhere in a 400 px area reduced by the
    template's factor): the mark's centre within 0.25 full px (0.084 px at most in 60 such scenes), correlating
    well above the threshold."""
    t = _learnt()
    assert t.factor == reduction_keeping(SIZE / 2, 16.0) == 2
    scene = synth.mark_scene("ring_x_dot", SIZE, window=400, centre=(x, y), rng=np.random.default_rng(seed))
    found = match_template(_reduced(scene.image, t.factor), t)
    assert found is not None
    fx, fy, score = found
    f = t.factor
    assert math.hypot(f * fx + (f - 1) / 2 - x, f * fy + (f - 1) / 2 - y) < 0.25, (fx, fy)
    assert score > 0.8


@pytest.mark.parametrize("centre", [(700.4, 612.7), (75.2, 1118.9)])
def test_a_roll_frame_is_sought_on_the_reduced_scan_where_the_template_correlates(centre):
    """The marks' step for a roll's first marks (``marks._matched``): the scan read reduced by the template's
    factor (2) around a prediction 150 px off, the area clipped by the scan's edge for the second mark; the place it
    gives (full px) within 0.25 px of the mark, the prediction's radius kept."""
    t = _learnt()
    scene = synth.mark_scene("ring_x_dot", SIZE, window=1200, centre=centre, rng=np.random.default_rng(7))
    start = Candidate(centre[0] + 120.0, centre[1] - 90.0, SIZE / 2, 0.0)
    with open_image(scene.image) as source:
        measurer = Measurer(source, make_detector("symmetry", "auto", {}), ("bright",))
        got = marks_module._matched(measurer, t, start, reach=200.0)
    assert got is not None and got.radius == start.radius
    assert math.hypot(got.x - centre[0], got.y - centre[1]) < 0.25, (got.x, got.y)


def test_no_mark_no_place():
    """Film border without a mark, and aerial ground: nothing correlates enough."""
    t = _learnt()
    rng = np.random.default_rng(4)
    for ground in (synth.film_border((400, 400), rng), synth.aerial_ground((400, 400), rng)):
        assert match_template(_reduced(ground, t.factor), t) is None


def test_an_area_smaller_than_the_template_finds_nothing():
    t = _learnt()
    assert match_template(np.zeros((t.shape[0] - 1, 500), np.float32), t) is None


def test_a_mark_cut_by_the_window_gives_no_template():
    """The window (the scan's edge) holds less than the mark's own disc on one side."""
    scene = synth.mark_scene("ring_x_dot", SIZE, window=200, centre=(30.0, 100.0), rng=np.random.default_rng(2))
    assert cut_template(scene.image, (0, 0, 200, 200), 30.0, 100.0, SIZE / 2) is None
    assert cut_template(np.full((200, 200), 0.3), (0, 0, 200, 200), 100.0, 100.0, SIZE / 2) is None  # no contrast


def test_a_template_reads_back_exactly():
    t = _learnt()
    assert MarkTemplate.from_dict(t.to_dict()) == t
    assert t.image.shape == t.shape


@pytest.mark.parametrize(("change", "message"), [
    ({"levels": "not base64!"}, "base64"),
    ({"levels": "é"}, "base64"),
    ({"levels": 5}, "base64 text"),
    ({"levels": "AAAA"}, "do not fill"),
    ({"levels": "AAAAAAAAAAAA", "shape": [3, 3]}, "without contrast"),
    ({"factor": 3}, "power of two"),
    ({"factor": 2**1000}, "power of two"),
    ({"factor": True}, "power of two"),
    ({"shape": ["a", 3]}, "whole numbers"),
    ({"shape": [3.9, 3.2]}, "whole numbers"),
    ({"centre": [-5.0, 2.0]}, "inside"),
    ({"centre": ["x", 1]}, "inside"),
    ({"centre": [float("nan"), 1]}, "inside"),
])
def test_a_malformed_template_is_refused(change, message):
    d = {**_learnt().to_dict(), **change}
    with pytest.raises(AerofidInputError, match=message):
        MarkTemplate.from_dict(d)


def test_a_malformed_template_that_is_no_mapping_is_refused():
    with pytest.raises(AerofidInputError, match="must hold"):
        MarkTemplate.from_dict([1, 2])
