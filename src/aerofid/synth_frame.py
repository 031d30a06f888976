"""Synthetic scanned film frames with exact truth: any camera's fiducials, the film lying any of the 8 ways in
the scanner, written band by band (bounded memory) as a tiled TIFF, a striped TIFF or a JPEG.

The film is drawn in its own millimetres (the camera's fiducial frame, origin at the fiducial centre, y as the
camera's ``y_axis``), around the calibrated fiducials:

- the exposed image area (|x|, |y| <= :data:`IMAGE_HALF_MM`, corners cut at |x| + |y| <= :data:`IMAGE_CORNER_MM`),
  aerial texture (:func:`aerofid.synth.aerial_ground` sampled at film mm);
- the unexposed film around it up to :data:`FILM_HALF_MM`, dark (a positive) or bright (a negative), with a
  data strip (a bar code, :data:`STRIP_MM`) on one side that turns with the film's lie;
- the scanner's margin beyond the film;
- one mark per fiducial (:class:`MarkStyle`, sized in mm), rendered by area coverage
  (:func:`aerofid.synth.paint_shape`) at its exact pixel centre.

The film's lie in the scanner follows :func:`aerofid.orientation.correspondence.arrangement_matrix`: the pixel ->
mm transformation is ``mm = A @ px + b`` with ``A = s * G @ R(tilt)`` (``s`` the pixel size, ``G`` the lie's
signed permutation, ``R`` a small rotation of the film in the scanner). Pixels: x = column, y = row, the centre
of the top-left pixel is (0, 0).

Every fiducial used here is point-symmetric, so its exact centre is also its intensity centroid; blur, grain,
noise, fading and JPEG blocks do not move it.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import cv2
import numpy as np
import tifffile
from scipy import ndimage

from aerofid.orientation.camera import Camera, Fiducial
from aerofid.orientation.correspondence import arrangement_matrix
from aerofid.synth import Coverage, aerial_ground, cross_shape, disc, mark_shape, paint_shape, ring, union

IMAGE_HALF_MM = 107.0
"""Half the exposed image area: the midside marks of a 23 cm camera (about 110 mm) lie on the film border."""
IMAGE_CORNER_MM = 200.0
"""The exposed area's corners are cut at |x| + |y| = 200 mm, leaving the corner marks (about 106, 106 mm, i.e.
8.5 mm from the cut) on the film border, as on Wild frames."""
FILM_HALF_MM = 120.0
"""Half the film's extent (240 mm roll film); beyond it the scanner's margin."""
STRIP_MM = (-119.0, -113.5, -75.0, 75.0)
"""The data strip (x0, x1, y0, y1), film mm: a bar code on the left border, so the lie is visible."""
STRIP_BAR_MM = (0.4, 2.5)
"""Widths (mm) of the strip's bars and gaps."""
MARGIN_MM = 5.0
"""Scanner margin beyond the film on every side when the scan's size is derived from the film."""
OFFSET_MM = 3.0
"""Largest shift (mm) of the film's centre from the scan's centre, each axis."""
TILT_DEG = 0.5
"""Largest rotation of the film in the scanner beyond its lie."""
TEXTURE_PX = 1024
"""Side of the aerial texture sampled over the image area (about 0.21 mm per texel)."""
BLUR_PX = 0.8
"""Gaussian blur of the scan (optics, film and scanner MTF), px."""
BAND_ROWS = 512
"""Rows rendered at once: one row of 512 px tiles (bounded memory: a band of an 11000 px wide frame holds
well under 100 MB of float32 per array)."""
ROWS_PER_STRIP = 64
"""Rows per strip of a striped TIFF."""
JPEG_QUALITY = 92
"""Quality of a frame written as JPEG (a good scan's file)."""
BLOCKY_QUALITY = 20
"""Quality of the JPEG round trip of the ``jpeg`` degradation: visible 8 x 8 blocks."""
SUPERSAMPLE = 16
"""Coverage samples per pixel side for the marks (256 samples in an N-rooks pattern): a Wild mark's coverage
centroid agrees with its centre to 0.007 px at 23 um and 40 um pixels (8 samples per side: 0.012 px)."""
MARK_ROWS = 16
"""Rows of a mark painted at once (its supersampled coordinates stay a few MB at any pixel size)."""
LEVELS = {"dark": (0.06, 0.92, 0.96), "bright": (0.88, 0.10, 0.03)}
"""Film border kind -> (border, mark, scanner margin) grey levels: marks of the opposite polarity."""
DEGRADATIONS = {
    # name: (grain sigma, white noise sigma, contrast range (lo, hi) or None, JPEG round trip)
    "clean": (0.0, 0.0, None, False),
    "noisy": (0.035, 0.03, None, False),
    "faded": (0.0, 0.008, (0.38, 0.58), False),
    "jpeg": (0.0, 0.01, None, True),
}
"""How a scan is degraded: film grain, sensor noise, a faded (low-contrast) print, JPEG blocks."""
KINDS = ("tiled", "striped", "jpeg")
"""File kinds :func:`write_frame` writes."""
TILE = 512
"""Tile side of a tiled TIFF."""


