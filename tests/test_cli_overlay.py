"""The pictures `aerofid locate --overlay/--plot` writes: captions legible on bright ground and wholly inside
the picture; one sheet shows every box and centre with its name."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from aerofid import render
from aerofid.locate import Location

LONG_REASON = ("no method found a mark: circles: too few edge pixels for circles; symmetry: the symmetry "
               "centre is at the limit of the search range; hough: no candidate: every window was homogeneous, "
               "too bright or lacked a pair of lines; "
               "a_single_word_far_longer_than_any_caption_line_could_ever_hold_without_breaking_it_inside_"
               "itself_somewhere_in_the_middle")


def location(found=True, x=1098.6, y=2000.8, window=None, reason="", box=(1000, 2000, 1100, 2100)):
    w = np.ones((box[3] - box[1], box[2] - box[0]), np.float32) if window is None else window
    nan = float("nan")
    return Location(status="found" if found else "not_found", x=x if found else nan, y=y if found else nan,
                    score=0.93, sigma=0.021 if found else nan, method="hough", mark="external",
                    polarity="bright", box=box, requested_box=tuple(float(v) for v in box), clipped=False,
                    reason=reason, window=w)


def decoded(png: bytes) -> np.ndarray:
    return cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)


def band_height(img: np.ndarray) -> int:
    """Rows of the caption band: above the first row of the (white) window."""
    return int(np.argmax(np.median(img.max(axis=2), axis=1) > 200))


@pytest.mark.parametrize("width", [60, 200, 480])
def test_wrapped_caption_lines_fit_and_lose_nothing(width):
    lines = render.wrap_caption(LONG_REASON, width)
    assert all(render.text_size(line, render.CAPTION_SCALE)[0] <= width for line in lines)
    assert "".join(lines).replace(" ", "") == LONG_REASON.replace(" ", "")


def test_caption_is_light_on_a_dark_band_inside_the_picture_on_bright_ground():
    img = decoded(render.overlay_png(location(found=False, reason=LONG_REASON), "P12"))
    top = band_height(img)
    band = img[:top].max(axis=2)
    assert top > 3 * render.text_size("Ag", render.CAPTION_SCALE)[1]  # wrapped onto several lines
    assert np.median(band) == 0 and (band > 200).sum() > 500         # light text on dark ground
    assert band[:, :2].max() == 0 and band[:, -2:].max() == 0 and band[-2:].max() == 0  # not cut by an edge
    assert np.median(img[top:]) == 255                                 # the window below stays white


@pytest.mark.parametrize("x,y", [(1098.6, 2000.8), (1000.2, 2099.4), (1050.0, 2050.0), (1099.4, 2099.4)])
def test_name_tag_is_whole_and_inside_the_picture_beside_a_centre_at_any_corner(x, y):
    name = "LONGNAME_P12"
    img = render.overlay_image(location(x=x, y=y), name)
    assert np.array_equal(decoded(render.overlay_png(location(x=x, y=y), name)), img)
    top = band_height(img)
    below = img[top:]
    dark = np.argwhere(below.max(axis=2) < 30)          # the tag's dark box on the white window
    (r0, c0), (r1, c1) = dark.min(axis=0), dark.max(axis=0)
    w, h, base = render.text_size(name, render.TAG_SCALE)
    assert (c1 - c0 + 1, r1 - r0 + 1) == (w + 2 * render.PAD, h + base + 2 * render.PAD)  # not clipped
    assert 0 <= c0 and c1 < below.shape[1] and 0 <= r0 and r1 < below.shape[0]
    assert (below[r0:r1 + 1, c0:c1 + 1].min(axis=2) > 200).sum() > 20  # light letters inside it


def test_one_sheet_shows_every_box_with_its_name():
    rng = np.random.default_rng(3)
    named = []
    for k in range(5):
        box = (100 * k, 50, 100 * k + 60 + 10 * k, 130)
        window = rng.uniform(0.2, 1.0, (box[3] - box[1], box[2] - box[0])).astype(np.float32)
        named.append((f"F{k + 1}", location(k != 3, box[0] + 30.3, 90.7, window, "nothing there", box)))
    sheet = decoded(render.overlay_sheet_png(named, min_side=200, gap=8))
    panels = [render.overlay_image(loc, name, 200) for name, loc in named]
    cell_h, cell_w = max(p.shape[0] for p in panels), max(p.shape[1] for p in panels)
    cols = math.ceil(math.sqrt(len(panels)))
    assert sheet.shape[:2] == (2 * cell_h + 3 * 8, cols * cell_w + (cols + 1) * 8)
    for k, p in enumerate(panels):
        top, left = 8 + (k // cols) * (cell_h + 8), 8 + (k % cols) * (cell_w + 8)
        assert np.array_equal(sheet[top:top + p.shape[0], left:left + p.shape[1]], p), named[k][0]


def test_diagnostic_title_stays_inside_the_figure():
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = render.diagnostic_figure(location(found=False, reason=LONG_REASON), "P12")
    canvas = fig.canvas
    assert isinstance(canvas, FigureCanvasAgg)
    canvas.draw()
    title = fig._suptitle
    assert title is not None and title.get_text().startswith("P12: not found")
    ext = title.get_window_extent(canvas.get_renderer())
    assert ext.x0 >= 0 and ext.y0 >= 0 and ext.x1 <= fig.bbox.x1 and ext.y1 <= fig.bbox.y1
