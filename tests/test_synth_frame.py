"""Synthetic whole frames (aerofid.synth_frame): the truth is exact, the film's lie follows arrangement_matrix,
and the three writers give back the rendered frame. Frames here are at most 3125 px (0.08 mm pixels)."""

import numpy as np
import pytest
import tifffile

from aerofid.io.raster import open_raster
from aerofid.orientation.correspondence import ARRANGEMENTS, arrangement_matrix, match_fiducials
from aerofid.synth_frame import (
    STRIP_MM,
    TILE,
    FrameTruth,
    MarkStyle,
    frame_bands,
    frame_spec,
    frame_truth,
    render_frame,
    wild_rc10_camera,
    with_lie,
    write_frame,
)

CAMERA = wild_rc10_camera()
COARSE_MM = 0.08


def _centroid(img: np.ndarray, x: float, y: float, half: int) -> tuple[float, float]:
    """Intensity centroid above the window's edge level in a (2 half + 1)^2 window around (x, y)."""
    xi, yi = int(round(x)), int(round(y))
    win = img[yi - half:yi + half + 1, xi - half:xi + half + 1].astype(float)
    edge = np.median(np.r_[win[0], win[-1], win[:, 0], win[:, -1]])
    w = np.abs(win - edge)
    yy, xx = np.mgrid[yi - half:yi + half + 1, xi - half:xi + half + 1]
    return float((w * xx).sum() / w.sum()), float((w * yy).sum() / w.sum())


@pytest.fixture(scope="module")
def styles():
    """Every style a frame offers: Wild corner and midside marks, a 1 mm dot, a cross."""
    s = {n: MarkStyle("ring_x_dot", 4.0) for n in ("1", "2")}
    s |= {n: MarkStyle("ring_cross", 3.5) for n in ("5", "6")}
    s |= {"3": MarkStyle("dot", 1.0), "7": MarkStyle("dot", 1.0), "4": MarkStyle("cross", 3.0, 0.15),
          "8": MarkStyle("cross", 3.0, 0.15)}
    return s


@pytest.mark.parametrize("lie,border", [((0, False), "dark"), ((90, True), "bright"), ((270, False), "dark")])
def test_each_marks_centroid_is_its_truth_on_a_clean_frame(styles, lie, border):
    spec = frame_spec(CAMERA, COARSE_MM, np.random.default_rng(7), rotation_deg=lie[0], mirrored=lie[1],
                      border=border, styles=styles)
    img = render_frame(spec)
    truth = frame_truth(spec)
    assert img.shape == spec.size_px and img.dtype == np.uint8
    for name, (x, y) in truth.marks.items():
        half = int(styles[name].size_mm / 2 / COARSE_MM) + 6
        cx, cy = _centroid(img, x, y, half)
        assert np.hypot(cx - x, cy - y) < 0.05, (name, cx - x, cy - y)


def test_the_affine_maps_the_truth_to_the_cameras_mm():
    for seed in range(5):
        rng = np.random.default_rng(seed)
        rot, mir = ARRANGEMENTS[seed % 8]
        truth = frame_truth(frame_spec(CAMERA, 0.021, rng, rotation_deg=rot, mirrored=mir))
        px = np.array([truth.marks[n] for n in CAMERA.names])
        mm = np.c_[px, np.ones(len(px))] @ truth.px_to_mm.T
        assert np.abs(mm - CAMERA.xy_mm).max() < 1e-9
        back = FrameTruth.from_dict(truth.to_dict())
        assert back == truth and np.array_equal(back.px_to_mm, truth.px_to_mm)