@dataclass(frozen=True)
class MarkStyle:
    """A fiducial mark in film mm: ``style`` (``ring_x_dot`` Wild corner, ``ring_cross`` Wild midside, ``dot``,
    ``cross``), overall ``size_mm`` and line width ``line_mm``."""

    style: str
    size_mm: float
    line_mm: float = 0.12

    def shape(self) -> Coverage:
        """The mark's shape in film mm, centred on the origin (point-symmetric)."""
        r, w = self.size_mm / 2.0, self.line_mm
        if self.style == "ring_x_dot":
            return union(ring(r - w, r), cross_shape(1.6 * r, w, 45.0), disc(1.5 * w))
        if self.style in ("ring_cross", "dot", "cross"):
            return mark_shape(self.style, self.size_mm, 0.0, w)
        raise ValueError(f"unknown mark style {self.style!r}; choose ring_x_dot, ring_cross, dot or cross")


WILD_CORNER = MarkStyle("ring_x_dot", 4.0)
WILD_MIDSIDE = MarkStyle("ring_cross", 3.5)


def wild_rc10_camera() -> Camera:
    """A Wild RC10-like 23 cm camera with 8 fiducials: corners 1-4 near (+-106, +-106) mm, midsides 5-8 near
    +-110 mm on the axes, each off its nominal place by a few hundredths of a mm as on a calibration
    certificate, so that the film's lie can be told from the marks alone."""
    xy = {"1": (-106.012, -105.991), "2": (105.996, -106.021), "3": (106.018, 106.004), "4": (-105.993, 106.015),
          "5": (-0.013, -110.027), "6": (110.009, 0.021), "7": (0.024, 110.012), "8": (-109.982, -0.008)}
    return Camera("Wild RC10 (synthetic)", tuple(Fiducial(k, x, y) for k, (x, y) in xy.items()),
                  focal_length_mm=153.0, ppa_mm=(0.004, -0.007))


def default_styles(camera: Camera) -> dict[str, MarkStyle]:
    """Wild marks: a ring with an X and a dot for fiducials off both axes, a ring with a '+' for the others."""
    return {f.name: WILD_CORNER if min(abs(f.x_mm), abs(f.y_mm)) > 10.0 else WILD_MIDSIDE
            for f in camera.fiducials}


