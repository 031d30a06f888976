"""Screening a region for mark candidates: where a centrally symmetric, compact mark may be, at which scale.

The seed methods locate one mark in a window a few times its size; a loose box or a whole frame is many
times larger and holds film border, notches, printed digits and the image itself. Screening is the cheap
first stage of a coarse-to-fine search (aerofid's, no seed has it; Cho & Kim's weak constraint, seed 002
section 2.1, that every mark is *symmetric about its centre*, is what it looks for): it costs a few
multiply-adds per pixel of a reduced image, and only its candidates go to the detectors.

On each level of an image pyramid (block means, factor 2 per level) and for each radius r of
:data:`RADII` (level pixels), with g the grey levels minus their local mean (a box of side 2 r_max + 1):

- the **point symmetry** of the disc of radius r about c, the normalised correlation of the disc with its
  half turn, ``S = sum_d g(c+d) g(c-d) / sum_d g(c+d)^2`` over the disc (1 for a centrally symmetric
  pattern, -1 for a step edge through c, about 0 for noise);
- its **isotropy** ``1 - (l1 - l2) / (l1 + l2)`` from the eigenvalues of the structure tensor summed over
  the disc (0 for a straight line or edge, which are symmetric about each of their points, about 1 for a
  '+', an X, a ring or a dot);
- its **contrast**: the RMS of g over the disc in units of the local noise (the robust first-difference
  noise of the plainest of the 3 x 3 blocks of :data:`BLOCK` level pixels around c), so that a mark on
  plain film border outranks texture of the same contrast in the image.

The strength of c at radius r is ``max(0, (1 + k) S - k) * isotropy * contrast`` (``k`` =
:data:`SYMMETRY_WEIGHT`: only nearly perfect symmetry counts); the candidates are its local maxima above
``min_strength``, strongest first, one per mark (maxima closer than the larger radius are one candidate, the
stronger kept). A candidate is a hint for the detectors, never an answer.
"""

from __future__ import annotations

import bisect
import functools
import heapq
import math
from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from aerofid.conventions import LEAST_GREY_STEP
from aerofid.parallel import THREADS, map_in_threads
from aerofid.robust import median

RADII = (3, 5, 7)
"""Disc radii (level pixels) screened on each pyramid level; level k covers radii 3 * 2^k .. 7 * 2^k of the
input."""
SYMMETRY_WEIGHT = 3.0
"""k in ``(1 + k) S - k``: a disc scores only when its symmetry S exceeds k / (1 + k) = 0.75."""
BLOCK = 16
"""Side (level pixels) of the blocks over which the local noise is estimated."""
MIN_STRENGTH = 5.0
"""Least strength of a candidate (a symmetric, isotropic disc whose RMS contrast is the local noise)."""
MEDIAN_MAX_DIFFERENCE = 1.0518 * np.sqrt(2.0)
"""Median of max(|dx|, |dy|) for white noise of unit sigma: each first difference has sigma sqrt(2), and the
median t of the larger of two half-normals solves (2 Phi(t) - 1)^2 = 1/2, t = 1.0518."""
MERGE_SHARE = 0.25
"""Two candidates closer than this share of the larger radius are one structure (module docstring)."""
ENERGY_ROWS = 256
"""Rows of a level that :func:`symmetric_energy` sums over every offset before the next (a band that stays in the
cache: 1.6 times faster on a 688 px level than whole levels, with the same sums; 256 rather than 128 since session
36: a whole frame's screen 0.92-0.95 of its time, half the calls where the other thread screens the coarser levels)."""
THREADED_PIXELS = 2**18
"""Least pixels of an image worked on by several threads (:data:`aerofid.parallel.THREADS`; a whole frame's, 688 x
688 px at 11000^2; starting them costs about a millisecond): its pyramid levels screened at once
(:func:`screen`), and its strength maps' parts (:func:`strength_maps`)."""
MIN_LEVEL_SIDE = 2 * RADII[-1] + 3
"""A pyramid level smaller than this on either side is not screened."""


