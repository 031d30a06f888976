"""Fuzz tests (issue 11): hypothesis strategies over boxes, parameters, image arrays and image files through the
Python API, and random hostile commands through the CLI (tests/fuzz_cli.py; the long run is
``benchmarks/fuzz.py --n 10000``). Every answer is a result or one :class:`AerofidInputError` line, never another
exception; every command ends with a documented status, no traceback, no noise, no file changed but its outputs.
Kept under a minute in all."""

from __future__ import annotations

import dataclasses
import io
import math
import random

import cv2
import numpy as np
import pytest
import tifffile
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from aerofid import locate
from aerofid.detect.auto import AutoParams
from aerofid.detect.registry import METHODS
from aerofid.errors import AerofidInputError
from aerofid.io.array import as_image_array
from aerofid.io.raster import open_raster
from fuzz_cli import judge, make_workspace, pristine_copy, random_case, restore, run_case, snapshot, warm_up

PARAM_TYPES = {**{m: METHODS[m].params_type for m in METHODS}, "auto": AutoParams}
FAST = settings(max_examples=60, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])

hostile_numbers = st.one_of(
    st.integers(min_value=-10**6, max_value=10**6), st.integers(min_value=10**300, max_value=10**420),
    st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([0, -0.0, 1e-300, 1e308, 5e-324]),
    st.text(max_size=5), st.booleans(), st.none())
boxes = st.one_of(st.lists(hostile_numbers, min_size=0, max_size=6).map(tuple),
                  st.tuples(*[st.floats(-50, 150, allow_nan=False)] * 4), st.text(max_size=8), st.none(),
                  st.binary(max_size=8))


def _scene() -> np.ndarray:
    image = np.full((96, 96), 30, np.uint8)
    image[46:50, 28:68] = 220
    image[28:68, 46:50] = 220
    return image


SCENE = _scene()


@FAST
@given(box=boxes)
def test_any_box_is_a_result_or_one_input_error(box):
    try:
        r = locate(SCENE, box, mark="external", method="hough")
    except AerofidInputError as e:
        assert "\n" not in str(e)
    else:
        assert r.status in ("found", "not_found")


@st.composite
def method_params(draw):
    method = draw(st.sampled_from(sorted(PARAM_TYPES)))
    names = [f.name for f in dataclasses.fields(PARAM_TYPES[method]) if f.name != "mark"]  # locate's own argument
    chosen = draw(st.lists(st.sampled_from(names), min_size=1, max_size=2, unique=True))
    return method, {n: draw(hostile_numbers) for n in chosen}


@settings(max_examples=40, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(case=method_params())
def test_any_parameter_value_is_a_result_or_one_input_error(case):
    method, params = case
    try:
        r = locate(SCENE, (30, 30, 66, 66), mark="external", method=method, **params)
    except AerofidInputError as e:
        assert "\n" not in str(e)
    else:
        assert r.status in ("found", "not_found")


@FAST
@given(dtype=st.sampled_from([np.int8, np.int16, np.int32, np.int64, np.uint32, np.uint64, np.float16, np.float32,
                              np.float64]),
       scale=st.sampled_from([1.0, 255.0, 65535.0, 1e12, -1.0, math.nan, math.inf]))
def test_any_image_array_is_on_a_known_scale_or_one_input_error(dtype, scale):
    image = SCENE / 255.0 * scale
    with np.errstate(all="ignore"):
        cast = image.astype(dtype)
    try:
        samples = as_image_array(cast)
    except AerofidInputError as e:
        assert "\n" not in str(e)
        return
    if samples.dtype.kind == "f":
        assert float(samples.max()) <= 2.0  # on the unit scale (noise may reach a little beyond 1)
        if scale in (255.0, 65535.0):
            np.testing.assert_allclose(samples, SCENE / 255.0, atol=1e-3)
    else:
        assert samples.dtype.kind == "u"


def test_integer_and_float_arrays_of_0_255_find_the_mark_as_uint8_does():
    truth = locate(SCENE, (30, 30, 66, 66), mark="external")
    assert truth.found
    for kind in (np.int16, np.int64, np.uint32, np.uint64, np.float32, np.float64):
        r = locate(SCENE.astype(kind), (30, 30, 66, 66), mark="external")
        assert r.found and math.hypot(r.x - truth.x, r.y - truth.y) < 1e-3, kind


def _encoded(kind: str) -> bytes:
    if kind == "tif":
        buffer = io.BytesIO()
        tifffile.imwrite(buffer, SCENE, tile=(32, 32), compression="deflate")
        return buffer.getvalue()
    return cv2.imencode(f".{kind}", SCENE)[1].tobytes()


ENCODED = {k: _encoded(k) for k in ("tif", "png", "jpg")}


@settings(max_examples=80, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow,
                                                                  HealthCheck.function_scoped_fixture])
@given(kind=st.sampled_from(sorted(ENCODED)), cut=st.integers(0, 4000),
       flips=st.lists(st.tuples(st.integers(0, 400), st.integers(1, 255)), max_size=4))
def test_any_damaged_image_file_reads_or_is_one_input_error(tmp_path, kind, cut, flips):
    data = bytearray(ENCODED[kind][: max(cut, 0) or None])
    for at, mask in flips:
        if at < len(data):
            data[at] ^= mask
    path = tmp_path / f"x.{kind}"
    path.write_bytes(bytes(data))
    try:
        with open_raster(path) as scan:
            window = scan.read_window((0, 0, min(scan.width, 40), min(scan.height, 40)))
    except AerofidInputError as e:
        assert "\n" not in str(e)
    else:
        assert window.ndim in (2, 3)


@pytest.fixture(scope="module")
def fuzz_ws(tmp_path_factory):
    ws = make_workspace(tmp_path_factory.mktemp("fuzz"))
    warm_up(ws, tmp_path_factory.mktemp("warm"))
    return ws, pristine_copy(ws, tmp_path_factory.mktemp("p") / "pristine")


@pytest.mark.parametrize("seed", range(40))
def test_random_hostile_commands(fuzz_ws, tmp_path, seed):
    ws, pristine = fuzz_ws
    case = random_case(random.Random(10_000 + seed), ws, seed)
    before = snapshot(ws.root)
    outcome = run_case(case, ws, tmp_path, time_limit=60)
    after = snapshot(ws.root)
    verdict = judge(case, outcome, before, after)
    restore(ws, before, after, pristine)
    assert verdict.ok, (case, verdict, outcome.stderr)