@dataclass(frozen=True)
class FrameSpec:
    """Everything that defines one synthetic frame (:func:`frame_spec` draws the random parts)."""

    camera: Camera
    styles: Mapping[str, MarkStyle] = field(repr=False)
    pixel_size_mm: float
    size_px: tuple[int, int]                 # (height, width)
    rotation_deg: int = 0
    mirrored: bool = False
    tilt_deg: float = 0.0
    offset_mm: tuple[float, float] = (0.0, 0.0)
    border: str = "dark"
    degradation: str = "clean"
    seed: int = 0

    def __post_init__(self) -> None:
        if self.border not in LEVELS:
            raise ValueError(f"border must be one of {', '.join(LEVELS)}")
        if self.degradation not in DEGRADATIONS:
            raise ValueError(f"degradation must be one of {', '.join(DEGRADATIONS)}")
        if (self.rotation_deg, self.mirrored) not in [(r, m) for r in (0, 90, 180, 270) for m in (False, True)]:
            raise ValueError("rotation_deg must be 0, 90, 180 or 270")
        missing = set(self.camera.names) - set(self.styles)
        if missing:
            raise ValueError(f"no mark style for fiducial(s) {', '.join(sorted(missing))}")

    @property
    def px_to_mm(self) -> np.ndarray:
        """The exact pixel -> film mm affine transformation, 2 x 3: ``mm = A @ [x, y, 1]``."""
        t = math.radians(self.tilt_deg)
        R = np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])
        A = self.pixel_size_mm * arrangement_matrix(self.rotation_deg, self.mirrored, self.camera.y_axis) @ R
        h, w = self.size_px
        centre = np.array([(w - 1) / 2.0, (h - 1) / 2.0]) + np.linalg.solve(A, np.asarray(self.offset_mm, float))
        return np.c_[A, -A @ centre]

    def mm_to_px(self, xy_mm: np.ndarray) -> np.ndarray:
        """Film mm (n x 2) -> pixel centres (n x 2), the inverse of :attr:`px_to_mm`."""
        M = self.px_to_mm
        return (np.asarray(xy_mm, float).reshape(-1, 2) - M[:, 2]) @ np.linalg.inv(M[:, :2]).T


def frame_spec(camera: Camera, pixel_size_mm: float, rng: np.random.Generator, *, rotation_deg: int = 0,
               mirrored: bool = False, size_px: int | None = None, border: str = "dark",
               degradation: str = "clean", styles: Mapping[str, MarkStyle] | None = None) -> FrameSpec:
    """A frame with a random shift (up to :data:`OFFSET_MM`) and tilt (up to :data:`TILT_DEG`) of the film.

    The scan is square, ``size_px`` on a side or, by default, the film plus :data:`MARGIN_MM` on every side.

    Examples
    --------
    >>> spec = frame_spec(wild_rc10_camera(), 0.08, np.random.default_rng(1), rotation_deg=90)
    >>> spec.size_px, frame_truth(spec).lie
    ((3125, 3125), (90, False))
    """
    side = size_px if size_px is not None else math.ceil(2 * (FILM_HALF_MM + MARGIN_MM) / pixel_size_mm)
    return FrameSpec(camera, dict(styles) if styles is not None else default_styles(camera), pixel_size_mm,
                     (side, side), rotation_deg, mirrored, float(rng.uniform(-TILT_DEG, TILT_DEG)),
                     (float(rng.uniform(-OFFSET_MM, OFFSET_MM)), float(rng.uniform(-OFFSET_MM, OFFSET_MM))),
                     border, degradation, int(rng.integers(2 ** 31)))


@dataclass(frozen=True)
class FrameTruth:
    """The exact answer for a synthetic frame: every fiducial's pixel centre by name, the pixel -> mm affine
    transformation (2 x 3), the pixel size and the film's lie."""

    marks: Mapping[str, tuple[float, float]]
    px_to_mm: np.ndarray = field(repr=False, compare=False)
    pixel_size_mm: float
    rotation_deg: int
    mirrored: bool
    size_px: tuple[int, int]

    @property
    def lie(self) -> tuple[int, bool]:
        return self.rotation_deg, self.mirrored

    def to_dict(self) -> dict:
        return {"marks": {k: list(v) for k, v in self.marks.items()}, "px_to_mm": self.px_to_mm.tolist(),
                "pixel_size_mm": self.pixel_size_mm, "rotation_deg": self.rotation_deg, "mirrored": self.mirrored,
                "size_px": list(self.size_px)}

    @classmethod
    def from_dict(cls, d: Mapping) -> FrameTruth:
        return cls({k: (float(v[0]), float(v[1])) for k, v in d["marks"].items()}, np.array(d["px_to_mm"]),
                   float(d["pixel_size_mm"]), int(d["rotation_deg"]), bool(d["mirrored"]),
                   (int(d["size_px"][0]), int(d["size_px"][1])))