@dataclass(frozen=True)
class Candidate:
    """Where a mark may be: centre (input pixels), the radius of the disc that scored, its strength."""

    x: float
    y: float
    radius: float
    strength: float
    inner: float = 0.0
    """The smallest radius of the structure screened here (a centre dot inside a ring); ``radius`` when
    only one scale scored (or when not given)."""

    def __post_init__(self) -> None:
        if not self.inner:
            object.__setattr__(self, "inner", self.radius)

    def to_dict(self) -> dict[str, float]:
        return {"x": round(self.x, 2), "y": round(self.y, 2), "radius": round(self.radius, 2),
                "inner": round(self.inner, 2), "strength": round(self.strength, 3)}


@functools.lru_cache(maxsize=16)
def half_disc_offsets(radius: int) -> np.ndarray:
    """The offsets (dx, dy) of a disc of ``radius`` px with one of each pair {d, -d} (d != 0), as an (n, 2)
    int array; with the centre excluded, each unordered pair of opposite pixels appears once (read-only, made once
    per radius)."""
    dy, dx = np.mgrid[0:radius + 1, -radius:radius + 1]
    keep = (dx * dx + dy * dy <= radius * radius) & ((dy > 0) | (dx > 0))
    return _read_only(np.stack([dx[keep], dy[keep]], axis=1))


@functools.lru_cache(maxsize=16)
def disc_kernel(radius: int, dtype: type = np.float32) -> np.ndarray:
    """A disc of ones of ``radius`` px (the pixels whose centres lie within it), float32 (or ``dtype``: uint8 for a
    structuring element); read-only, made once per radius and type."""
    dy, dx = np.mgrid[-radius:radius + 1, -radius:radius + 1]
    return _read_only((dx * dx + dy * dy <= radius * radius).astype(dtype))


