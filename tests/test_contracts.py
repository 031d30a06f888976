"""Contracts every method and the API keep: inputs are never mutated, results are typed and frozen, the
decode cache shared by threads gives every thread the same answer, parameters are checked in one place."""

from __future__ import annotations

import dataclasses
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import aerofid
from aerofid import synth
from aerofid.detect import auto
from aerofid.detect.params import MethodParams
from aerofid.detect.registry import METHODS, SEED_METHODS, route_params
from aerofid.detect.result import Detection
from aerofid.errors import AerofidInputError


def _scene(style: str = "ring_cross", seed: int = 3) -> synth.Scene:
    return synth.mark_scene(style, size=36, window=90, rng=np.random.default_rng(seed))


@pytest.mark.parametrize("name", ["auto", *METHODS])
def test_methods_do_not_mutate_their_window_and_return_their_own_frozen_type(name):
    sc = _scene()
    window = sc.image.copy()
    before = window.copy()
    result = auto.detect(window) if name == "auto" else METHODS[name].detect(window)
    np.testing.assert_array_equal(window, before)
    assert isinstance(result, Detection) and type(result) is not Detection
    assert result.found, (name, result.reason)
    assert np.hypot(result.x - sc.marks[0].x, result.y - sc.marks[0].y) < 0.5
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.x = 0.0  # type: ignore[misc]
    assert isinstance(auto.AutoParams() if name == "auto" else METHODS[name].params_type(), MethodParams)


def test_locate_does_not_mutate_the_image_array():
    sc = _scene()
    img = (sc.image * 255).astype(np.uint8)
    before = img.copy()
    for polarity in ("bright", "auto"):
        aerofid.locate(img, (10, 10, 80, 80), polarity=polarity)
    np.testing.assert_array_equal(img, before)


def test_orient_does_not_mutate_the_measurements():
    mm = {"A": [-100, 100], "B": [100, 100], "C": [100, -100], "D": [-100, -100], "E": [30, 110]}
    cam = aerofid.Camera.from_dict({"name": "c", "fiducials": mm})
    xy = np.array([[4550 + 45 * x, 4550 - 45 * y] for x, y in mm.values()]) + [[0.1, 0], [0, 0.1], [-0.1, 0],
                                                                             [0, -0.1], [0.05, 0.05]]
    before = xy.copy()
    aerofid.orient(cam, dict(zip(mm, xy)), "affine")
    aerofid.orient(cam, xy, "affine", correspondence="auto")
    np.testing.assert_array_equal(xy, before)


def test_the_decode_cache_gives_every_thread_the_same_answer(tmp_path):
    """JPEGs are decoded once and cached (read-only) for every box of the file: eight threads locating eight
    marks at once get exactly what one thread gets, and nobody can write into the cached image."""
    import cv2

    scene = synth.demo_frame(np.random.default_rng(2), size=800)
    path = tmp_path / "scan.jpg"
    cv2.imwrite(str(path), synth.to_uint8(scene.image), [cv2.IMWRITE_JPEG_QUALITY, 95])
    marks = [m for m in scene.marks if m.style == "cross"]

    def one(m: synth.TruthMark) -> tuple[str, float, float]:
        r = aerofid.locate(path, m.box, mark="external")
        assert r.window is not None
        return r.status, r.x, r.y

    serial = [one(m) for m in marks]
    with ThreadPoolExecutor(max_workers=8) as pool:
        parallel = list(pool.map(one, marks * 2))
    assert parallel == serial * 2
    assert sum(s == "found" for s, _, _ in serial) == len(marks)
    from aerofid.io.raster import open_raster

    with open_raster(path) as r:
        w = r.read_window((0, 0, 10, 10))
        assert not w.flags.writeable or not np.shares_memory(w, r.read_window((0, 0, 10, 10)))


def test_the_method_names_a_user_gives_are_the_registry_s_methods():
    """The names the command line offers (``aerofid.conventions``, light: no detector imported for them) are the
    registry's methods in its order, and each runs as the method of that name."""
    from aerofid.conventions import METHOD_NAMES
    from aerofid.methods import make_detector

    assert tuple(METHODS) == SEED_METHODS and METHOD_NAMES == ("auto", *METHODS)
    for name in SEED_METHODS:
        assert make_detector(name, "auto", {}).method is METHODS[name]


def test_every_parameter_name_belongs_to_a_method_and_bad_ones_are_one_line():
    types = {"auto": auto.AutoParams, **{m: METHODS[m].params_type for m in SEED_METHODS}}
    assert set(route_params({}, types)) == {"auto", *SEED_METHODS}
    with pytest.raises(AerofidInputError, match="unknown parameter 'no_such' .* valid: "):
        route_params({"no_such": 1}, types)
    for name in SEED_METHODS:
        with pytest.raises(AerofidInputError) as e:
            aerofid.locate(np.zeros((50, 50)), (0, 0, 50, 50), method=name, no_such=1)
        assert "\n" not in str(e.value) and "valid:" in str(e.value)


def test_a_symmetry_parameter_reaches_symmetry_through_auto():
    """The symmetry docstring tells users to raise max_asymmetry: that works with the default method."""
    sc = _scene("dot")
    r = aerofid.locate(sc.image, (5, 5, 85, 85), max_asymmetry=1.0)
    assert r.found