def frame_truth(spec: FrameSpec) -> FrameTruth:
    """The exact pixel centre of every fiducial of ``spec`` and the frame's geometry."""
    px = spec.mm_to_px(spec.camera.xy_mm)
    marks = {n: (float(x), float(y)) for n, (x, y) in zip(spec.camera.names, px, strict=True)}
    return FrameTruth(marks, spec.px_to_mm, spec.pixel_size_mm, spec.rotation_deg, spec.mirrored, spec.size_px)


# --- rendering ------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class _Film:
    """What every band of one frame shares: the aerial texture and the strip's bar edges (mm)."""

    texture: np.ndarray
    bar_edges: np.ndarray


def _film(spec: FrameSpec) -> _Film:
    rng = np.random.default_rng(spec.seed)
    texture = aerial_ground((TEXTURE_PX, TEXTURE_PX), rng)
    y0, y1 = STRIP_MM[2:]
    widths = rng.uniform(*STRIP_BAR_MM, size=int((y1 - y0) / STRIP_BAR_MM[0]) + 1)
    edges = y0 + np.cumsum(widths)
    return _Film(texture, edges[edges < y1])


def _film_mm(spec: FrameSpec, r0: int, r1: int) -> tuple[np.ndarray, np.ndarray]:
    """Film mm (x, y) of the pixel centres of rows r0:r1, all columns (float32)."""
    M = spec.px_to_mm.astype(np.float32)
    ys = np.arange(r0, r1, dtype=np.float32)[:, None]
    xs = np.arange(spec.size_px[1], dtype=np.float32)[None, :]
    return M[0, 0] * xs + (M[0, 1] * ys + M[0, 2]), M[1, 0] * xs + (M[1, 1] * ys + M[1, 2])