def _read_only(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


DFT_CELLS = 130
"""OpenCV's ``filter2D`` convolves float32 images with a kernel of at least this many cells (rows x columns) by DFT."""


def disc_sums(img: np.ndarray, radius: int) -> np.ndarray:
    """The sum of each channel of ``img`` (float32, at most 4 channels) over the disc of ``radius`` px
    (:func:`disc_kernel`) about each pixel, zero outside. Summed directly: a disc whose square has
    :data:`DFT_CELLS` cells or more (radius 7) in two halves, the rows up to its centre and those below, each
    under that size (the DFT was the slower way on screening levels of 248 to 1400 px)."""
    kern = disc_kernel(radius)
    if kern.size < DFT_CELLS:
        return cv2.filter2D(img, -1, kern, borderType=cv2.BORDER_CONSTANT)
    upper, lower = kern[:radius + 1], kern[radius:].copy()
    lower[0] = 0
    assert max(upper.size, lower.size) < DFT_CELLS, radius
    out: np.ndarray = cv2.filter2D(img, -1, upper, anchor=(radius, radius), borderType=cv2.BORDER_CONSTANT)
    out += cv2.filter2D(img, -1, lower, anchor=(radius, 0), borderType=cv2.BORDER_CONSTANT)
    return out


def symmetric_energy(g: np.ndarray, radii: tuple[int, ...] = RADII, threads: int = 1) -> np.ndarray:
    """``sum_{d in disc(r)} g(c+d) g(c-d)`` for each r of ``radii`` (stacked on axis 0), zero-padded outside
    ``g``. The sum runs over the half disc and is doubled (each opposite pair appears twice in the full disc);
    the centre pixel's own term g(c)^2 is added. Bands of :data:`ENERGY_ROWS` rows are summed apart, by
    ``threads`` threads at once."""
    h, w = g.shape
    rmax = max(radii)
    pad = np.pad(g.astype(np.float32), rmax)
    rings = np.zeros((len(radii), h, w), np.float32)
    offsets = half_disc_offsets(rmax)
    ring_of = np.searchsorted(np.asarray(radii) ** 2, (offsets ** 2).sum(axis=1)).tolist()

    def band(r0: int) -> None:                # a band of rows, every offset: it stays in the cache
        r1 = min(r0 + ENERGY_ROWS, h)
        for (dx, dy), k in zip(offsets.tolist(), ring_of, strict=True):   # one pass per offset: rings += a * b
            cv2.accumulateProduct(pad[rmax + dy + r0:rmax + dy + r1, rmax + dx:rmax + dx + w],
                                  pad[rmax - dy + r0:rmax - dy + r1, rmax - dx:rmax - dx + w], rings[k, r0:r1])

    map_in_threads(band, range(0, h, ENERGY_ROWS), threads)
    for k in range(1, len(radii)):              # the discs' sums from their rings (np.cumsum along this short
        rings[k] += rings[k - 1]                # first axis: the same sums, 20 times slower)
    rings *= 2.0
    rings += g[None] * g[None]
    return rings


def local_noise(img: np.ndarray, block: int = BLOCK, floor: float = LEAST_GREY_STEP) -> np.ndarray:
    """Per pixel, the white-noise sigma of the plainest of the 3 x 3 blocks of ``block`` px around it: the
    median absolute first difference of each block (horizontal and vertical, scaled to a sigma), the minimum
    over the neighbouring blocks (a mark beside a strong edge is judged by its plain side), bilinearly
    interpolated. Floored at ``floor`` (one quantisation step: flat JPEG black has almost no noise, and its
    specks would outrank the mark). On white noise it reads 0.87-0.88 of the true sigma (5 seeds of 256 x 256
    px): the minimum over neighbouring blocks is biased low, which only scales every strength alike."""
    h, w = img.shape
    bh, bw = -(-h // block), -(-w // block)
    # max(|dx|, |dy|) of the first differences forward (0 on the last column and row: the edge value repeated),
    # on blocks of whole size (the edge values repeated)
    d = np.empty((bh * block, bw * block), img.dtype)
    dx, dy = d[:h, :w], np.empty_like(img)
    np.subtract(img[:, 1:], img[:, :-1], out=dx[:, :-1])
    np.subtract(img[:, -1:], img[:, -1:], out=dx[:, -1:])
    np.subtract(img[1:], img[:-1], out=dy[:-1])
    np.subtract(img[-1:], img[-1:], out=dy[-1:])
    np.maximum(np.abs(dx, out=dx), np.abs(dy, out=dy), out=dx)
    d[h:, :w] = dx[-1]
    d[:, w:] = d[:, w - 1:w]
    blocks = d.reshape(bh, block, bw, block).transpose(0, 2, 1, 3).reshape(bh, bw, -1)
    med = median(blocks, axis=2).astype(np.float32) / np.float32(MEDIAN_MAX_DIFFERENCE)
    sigma = cv2.erode(med, np.ones((3, 3), np.uint8), borderType=cv2.BORDER_REPLICATE)
    up = cv2.resize(sigma, (bw * block, bh * block), interpolation=cv2.INTER_LINEAR)[:h, :w]
    return np.maximum(up, np.float32(floor))


def strength_maps(img: np.ndarray, radii: tuple[int, ...] = RADII,
                  k: float = SYMMETRY_WEIGHT, noise_floor: float = LEAST_GREY_STEP,
                  threads: int | None = None) -> np.ndarray:
    """The screening strength (module docstring) of every pixel of ``img`` for each of ``radii`` (axis 0);
    zero where the disc is not wholly inside ``img``. Worked on by ``threads`` threads (the symmetric energy's
    bands, the radii, the largest first: its disc sums cost the most); default: :data:`~aerofid.parallel.THREADS` for
    an image of :data:`THREADED_PIXELS` or more, else one."""
    return _strength_maps(img, radii, k, noise_floor, threads)


def _strength_maps(img: np.ndarray, radii: tuple[int, ...], k: float, noise_floor: float, threads: int | None,
                   then: Callable[[int, np.ndarray], None] | None = None) -> np.ndarray:
    """:func:`strength_maps`, and ``then(i, map)`` run on each radius's map by the thread that made it."""
    img = img.astype(np.float32)
    threads = _threads(img.size, threads)
    rmax = max(radii)
    g = img - cv2.blur(img, (2 * rmax + 1, 2 * rmax + 1), borderType=cv2.BORDER_REFLECT)
    g = cv2.GaussianBlur(g, (0, 0), 0.7, borderType=cv2.BORDER_REFLECT)
    sym = symmetric_energy(g, radii, threads)
    gx = cv2.Sobel(g, cv2.CV_32F, 1, 0)
    gy = cv2.Sobel(g, cv2.CV_32F, 0, 1)
    noise = local_noise(img, floor=noise_floor)
    out = np.zeros_like(sym)
    squares = cv2.merge([g * g, gx * gx, gy * gy, gx * gy])

    def strength(i: int) -> None:
        r = radii[i]
        sums = disc_sums(squares, r)
        energy, jxx, jyy, jxy = (sums[:, :, c] for c in range(4))
        s = sym[i] / np.maximum(energy, 1e-12)
        iso = 1.0 - np.sqrt((jxx - jyy) ** 2 + 4 * jxy ** 2) / np.maximum(jxx + jyy, 1e-12)
        m = np.clip((1 + k) * s - k, 0, None) * iso * np.sqrt(energy) / noise
        m[:r], m[-r:], m[:, :r], m[:, -r:] = 0, 0, 0, 0
        out[i] = m
        if then is not None:
            then(i, out[i])

    map_in_threads(strength, sorted(range(len(radii)), key=lambda i: -radii[i]), threads)
    return out


def level_candidates(img: np.ndarray, scale: float, radii: tuple[int, ...] = RADII,
                     min_strength: float = MIN_STRENGTH, noise_floor: float = LEAST_GREY_STEP,
                     limit: int = 256, threads: int | None = None) -> Found:
    """The ``limit`` strongest local maxima of the strength of one pyramid level per radius, in input pixels
    (``scale`` input pixels per level pixel; a level pixel's centre i lies at input ``(i + 0.5) * scale - 0.5``);
    ``threads``: as :func:`strength_maps` (each finds the maxima of the maps it made)."""
    found: list[Found] = [Found.of([])] * len(radii)

    def maxima(i: int, m: np.ndarray) -> None:
        r = radii[i]
        peak = m == cv2.dilate(m, disc_kernel(r, np.uint8))
        ys, xs = np.nonzero(peak & (m >= min_strength))
        strength = m[ys, xs]
        order = np.argsort(-strength, kind="stable")[:limit]
        radius = np.full(len(order), r * scale)
        found[i] = Found((xs[order] + 0.5) * scale - 0.5, (ys[order] + 0.5) * scale - 0.5, radius,
                         strength[order].astype(float), radius)

    _strength_maps(img, radii, SYMMETRY_WEIGHT, noise_floor, threads, maxima)
    return Found.joined(found)


def reduce2(img: np.ndarray) -> np.ndarray:
    """The next pyramid level: means of 2 x 2 blocks (a last odd row or column is dropped)."""
    h, w = (img.shape[0] // 2) * 2, (img.shape[1] // 2) * 2
    a = img[:h, :w]
    return 0.25 * (a[0::2, 0::2] + a[1::2, 0::2] + a[0::2, 1::2] + a[1::2, 1::2])


def screen(img: np.ndarray, scale: float = 1.0, min_radius: float = 3.0, max_radius: float | None = None,
           max_candidates: int = 32, min_strength: float = MIN_STRENGTH,
           noise_floor: float = LEAST_GREY_STEP, threads: int | None = None) -> tuple[Candidate, ...]:
    """Candidates for mark centres in ``img`` (grey, either polarity), strongest first.

    Parameters
    ----------
    img : ndarray
        2-D grey levels, possibly already reduced from the full image by ``scale``.
    scale : float
        Full-image pixels per pixel of ``img``; candidates are returned in full-image pixels of ``img``'s
        region (``(i + 0.5) * scale - 0.5``) with radii in full-image pixels.
    min_radius, max_radius : float
        The radii (full-image px) of the marks sought; levels that cannot hold them are skipped.
    max_candidates : int
        At most this many candidates (the strongest).
    min_strength : float
        Least strength (module docstring).
    noise_floor : float
        Least local noise (grey levels of ``img``): one quantisation step of the scan's samples.
    threads : int, optional
        Threads that screen the levels at once and work on each (the same candidates whatever their number);
        default: :data:`~aerofid.parallel.THREADS` for an image of :data:`THREADED_PIXELS` or more, else one.

    Examples
    --------
    >>> from aerofid import synth
    >>> scene = synth.mark_scene("ring_cross", size=40, window=300, centre=(180.3, 110.6),
    ...                          rng=np.random.default_rng(1))
    >>> best = screen(scene.image)[0]
    >>> bool(abs(best.x - 180.3) < 3 and abs(best.y - 110.6) < 3)
    True
    """
    levels: list[tuple[np.ndarray, float]] = []
    level = np.asarray(img, np.float32)
    s = float(scale)
    while min(level.shape) >= MIN_LEVEL_SIDE:
        if max_radius is not None and RADII[0] * s > max_radius:
            break
        if RADII[-1] * s >= min_radius:
            levels.append((level, s))
        level = reduce2(level)
        s *= 2.0
    found = map_in_threads(lambda ls: level_candidates(ls[0], ls[1], RADII, min_strength, noise_floor,
                                                       4 * max_candidates, threads),
                           levels, _threads(levels[0][0].size if levels else 0, threads))
    return _merged(Found.joined(found), max_candidates)


def _threads(pixels: int, threads: int | None) -> int:
    """``threads``, or by default those an image of ``pixels`` is worked on by (:data:`THREADED_PIXELS`)."""
    if threads is not None:
        return threads
    return THREADS if pixels >= THREADED_PIXELS else 1


@dataclass(frozen=True, eq=False)
class Found:
    """Candidates as arrays (what :func:`level_candidates` finds, many thousands on a whole frame): centres, radii,
    strengths and inner radii, float64, in the fields' order of :class:`Candidate`."""

    x: np.ndarray
    y: np.ndarray
    radius: np.ndarray
    strength: np.ndarray
    inner: np.ndarray

    @classmethod
    def of(cls, candidates: list[Candidate]) -> Found:
        columns = np.array([(c.x, c.y, c.radius, c.strength, c.inner) for c in candidates], float).reshape(-1, 5)
        return cls(*columns.T)

    @classmethod
    def joined(cls, parts: list[Found]) -> Found:
        if not parts:
            return cls.of([])
        return cls(*(np.concatenate([getattr(p, f) for p in parts]) for f in ("x", "y", "radius", "strength",
                                                                              "inner")))


def merge_candidates(found: list[Candidate], max_candidates: int) -> tuple[Candidate, ...]:
    """One candidate per place, strongest first. A weaker candidate is the same structure seen at another scale
    when its centre lies within :data:`MERGE_SHARE` of the larger radius of a stronger one's (a ring and its
    centre dot) or within half the smaller radius (two scales of one blob; not a mark beside the centre of a
    pair of marks, which is itself symmetric): it is merged into the stronger one, which keeps the
    largest radius (the whole mark), the smallest (``inner``) and the position of the finest scale."""
    return _merged(Found.of(found), max_candidates)


def _merged(found: Found, max_candidates: int) -> tuple[Candidate, ...]:
    """:func:`merge_candidates` on arrays. The rule is sequential (a merge moves a kept one, and a kept one that was
    not there could take the next), but which candidates a kept one reaches is found once for all that follow it
    when it is kept, and again when a merge changes its reach (:class:`_Merge`): every candidate is visited until
    ``max_candidates`` are kept, then only those a kept one reaches (a few hundred of the thousands of a whole
    frame). The same decisions, with the same arithmetic (:func:`_reaches`: ``math.hypot``), as one candidate after
    another (0.75 of the time of session 32's reach tests in batches of candidates on a whole frame's,
    docs/benchmarks_frames.md; those took numpy's complex ``abs``, which differs from ``math.hypot`` in the last bit
    for about a third of pairs: at an exact tie with the reach their decision could differ, on no benchmark frame)."""
    ordered = np.argsort(-found.strength, kind="stable")
    merge = _Merge(*(getattr(found, f)[ordered] for f in ("x", "y", "radius", "inner")))
    c = 0
    while c < len(ordered) and len(merge.kept.of) < max_candidates:
        merge.visit(c, room=True)
        c += 1
    todo = sorted(j for j, by in merge.reached.items() if by and j >= c)    # a heap
    while todo:
        for j in merge.visit(heapq.heappop(todo), room=False):
            heapq.heappush(todo, j)
    kept, strength = merge.kept, found.strength[ordered]
    return tuple(Candidate(x, y, r, float(strength[c]), inner)
                 for x, y, r, inner, c in zip(kept.x, kept.y, kept.r, kept.inner, kept.of, strict=True))


class _Kept:
    """The kept candidates as :func:`_merged` runs: centres, largest and smallest radii, and which candidate each is
    (its strength)."""

    def __init__(self) -> None:
        self.x: list[float] = []
        self.y: list[float] = []
        self.r: list[float] = []
        self.inner: list[float] = []
        self.of: list[int] = []

    def merge(self, i: int, x: float, y: float, r: float, inner: float) -> bool:
        """A candidate merged into kept one ``i``: the finer scale's position, the largest radius and the smallest
        inner one; whether its reach changed (it moved or grew)."""
        moved, grew = r < self.inner[i], r > self.r[i]
        if moved:
            self.x[i], self.y[i] = x, y
        self.r[i], self.inner[i] = max(self.r[i], r), min(self.inner[i], inner)
        return moved or grew

    def add(self, c: int, x: float, y: float, r: float, inner: float) -> int:
        """Candidate ``c`` kept; its slot."""
        self.of.append(c)
        self.x.append(x)
        self.y.append(y)
        self.r.append(r)
        self.inner.append(inner)
        return len(self.of) - 1


class _Merge:
    """The state of :func:`_merged`: the candidates (strongest first), the kept ones, and which kept ones reach
    each candidate not yet visited (``reached``), and which candidates after it each kept one reaches
    (``reaches``)."""

    def __init__(self, xs: np.ndarray, ys: np.ndarray, radii: np.ndarray, inners: np.ndarray) -> None:
        self.cells = _Cells(xs, ys, radii)
        self.candidates = list(zip(self.cells.xs, self.cells.ys, radii.tolist(), inners.tolist(), strict=True))
        self.kept = _Kept()
        self.reached: dict[int, set[int]] = {}
        self.reaches: list[list[int]] = []

    def visit(self, c: int, room: bool) -> list[int]:
        """Candidate ``c`` merged into the first kept one that reaches it, else kept if there is ``room``; the
        candidates after it that a kept one now reaches and none did before."""
        by = self.reached.pop(c, None)
        args = self.candidates[c]
        if by:
            i = min(by)                                 # the first kept one within reach
            if not self.kept.merge(i, *args):           # its reach is as it was
                return []
            for j in self.reaches[i]:
                if j > c:
                    self.reached[j].discard(i)
        elif room:
            i = self.kept.add(c, *args)
            self.reaches.append([])
        else:
            return []
        self.reaches[i] = self.cells.near(self.kept, i, c)
        fresh = []
        for j in self.reaches[i]:
            by = self.reached.setdefault(j, set())
            if not by:
                fresh.append(j)
            by.add(i)
        return fresh


GROUP_SPAN = 4.0
"""Candidates whose radii lie within this factor of the smallest of theirs are one group of :class:`_Cells`."""
FEW_CANDIDATES = 48
"""Candidates at most that :class:`_Cells` tests one by one (a box's screen: the cells cost more than they save)."""
MAX_CELLS = 4096
"""Cells of a group of :class:`_Cells` along an axis at most (their side grows where the candidates spread further:
the cells' numbers stay small, a reach spans at most so many columns)."""


class _Cells:
    """Candidates (centres ``xs``, ``ys``, ``radii``) in groups of radii (:data:`GROUP_SPAN`), each group's in square
    cells of half its largest radius: a kept one's reach (:func:`_reaches`) grows with a candidate's radius, so only the
    cells that its reach of the group's largest radius touches hold the candidates of the group it may reach (those
    of a kept one no larger than the group's radii, in the 2 x 2 or 3 x 3 cells about it). A group's candidates are
    sorted by their cells' numbers, column by column, so that a column of cells is one run found by bisection."""

    def __init__(self, xs: np.ndarray, ys: np.ndarray, radii: np.ndarray) -> None:
        self.xs, self.ys = xs.tolist(), ys.tolist()
        self.a, self.h = (MERGE_SHARE * radii).tolist(), (0.5 * radii).tolist()
        self.groups: list[_CellGroup] = []
        # every candidate, tested one by one where they are few, or their radii not positive or not finite, or their
        # places not finite (as the rule says of them); None: by cells
        self.every: list[int] | None = list(range(len(self.xs)))
        if len(xs) <= FEW_CANDIDATES:
            return
        classes = np.sort(radii)
        classes = classes[np.concatenate(([True], classes[1:] != classes[:-1]))]   # np.unique's (no numpy.ma)
        while len(classes) and classes[0] > 0 and np.isfinite(classes[-1]):
            group = classes[classes <= GROUP_SPAN * classes[0]]
            classes = classes[len(group):]
            these = np.flatnonzero((radii >= group[0]) & (radii <= group[-1]))
            self.groups.append(_CellGroup.of_candidates(these, xs[these], ys[these], float(group[-1])))
        if len(classes) or not all(np.isfinite(g.side) for g in self.groups):
            self.groups = []
        else:
            self.every = None

    def near(self, kept: _Kept, i: int, after: int) -> list[int]:
        """The candidates after ``after`` within kept one ``i``'s reach."""
        x, y, share, half = kept.x[i], kept.y[i], MERGE_SHARE * kept.r[i], 0.5 * kept.r[i]
        xs, ys, a, h = self.xs, self.ys, self.a, self.h
        runs = [self.every] if self.every is not None else [g.within(x, y, g.reach(x, y, share, half))
                                                            for g in self.groups]
        return [j for run in runs for j in run
                if j > after and _reaches(x - xs[j], y - ys[j], share, half, a[j], h[j])]


@dataclass(frozen=True)
class _CellGroup:
    """One group of :class:`_Cells`: its largest radius, the cells' side (half of it, or more where the candidates
    spread over more than :data:`MAX_CELLS` cells along an axis), and its candidates sorted by their cells' numbers
    ``(column - first column) * rows + row - first row``."""

    largest: float
    side: float
    first: tuple[int, int]
    rows: int
    number: list[int]
    of: list[int]

    @classmethod
    def of_candidates(cls, these: np.ndarray, xs: np.ndarray, ys: np.ndarray, largest: float) -> _CellGroup:
        side = max(0.5 * largest, float(max(np.ptp(xs), np.ptp(ys))) / MAX_CELLS)
        if not (np.isfinite(side) and np.isfinite(xs).all() and np.isfinite(ys).all()):
            return cls(largest, np.inf, (0, 0), 1, [], [])
        col, row = np.floor(xs / side).astype(np.int64), np.floor(ys / side).astype(np.int64)
        c0, r0 = int(col.min()), int(row.min())
        rows = int(row.max()) - r0 + 1
        number = (col - c0) * rows + (row - r0)
        order = np.argsort(number, kind="stable")
        return cls(largest, side, (c0, r0), rows, number[order].tolist(), these[order].tolist())

    def reach(self, x: float, y: float, share: float, half: float) -> float:
        """The reach from (x, y) of a kept one (:data:`MERGE_SHARE` and half its radius ``share``, ``half``) to the
        group's largest radius, the most it reaches any candidate of the group (the reach grows with a candidate's
        radius), and a little more: :func:`_reaches` tests the cells' candidates exactly."""
        reach = max(share, MERGE_SHARE * self.largest, min(half, 0.5 * self.largest))
        return reach + 1e-9 * (reach + abs(x) + abs(y))

    def within(self, x: float, y: float, reach: float) -> list[int]:
        """The candidates in the cells that the square of half-side ``reach`` about (x, y) touches."""
        (c0, r0), rows = self.first, self.rows
        row_lo = max(math.floor((y - reach) / self.side) - r0, 0)
        row_hi = min(math.floor((y + reach) / self.side) - r0, rows - 1)
        if row_lo > row_hi:
            return []
        got: list[int] = []
        for col in range(max(math.floor((x - reach) / self.side) - c0, 0),
                         min(math.floor((x + reach) / self.side) - c0, self.number[-1] // rows) + 1):
            lo = bisect.bisect_left(self.number, col * rows + row_lo)
            got += self.of[lo:bisect.bisect_right(self.number, col * rows + row_hi, lo)]
        return got


def _reaches(dx: float, dy: float, share: float, half: float, a: float, h: float) -> bool:
    """Whether a candidate (:data:`MERGE_SHARE` and half its radius ``a``, ``h``) lies within reach of a kept one
    (``share``, ``half``) at (``dx``, ``dy``) from it: ``hypot(dx, dy) <= max(share, a, min(half, h))``, the larger
    radius's share or half the smaller."""
    return math.hypot(dx, dy) <= max(share, a, min(half, h))


__all__ = ["Candidate", "half_disc_offsets", "local_noise", "merge_candidates", "screen", "strength_maps"]
