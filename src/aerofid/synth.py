"""Synthetic scans with exact truth, for tests, benchmarks and the demo.

Marks are rendered by area coverage: each pixel is sampled on a ``supersample x supersample`` grid and the
fraction of samples inside the mark is its coverage, so a mark centred at any sub-pixel position has that
position as its exact centre (to about 1/supersample**2 of a pixel). Pixel convention as everywhere in
aerofid: x = column, y = row, the centre of the top-left pixel is (0, 0), pixel (row i, column j) covers
[j - 0.5, j + 0.5] x [i - 0.5, i + 0.5].

Mark styles (``MARK_STYLES``), each a union of primitives (bars, discs, rings):

- ``cross``: external fiducial '+' (Hunt, Ryan & Gifford: 40 px, 2 px wide, bright on a black border);
- ``panel``: cloth ground panel '+' (about 8 px across, low contrast, on aerial ground);
- ``ring_x_dot``: Wild corner mark, a ring with a diagonal X and a centre dot;
- ``ring_cross``: Wild midside mark, a ring with an upright '+';
- ``dot``: a plain dot; ``bullseye``: concentric rings around a dot;
- ``notch_dot``: Zeiss RMK style, a small bright dot inside a dark notch cut into a bright frame edge.

All functions are pure: they take a ``numpy.random.Generator`` where randomness is needed.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

Coverage = Callable[[np.ndarray, np.ndarray], np.ndarray]
"""A shape: maps sample coordinates (x, y), relative to the mark centre, to a boolean 'inside' array."""

MARK_STYLES = ("cross", "panel", "ring_x_dot", "ring_cross", "dot", "bullseye", "notch_dot")


# --- primitives -----------------------------------------------------------------------------------------

def bar(length: float, width: float, angle_deg: float) -> Coverage:
    """A rectangle of ``length`` x ``width`` centred on the origin, its long axis at ``angle_deg``
    (counter-clockwise from +x in the image's x-right, y-down frame, i.e. clockwise on screen)."""
    t = np.deg2rad(angle_deg)
    c, s = np.cos(t), np.sin(t)

    def inside(x, y):
        u = x * c + y * s
        v = -x * s + y * c
        return (np.abs(u) <= length / 2) & (np.abs(v) <= width / 2)

    return inside


def disc(radius: float) -> Coverage:
    return lambda x, y: x * x + y * y <= radius * radius


def ring(r_inner: float, r_outer: float) -> Coverage:
    def inside(x, y):
        r2 = x * x + y * y
        return (r2 >= r_inner * r_inner) & (r2 <= r_outer * r_outer)

    return inside


def union(*shapes: Coverage) -> Coverage:
    def inside(x, y):
        out = shapes[0](x, y)
        for s in shapes[1:]:
            out = out | s(x, y)
        return out

    return inside


def cross_shape(size: float, width: float, angle_deg: float = 0.0) -> Coverage:
    """A '+' of two orthogonal bars ``size`` long and ``width`` wide, intersecting at their midpoints."""
    return union(bar(size, width, angle_deg), bar(size, width, angle_deg + 90.0))


def mark_shape(style: str, size: float, angle_deg: float = 0.0, width: float | None = None) -> Coverage:
    """The shape of a mark style (see module docstring) whose overall extent is about ``size`` px."""
    w = width if width is not None else max(1.0, size / 20.0)
    r = size / 2.0
    if style in ("cross", "panel"):
        return cross_shape(size, w, angle_deg)
    if style == "ring_x_dot":
        return union(ring(r - w, r), cross_shape(1.6 * r, w, angle_deg + 45.0), disc(max(1.2, 1.5 * w)))
    if style == "ring_cross":
        return union(ring(r - w, r), cross_shape(1.6 * r, w, angle_deg))
    if style == "dot":
        return disc(r)
    if style == "bullseye":
        return union(disc(0.25 * r), ring(0.5 * r, 0.5 * r + w), ring(r - w, r))
    if style == "notch_dot":
        return disc(max(1.0, 0.15 * r))
    raise ValueError(f"unknown mark style {style!r}; choose one of {', '.join(MARK_STYLES)}")


# --- rendering ------------------------------------------------------------------------------------------

def _sample_offsets(supersample: int) -> tuple[np.ndarray, np.ndarray]:
    """``supersample**2`` sample offsets within a pixel, an N-rooks pattern: every sample has its own column
    and its own row (x_k = (k + 1/2)/N, y_k = (k p mod N + 1/2)/N with p coprime to N), so an edge parallel
    to an axis is resolved to 1/N px instead of 1/supersample px (a regular grid would bias the centre of an
    axis-aligned mark by up to 1/(2 supersample) px)."""
    n = supersample * supersample
    p = max(1, int(round(n * 0.618)))
    while np.gcd(p, n) != 1:
        p += 1
    k = np.arange(n)
    return (k + 0.5) / n - 0.5, ((k * p) % n + 0.5) / n - 0.5


def coverage(shape_hw: tuple[int, int], centre: tuple[float, float], shape: Coverage,
             supersample: int = 16, extent: float | None = None) -> np.ndarray:
    """Fraction of each pixel covered by ``shape`` placed at ``centre`` = (x, y), as float32 in [0, 1],
    from ``supersample**2`` samples per pixel (:func:`_sample_offsets`).

    Only pixels within ``extent`` px of the centre are sampled (all pixels when ``extent`` is None).
    """
    out = np.zeros(shape_hw, np.float32)
    region, cov = _local_coverage(shape_hw, centre, shape, supersample, extent)
    out[region] = cov
    return out


def _local_coverage(shape_hw, centre, shape, supersample, extent):
    """(region slices, coverage of that region) for :func:`coverage`."""
    h, w = shape_hw
    cx, cy = centre
    if extent is None:
        r0, r1, c0, c1 = 0, h, 0, w
    else:
        r0, r1 = max(0, int(np.floor(cy - extent))), min(h, int(np.ceil(cy + extent)) + 1)
        c0, c1 = max(0, int(np.floor(cx - extent))), min(w, int(np.ceil(cx + extent)) + 1)
    region = (slice(r0, max(r0, r1)), slice(c0, max(c0, c1)))
    if r0 >= r1 or c0 >= c1:
        return region, np.zeros((max(0, r1 - r0), max(0, c1 - c0)), np.float32)
    ox, oy = _sample_offsets(supersample)
    ys = np.arange(r0, r1, dtype=np.float64)[:, None, None] + oy[None, None, :] - cy
    xs = np.arange(c0, c1, dtype=np.float64)[None, :, None] + ox[None, None, :] - cx
    ys, xs = np.broadcast_arrays(ys, xs)
    return region, shape(xs, ys).mean(axis=2).astype(np.float32)


BLUR_OVERSAMPLING = 8
""":func:`blurred_coverage` blurs a mark on a grid this many times finer than the pixels."""


def blurred_coverage(shape_hw: tuple[int, int], centre: tuple[float, float], shape: Coverage, blur_sigma: float,
                     extent: float, supersample: int = 4) -> np.ndarray:
    """The coverage of ``shape`` at ``centre`` blurred by a Gaussian of ``blur_sigma`` px before the pixels
    integrate it, as a scanner images a mark (its optics blur, its sensor's pixels integrate), within ``extent``
    px of the centre (plus the blur's reach): the shape's coverage on a grid :data:`BLUR_OVERSAMPLING` times finer
    (``supersample`` samples a side per fine pixel), blurred there and averaged over each pixel.

    :func:`coverage` followed by :func:`blur` blurs on the pixel grid instead, after the pixels integrated the
    shape: a bar's profile then depends on where it falls on the grid, and the cross fit of ``hough`` finds an
    upright '+' 0.02 px RMS (0.03 px at worst, at a blur of 0.7 px) from its truth, against 0.0005 px here
    (docs/hough.md). The benchmarks' scenes keep that rendering (their tables were made with it); the demo frame
    uses this one. A mark within its blur's reach of the image's edge loses the light its part beyond the edge
    would have blurred in.
    """
    k = BLUR_OVERSAMPLING
    reach = extent + 4.0 * blur_sigma + 1.0
    h, w = shape_hw
    cx, cy = centre
    r0, r1 = max(0, int(np.floor(cy - reach))), min(h, int(np.ceil(cy + reach)) + 1)
    c0, c1 = max(0, int(np.floor(cx - reach))), min(w, int(np.ceil(cx + reach)) + 1)
    out = np.zeros(shape_hw, np.float32)
    if r0 >= r1 or c0 >= c1:
        return out
    # fine pixel (i, j) covers [(j - 0.5) / k, (j + 0.5) / k] - 0.5 + c0 in pixels: the centre in fine pixels
    fine_centre = ((cx - c0 + 0.5) * k - 0.5, (cy - r0 + 0.5) * k - 0.5)
    fine = coverage(((r1 - r0) * k, (c1 - c0) * k), fine_centre, lambda x, y: shape(x / k, y / k), supersample)
    fine = ndimage.gaussian_filter(fine.astype(np.float64), blur_sigma * k, mode="constant")
    out[r0:r1, c0:c1] = fine.reshape(r1 - r0, k, c1 - c0, k).mean(axis=(1, 3))
    return out


def paint_shape(image: np.ndarray, centre: tuple[float, float], shape: Coverage, level: float,
                supersample: int = 16, extent: float | None = None) -> np.ndarray:
    """Paint ``shape`` at ``centre`` with grey ``level`` into a copy of ``image``, touching only the pixels
    within ``extent`` px of the centre."""
    region, cov = _local_coverage(image.shape, centre, shape, supersample, extent)
    out = image.astype(np.float32, copy=True)
    out[region] = out[region] * (1.0 - cov) + level * cov
    return out


def paint(image: np.ndarray, cov: np.ndarray, level: float) -> np.ndarray:
    """Blend ``level`` into ``image`` by coverage: ``image * (1 - cov) + level * cov``."""
    return (image * (1.0 - cov) + level * cov).astype(np.float32)


def blur(image: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian blur (optics, film and scanner MTF) with standard deviation ``sigma`` px."""
    if sigma <= 0:
        return image.astype(np.float32)
    return ndimage.gaussian_filter(image.astype(np.float32), sigma, mode="nearest")


def add_gaussian_noise(image: np.ndarray, sigma: float, rng: np.random.Generator) -> np.ndarray:
    return (image + rng.normal(0.0, sigma, image.shape)).astype(np.float32)


def add_grain(image: np.ndarray, sigma: float, rng: np.random.Generator, grain_px: float = 1.2) -> np.ndarray:
    """Film grain: spatially correlated noise (white noise smoothed over ``grain_px``), std ``sigma``."""
    g = ndimage.gaussian_filter(rng.normal(0.0, 1.0, image.shape), grain_px)
    g /= g.std() + 1e-12
    return (image + sigma * g).astype(np.float32)


def add_impulse_noise(image: np.ndarray, fraction: float, rng: np.random.Generator,
                      amplitude: float = 200.0 / 255.0) -> np.ndarray:
    """Thesis section 5.8 noise: add +/- ``amplitude`` (uniform) to ``fraction`` of the pixels, then rescale
    the grey levels to [0, 1] ("adding +,- 200 to 10 % of the image pixels and scaling between 0 and 255")."""
    out = image.astype(np.float64).copy()
    hit = rng.random(image.shape) < fraction
    out[hit] += rng.uniform(-amplitude, amplitude, int(hit.sum()))
    lo, hi = out.min(), out.max()
    return ((out - lo) / (hi - lo if hi > lo else 1.0)).astype(np.float32)


def to_uint8(image: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(image * 255.0), 0, 255).astype(np.uint8)


# --- backgrounds ----------------------------------------------------------------------------------------

def film_border(shape_hw: tuple[int, int], rng: np.random.Generator, level: float = 0.06,
                gradient: float = 0.03) -> np.ndarray:
    """The dark, nearly homogeneous film border around the image area, with a gentle density gradient."""
    h, w = shape_hw
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    a = rng.uniform(0, 2 * np.pi)
    ramp = (np.cos(a) * xx / max(w, 1) + np.sin(a) * yy / max(h, 1))
    return (level + gradient * ramp).astype(np.float32)


def fractal_noise(shape_hw: tuple[int, int], rng: np.random.Generator, beta: float = 2.0) -> np.ndarray:
    """Zero-mean, unit-std noise with a 1/f**beta power spectrum (natural-image-like texture)."""
    h, w = shape_hw
    fy = np.fft.fftfreq(h)[:, None]
    fx = np.fft.rfftfreq(w)[None, :]
    f = np.sqrt(fx * fx + fy * fy)
    f[0, 0] = 1.0
    spec = (rng.normal(size=f.shape) + 1j * rng.normal(size=f.shape)) / f ** (beta / 2)
    spec[0, 0] = 0
    n = np.fft.irfft2(spec, s=(h, w))
    return ((n - n.mean()) / (n.std() + 1e-12)).astype(np.float32)


def aerial_ground(shape_hw: tuple[int, int], rng: np.random.Generator, density: float = 1.0) -> np.ndarray:
    """A suburban aerial scene: fractal ground, roads, houses with bright and dark roofs, dark trees.

    ``density`` scales the number of houses and trees per area. Values in about [0.1, 0.9].
    """
    h, w = shape_hw
    img = 0.42 + 0.07 * fractal_noise(shape_hw, rng, 2.2)
    area = h * w / 10000.0
    # roads: long bright bars
    for _ in range(rng.poisson(0.15 * area * density) + 1):
        cx, cy = rng.uniform(0, w), rng.uniform(0, h)
        ang = rng.choice([0.0, 90.0]) + rng.normal(0, 8)
        length = rng.uniform(0.5, 1.5) * max(h, w)
        img = paint_shape(img, (cx, cy), bar(length, rng.uniform(5, 9), ang), rng.uniform(0.55, 0.68), 2,
                          extent=length / 2 + 10)
    # houses: rectangles, some bright roofs with a darker ridge, some with small bright spots
    for _ in range(rng.poisson(2.0 * area * density)):
        cx, cy = rng.uniform(0, w), rng.uniform(0, h)
        L, W = rng.uniform(10, 24), rng.uniform(7, 14)
        ang = rng.normal(0, 20)
        img = paint_shape(img, (cx, cy), bar(L, W, ang), rng.uniform(0.25, 0.75), 2, extent=L)
        if rng.random() < 0.3:
            img = paint_shape(img, (cx + rng.normal(0, 2), cy + rng.normal(0, 2)),
                              bar(rng.uniform(2, 4), rng.uniform(2, 4), ang), rng.uniform(0.75, 0.9), 2, extent=6)
    # trees: dark soft blobs
    for _ in range(rng.poisson(3.0 * area * density)):
        cx, cy = rng.uniform(0, w), rng.uniform(0, h)
        img = paint_shape(img, (cx, cy), disc(rng.uniform(2, 6)), rng.uniform(0.12, 0.3), 2, extent=8)
    return np.clip(blur(img, 0.7), 0.0, 1.0)


# --- scenes with truth ----------------------------------------------------------------------------------

@dataclass(frozen=True)
class TruthMark:
    """A rendered mark: its exact centre (full-image px), style, size (px) and a generous box around it."""

    name: str
    x: float
    y: float
    style: str
    size: float
    box: tuple[int, int, int, int]

    def to_dict(self) -> dict:
        return {"name": self.name, "x": self.x, "y": self.y, "style": self.style, "size": self.size,
                "box": list(self.box)}


@dataclass(frozen=True)
class Scene:
    """A synthetic image (float32 in [0, 1]) and the marks rendered into it."""

    image: np.ndarray = field(repr=False)
    marks: tuple[TruthMark, ...]
    polarity: str = "bright"


def box_around(x: float, y: float, half: float, shape_hw: tuple[int, int] | None = None) -> tuple[int, int, int, int]:
    """The box (x0, y0, x1, y1), x1/y1 exclusive, of half-size ``half`` px around (x, y)."""
    b = (int(np.floor(x - half)), int(np.floor(y - half)), int(np.ceil(x + half)) + 1, int(np.ceil(y + half)) + 1)
    if shape_hw is not None:
        h, w = shape_hw
        b = (max(0, b[0]), max(0, b[1]), min(w, b[2]), min(h, b[3]))
    return b


def mark_scene(style: str = "cross", size: float = 40.0, width: float | None = None,
               window: int = 120, centre: tuple[float, float] | None = None, angle_deg: float = 0.0,
               rng: np.random.Generator | None = None, ground: str = "film", contrast: float = 0.8,
               blur_sigma: float = 0.7, noise_sigma: float = 0.02, grain_sigma: float = 0.0,
               polarity: str = "bright", supersample: int = 16) -> Scene:
    """One mark of ``style`` in a ``window`` x ``window`` image, at a random sub-pixel centre near the middle
    (or ``centre``), on ``ground`` = "film" (dark film border) or "aerial" (aerial-like texture).

    ``contrast`` is the mark's grey level above the ground's mean. ``polarity="dark"`` renders a dark mark on
    bright ground (the negative of the bright rendering).
    """
    rng = rng if rng is not None else np.random.default_rng()
    hw = (window, window)
    if centre is None:
        centre = (window / 2 + rng.uniform(-3, 3), window / 2 + rng.uniform(-3, 3))
    if ground == "film":
        img = film_border(hw, rng)
    elif ground == "aerial":
        img = aerial_ground(hw, rng)
    else:
        raise ValueError("ground must be 'film' or 'aerial'")
    base = float(np.median(img))
    if style == "notch_dot":
        img = _notch(img, centre, size, angle_deg, base + contrast, supersample)
    cov = coverage(hw, centre, mark_shape(style, size, angle_deg, width), supersample, extent=size)
    img = paint(img, cov, min(1.0, base + contrast))
    img = blur(img, blur_sigma)
    if grain_sigma > 0:
        img = add_grain(img, grain_sigma, rng)
    if noise_sigma > 0:
        img = add_gaussian_noise(img, noise_sigma, rng)
    img = np.clip(img, 0.0, 1.0)
    if polarity == "dark":
        img = 1.0 - img
    mark = TruthMark("M", float(centre[0]), float(centre[1]), style, float(size), (0, 0, window, window))
    return Scene(img.astype(np.float32), (mark,), polarity)


def _notch(img, centre, size, angle_deg, frame_level, supersample):
    """Zeiss RMK midside: a bright frame edge with a dark rectangular notch whose centre is the mark."""
    h, w = img.shape
    cx, cy = centre
    t = np.deg2rad(angle_deg)
    # bright frame band below the mark (in the mark's own frame), notch cut out around the centre
    frame = coverage((h, w), (cx + 0.6 * size * -np.sin(t) * -1, cy + 0.6 * size * np.cos(t)),
                     bar(3 * size, 1.2 * size, angle_deg), supersample=4)
    img = paint(img, frame, min(1.0, frame_level * 0.8))
    notch = coverage((h, w), (cx, cy), bar(0.6 * size, 0.6 * size, angle_deg), supersample=4)
    return paint(img, notch, float(np.median(img)))


def panel_scene(rng: np.random.Generator, shape_hw: tuple[int, int] = (404, 404),
                centre: tuple[float, float] | None = None, size: float = 8.0, width: float | None = None,
                angle_deg: float | None = None, contrast: float = 0.25, blur_sigma: float = 0.6,
                noise_sigma: float = 0.015, ground: np.ndarray | None = None) -> Scene:
    """A thesis-like test scene (chapter 5, figure 5.6): a 404 x 404 suburban aerial photograph with one
    cloth panel of about 8 px at (200, 200) (or ``centre``) among houses, roads and trees.

    ``ground`` may be a real aerial texture (float32 in [0, 1]) to render the panel on instead.
    ``width`` (the strips' width) defaults to size / 6, at least 1.2 px: cloth strips are 5-10 times as
    long as they are wide.
    """
    width = width if width is not None else max(1.2, size / 6.0)
    if ground is None:
        ground = aerial_ground(shape_hw, rng)
    else:
        shape_hw = ground.shape
    if centre is None:
        centre = (shape_hw[1] / 2 - 2 + rng.uniform(-0.5, 0.5), shape_hw[0] / 2 - 2 + rng.uniform(-0.5, 0.5))
    if angle_deg is None:
        angle_deg = rng.uniform(0, 90)
    cx, cy = centre
    # clear a patch of lawn under the panel, as survey crews do
    lawn = coverage(shape_hw, centre, disc(size * 1.2), supersample=4, extent=2 * size)
    local = float(np.median(ground[max(0, int(cy) - 20):int(cy) + 20, max(0, int(cx) - 20):int(cx) + 20]))
    img = paint(ground, lawn, local)
    cov = coverage(shape_hw, centre, cross_shape(size, width, angle_deg), 16, extent=size)
    img = paint(img, cov, min(1.0, local + contrast))
    img = np.clip(add_gaussian_noise(blur(img, blur_sigma), noise_sigma, rng), 0, 1)
    half = size * 3
    mark = TruthMark("panel", float(cx), float(cy), "panel", size, box_around(cx, cy, half, shape_hw))
    return Scene(img.astype(np.float32), (mark,))


DEMO_BLUR = 0.7
"""The demo frame's blur (px): the ground's, on the pixel grid, and the marks', before the pixels
(:func:`blurred_coverage`)."""


def demo_frame(rng: np.random.Generator, size: int = 1600, mark_size: float = 40.0,
               border: int = 110) -> Scene:
    """A whole scanned frame: aerial image area, dark film border, four corner and four midside '+' fiducials
    at sub-pixel positions, two cloth panels in the image area.

    The frame is slightly rotated and sheared like a real scan, so the fiducials are not on a pixel grid. The
    marks are blurred before the pixels integrate them (:func:`blurred_coverage`), the ground on the pixel grid;
    film grain (0.012) over all.
    """
    hw = (size, size)
    img = film_border(hw, rng, level=0.05)
    inner = aerial_ground((size - 2 * border, size - 2 * border), rng, density=0.6)
    img[border:size - border, border:size - border] = inner
    img = blur(img, DEMO_BLUR)
    c = (size - 1) / 2.0
    rot = np.deg2rad(rng.uniform(-0.4, 0.4))
    off = c - border / 2.0
    nominal = {"P1": (-1, -1), "P2": (1, -1), "P3": (1, 1), "P4": (-1, 1),
               "P5": (0, -1), "P6": (1, 0), "P7": (0, 1), "P8": (-1, 0)}
    marks = []
    for name, (u, v) in nominal.items():
        dx, dy = u * off, v * off
        x = c + dx * np.cos(rot) - dy * np.sin(rot) + rng.uniform(-0.5, 0.5)
        y = c + dx * np.sin(rot) + dy * np.cos(rot) + rng.uniform(-0.5, 0.5)
        cov = blurred_coverage(hw, (x, y), cross_shape(mark_size, 2.0, np.rad2deg(rot)), DEMO_BLUR, mark_size / 2)
        img = paint(img, cov, 0.9)
        marks.append(TruthMark(name, float(x), float(y), "cross", mark_size, box_around(x, y, 60, hw)))
    for k in range(2):
        x = rng.uniform(border + 150, size - border - 150)
        y = rng.uniform(border + 150, size - border - 150)
        img = paint(img, blurred_coverage(hw, (x, y), disc(10), DEMO_BLUR, 10), 0.4)
        cross = cross_shape(9.0, 1.6, rng.uniform(0, 90))
        img = paint(img, blurred_coverage(hw, (x, y), cross, DEMO_BLUR, 5), 0.68)
        marks.append(TruthMark(f"GCP{k + 1}", float(x), float(y), "panel", 9.0, box_around(x, y, 30, hw)))
    img = add_grain(img, 0.012, rng)
    return Scene(np.clip(img, 0, 1).astype(np.float32), tuple(marks))