def _ground(spec: FrameSpec, film: _Film, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """The frame without marks at film mm (X, Y): margin, film border, data strip, aerial image area."""
    border, _, margin = LEVELS[spec.border]
    out = np.full(X.shape, margin, np.float32)
    on_film = (np.abs(X) <= FILM_HALF_MM) & (np.abs(Y) <= FILM_HALF_MM)
    out[on_film] = border
    ax, ay = np.abs(X), np.abs(Y)
    image = (ax <= IMAGE_HALF_MM) & (ay <= IMAGE_HALF_MM) & (ax + ay <= IMAGE_CORNER_MM)
    texel = 2 * IMAGE_HALF_MM / (TEXTURE_PX - 1)
    rows, cols = (IMAGE_HALF_MM - Y[image]) / texel, (X[image] + IMAGE_HALF_MM) / texel
    out[image] = ndimage.map_coordinates(film.texture, [rows, cols], order=1, mode="nearest")
    x0, x1, y0, y1 = STRIP_MM
    strip = (X >= x0) & (X <= x1) & (Y >= y0) & (Y <= y1)
    bar = np.searchsorted(film.bar_edges, Y[strip]) % 2 == 1
    out[strip] = np.where(bar, border, 1.0 - border)
    return out


def _pixel_shape(shape_mm: Coverage, A: np.ndarray) -> Coverage:
    """A film-mm shape as seen in pixels: pixel offsets (x, y) from the centre mapped by the linear part A."""
    a, b, c, d = (float(v) for v in A.ravel())
    return lambda x, y: shape_mm(a * x + b * y, c * x + d * y)


def _paint_marks(spec: FrameSpec, band: np.ndarray, r0: int, truth: FrameTruth) -> np.ndarray:
    """The marks that reach rows r0:r0+len(band) painted into the band at their exact centres."""
    _, level, _ = LEVELS[spec.border]
    A = spec.px_to_mm[:, :2]
    for name, (x, y) in truth.marks.items():
        style = spec.styles[name]
        extent = (style.size_mm / 2 + style.line_mm) / spec.pixel_size_mm + 2
        shape = _pixel_shape(style.shape(), A)
        lo, hi = max(0, int(math.floor(y - extent - r0))), min(band.shape[0], int(math.ceil(y + extent - r0)) + 1)
        for a in range(lo, hi, MARK_ROWS):
            band[a:a + MARK_ROWS] = paint_shape(band[a:a + MARK_ROWS], (x, y - r0 - a), shape, level, SUPERSAMPLE,
                                                extent)
    return band


def _degrade(spec: FrameSpec, band: np.ndarray, rng: np.random.Generator, pad: int) -> np.ndarray:
    """Grain, noise and fading (:data:`DEGRADATIONS`) of a band with ``pad`` extra rows above and below,
    returned without them."""
    grain, noise, faded, _ = DEGRADATIONS[spec.degradation]
    if grain > 0:
        g = ndimage.gaussian_filter(rng.normal(0.0, 1.0, band.shape).astype(np.float32), 1.2)
        band = band + grain * g / max(float(g.std()), 1e-12)
    band = band[pad:band.shape[0] - pad]
    if faded is not None:
        band = faded[0] + (faded[1] - faded[0]) * band
    if noise > 0:
        band = band + rng.normal(0.0, noise, band.shape).astype(np.float32)
    return band


def _jpeg_round_trip(band: np.ndarray, quality: int) -> np.ndarray:
    """The band encoded as a JPEG and decoded (grey: 8 x 8 blocks independent, so band by band is the same as
    the whole frame when bands start at multiples of 8 rows)."""
    ok, buf = cv2.imencode(".jpg", band, [cv2.IMWRITE_JPEG_QUALITY, quality])
    out = cv2.imdecode(buf, cv2.IMREAD_GRAYSCALE) if ok else None
    if out is None:
        raise RuntimeError("OpenCV could not encode and decode a JPEG")
    return np.asarray(out)


def frame_bands(spec: FrameSpec, rows: int = BAND_ROWS) -> Iterator[np.ndarray]:
    """The frame as uint8 bands of ``rows`` rows (the last may be shorter), top to bottom.

    Each band is rendered with a margin of rows for the blur and the grain, so the frame is the same whatever
    ``rows`` is, except for the random noise.
    """
    if rows % 8:
        raise ValueError("rows must be a multiple of 8 (JPEG blocks)")
    film, truth = _film(spec), frame_truth(spec)
    pad = int(math.ceil(4 * BLUR_PX)) + 4
    h = spec.size_px[0]
    for r0 in range(0, h, rows):
        r1 = min(h, r0 + rows)
        a0, a1 = max(0, r0 - pad), min(h, r1 + pad)
        X, Y = _film_mm(spec, a0, a1)
        band = _paint_marks(spec, _ground(spec, film, X, Y), a0, truth)
        del X, Y
        band = ndimage.gaussian_filter(band, BLUR_PX, mode="nearest")
        band = np.pad(band, ((pad - (r0 - a0), pad - (a1 - r1)), (0, 0)), mode="edge")
        out = np.clip(np.rint(_degrade(spec, band, np.random.default_rng([spec.seed, r0]), pad) * 255), 0, 255)
        out = out.astype(np.uint8)
        yield _jpeg_round_trip(out, BLOCKY_QUALITY) if DEGRADATIONS[spec.degradation][3] else out


def render_frame(spec: FrameSpec) -> np.ndarray:
    """The whole frame as one uint8 array (small frames: tests, demos)."""
    return np.vstack(list(frame_bands(spec)))


# --- writing --------------------------------------------------------------------------------------------

def write_frame(spec: FrameSpec, path: str | os.PathLike[str], kind: str = "tiled") -> FrameTruth:
    """Write the frame to ``path`` band by band and return its truth.

    ``kind``: ``tiled`` (TIFF, :data:`TILE` px tiles), ``striped`` (TIFF, :data:`ROWS_PER_STRIP` rows per strip),
    both uncompressed with the pixel size as resolution tags, or ``jpeg`` (:data:`JPEG_QUALITY`; the one kind
    that holds the whole frame in memory, as uint8, because a JPEG is encoded at once). The file is written
    beside ``path`` and renamed into place.
    """
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {', '.join(KINDS)}")
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        if kind == "jpeg":
            if not cv2.imwrite(str(tmp) + ".jpg", render_frame(spec), [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY]):
                raise OSError(f"OpenCV could not write {path}")
            os.replace(str(tmp) + ".jpg", tmp)
        else:
            _write_tiff(spec, tmp, kind)
        os.replace(tmp, path)
    finally:
        for p in (tmp, Path(str(tmp) + ".jpg")):
            p.unlink(missing_ok=True)
    return frame_truth(spec)


def _write_tiff(spec: FrameSpec, path: Path, kind: str) -> None:
    h, w = spec.size_px
    dpi = 25.4 / spec.pixel_size_mm
    tiled = kind == "tiled"
    tifffile.imwrite(path, _tiles(spec) if tiled else _rows(spec), shape=(h, w), dtype=np.uint8,
                     photometric="minisblack", resolution=(dpi, dpi), resolutionunit="INCH",
                     bigtiff=h * w > 2 ** 31, tile=(TILE, TILE) if tiled else None,
                     rowsperstrip=None if tiled else ROWS_PER_STRIP)


def _tiles(spec: FrameSpec) -> Iterator[np.ndarray]:
    for band in frame_bands(spec, TILE):
        for c0 in range(0, spec.size_px[1], TILE):
            yield band[:, c0:c0 + TILE]


def _rows(spec: FrameSpec) -> Iterator[np.ndarray]:
    for band in frame_bands(spec):
        yield from band


def with_lie(spec: FrameSpec, rotation_deg: int, mirrored: bool) -> FrameSpec:
    """The same frame with the film lying another way in the scanner."""
    return replace(spec, rotation_deg=rotation_deg, mirrored=mirrored)


ASKEW_TURN_DEG = 10.0
"""The largest turn of a film laid askew in :func:`random_frame` (either way; :func:`frame_spec`'s at most
:data:`TILT_DEG`)."""


def random_frame(camera: Camera, seed: int) -> tuple[FrameSpec, bool]:
    """The frame drawn from ``seed`` (``benchmarks/bench_sweep.py``): at a pixel size of 70-100 um, lying in one of the
    8 ways, one of the :data:`DEGRADATIONS`, the film turned up to :data:`ASKEW_TURN_DEG` either way; and whether its
    pixel size is given to the search (half the time).

    >>> spec, given = random_frame(wild_rc10_camera(), 1010)
    >>> spec.degradation, spec.size_px, frame_truth(spec).lie, given
    ('faded', (2564, 2564), (180, False), False)
    """
    rng = np.random.default_rng(seed)
    rotation, mirrored = int(rng.choice([0, 90, 180, 270])), bool(rng.integers(2))
    degradation = str(rng.choice(list(DEGRADATIONS)))
    spec = frame_spec(camera, float(rng.uniform(0.07, 0.1)), rng, rotation_deg=rotation, mirrored=mirrored,
                      degradation=degradation)
    spec = replace(spec, tilt_deg=float(rng.uniform(-ASKEW_TURN_DEG, ASKEW_TURN_DEG)))
    return spec, bool(rng.integers(2))


__all__ = ["ASKEW_TURN_DEG", "BLUR_PX", "DEGRADATIONS", "FrameSpec", "FrameTruth", "KINDS", "MarkStyle", "WILD_CORNER",
           "WILD_MIDSIDE", "default_styles", "frame_bands", "frame_spec", "frame_truth", "random_frame",
           "render_frame", "wild_rc10_camera", "with_lie", "write_frame"]