@pytest.mark.parametrize("rot,mir", ARRANGEMENTS)
def test_every_lie_turns_the_frame_as_arrangement_matrix_says(rot, mir):
    spec = frame_spec(CAMERA, 0.4, np.random.default_rng(3), rotation_deg=rot, mirrored=mir)
    truth = frame_truth(spec)
    G = arrangement_matrix(rot, mir, CAMERA.y_axis)
    # pixel -> mm linear part is s * G up to the film's small tilt (<= 0.5 degrees)
    assert np.abs(truth.px_to_mm[:, :2] / spec.pixel_size_mm - G).max() < np.sin(np.radians(0.5)) + 1e-12
    # the rendered data strip lies where the truth puts film x = -116 mm, not on the opposite side
    img = render_frame(spec).astype(float)
    x0, x1, y0, y1 = STRIP_MM
    strip = [spec.mm_to_px(np.array([[(x0 + x1) / 2, y]]))[0] for y in np.linspace(y0 + 5, y1 - 5, 30)]
    other = [spec.mm_to_px(np.array([[-(x0 + x1) / 2, y]]))[0] for y in np.linspace(y0 + 5, y1 - 5, 30)]
    grey = [np.mean([img[int(round(y)), int(round(x))] for x, y in p]) for p in (strip, other)]
    assert grey[0] > 60 and grey[1] < 30, grey


@pytest.mark.parametrize("rot,mir", ARRANGEMENTS)
def test_the_test_cameras_asymmetries_tell_the_lie_from_the_marks(rot, mir):
    rng = np.random.default_rng(rot + mir)
    truth = frame_truth(frame_spec(CAMERA, 0.021, rng, rotation_deg=rot, mirrored=mir))
    px = np.array(list(truth.marks.values())) + rng.normal(0, 0.1, (8, 2))
    order = rng.permutation(8)
    c = match_fiducials(px[order], CAMERA.xy_mm)
    assert c.status == "unique" and (c.best.rotation_deg, c.best.mirrored) == (rot, mir)
    assert list(c.assignment) == list(order)


@pytest.mark.parametrize("kind", ["tiled", "striped", "jpeg"])
def test_the_writers_give_back_the_rendered_frame(tmp_path, kind):
    spec = frame_spec(CAMERA, 0.1, np.random.default_rng(2), rotation_deg=180, mirrored=True,
                      degradation="noisy")
    path = tmp_path / ("frame.jpg" if kind == "jpeg" else "frame.tif")
    truth = write_frame(spec, path, kind)
    assert truth == frame_truth(spec)
    assert [p.name for p in tmp_path.iterdir()] == [path.name]          # no temporary file left
    expected = render_frame(spec)
    with open_raster(path) as r:
        got = np.asarray(r.read_window((0, 0, spec.size_px[1], spec.size_px[0]))).reshape(expected.shape)
    if kind == "jpeg":
        assert np.abs(got.astype(float) - expected).mean() < 3.0
        return
    assert np.array_equal(got, expected)
    with tifffile.TiffFile(path) as tif:
        page = tif.pages[0]
        assert page.is_tiled == (kind == "tiled")
        if kind == "tiled":
            assert (page.tilelength, page.tilewidth) == (TILE, TILE)
        num, den = page.tags["XResolution"].value
        assert 25.4 / (num / den) == pytest.approx(spec.pixel_size_mm, rel=1e-6)


def test_degradations_fade_add_noise_and_blocks():
    base = frame_spec(CAMERA, 0.1, np.random.default_rng(4))
    frames = {d: render_frame(type(base)(**{**base.__dict__, "degradation": d}))
              for d in ("clean", "noisy", "faded", "jpeg")}
    spread = {d: np.percentile(f, 99) - np.percentile(f, 1) for d, f in frames.items()}
    assert spread["faded"] < 0.3 * spread["clean"]
    # the film border is flat on the clean frame; noise shows as first differences there
    border = (slice(30, 80), slice(None))
    diff = {d: np.abs(np.diff(f[border].astype(float), axis=1)).mean() for d, f in frames.items()}
    assert diff["clean"] < 0.5 < diff["noisy"]
    # JPEG blocks: jumps across the 8 px block edges exceed those inside blocks
    rows = frames["jpeg"][1000:1500].astype(float)
    d = np.abs(np.diff(rows, axis=1)).mean(axis=0)
    assert d[7::8].mean() > 1.2 * np.delete(d, np.s_[7::8]).mean()


def test_bands_are_the_frame_whatever_their_height():
    spec = frame_spec(CAMERA, 0.2, np.random.default_rng(5))
    a = np.vstack(list(frame_bands(spec, 512)))
    b = np.vstack(list(frame_bands(spec, 64)))
    assert a.shape == b.shape == spec.size_px
    assert np.abs(a.astype(int) - b).max() <= 1
    assert with_lie(spec, 90, True).rotation_deg == 90
