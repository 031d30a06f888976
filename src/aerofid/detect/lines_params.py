"""The parameters of the ``lines`` method (Sohn et al., seed 004), apart from the method: ``auto`` routes a user's
parameters to every method (:func:`aerofid.detect.registry.route_params`), and a call that never runs ``lines``
(the RC20 marks' ``aerofid locate``) then does not pay for the import of :mod:`aerofid.detect.lines`."""

from __future__ import annotations

import math
from dataclasses import dataclass

from aerofid.detect.params import MethodParams, check, is_int, number_in


@dataclass(frozen=True)
class LinesParams(MethodParams):
    """Parameters of the ``lines`` method (Sohn et al., seed 004, section 4; the sub-pixel refinement and the
    checks beyond the seed).

    Examples
    --------
    >>> import numpy as np
    >>> from aerofid import synth
    >>> from aerofid.detect.lines import detect
    >>> scene = synth.mark_scene("cross", 30, width=2.0, window=56, rng=np.random.default_rng(3))
    >>> r = detect(scene.image, LinesParams())
    >>> r.found, bool(np.hypot(r.x - scene.marks[0].x, r.y - scene.marks[0].y) < 0.1), len(r.lines)
    (True, True, 2)
    >>> LinesParams(theta_step=0)
    Traceback (most recent call last):
    ...
    ValueError: theta_step must be in [0.1, 45] degrees, not 0
    """

    region: int = 8
    """Local region (px) of the bimodal threshold (seed 004 section 4: "the size of local region to estimate
    bimodal approximation was 8x8")."""
    theta_step: float = 0.5
    """Hough angle step in degrees over 0 <= theta < 180 (seed 004 eq. 5)."""
    rho_step: float = 1.0
    """Hough distance step in px (seed 004 eq. 4: 0 < rho < sqrt(M1^2 + M2^2), here signed)."""
    min_angle: float = 45.0
    """Smallest angle (degrees) between the two lines; the second peak is searched this far from the first.
    Fiducial crosses cross at 60-90 degrees; a band (the frame under a blurred Zeiss notch) is centrally
    symmetric about any point of its midline, and its edges with the notch's corners gave 36-degree crossings
    that passed every other check (5 of 20 strongly blurred notch marks, 13-16 px off)."""
    min_peak_ratio: float = 0.3
    """The second Hough peak must hold at least this fraction of the first one's votes."""
    band_margin: float = 2.0
    """Half-width of the fitting band beyond the bar's half-width (px): the blurred flanks of the bar."""
    min_arm: int = 3
    """Each line needs at least this many supported 1 px slices on each side of the intersection."""
    min_arm_ratio: float = 0.25
    """... and its shorter side at least this fraction of its longer side (a mark cut by the window edge, or two
    lines meeting in a 'T' or 'L', has one side missing)."""
    iterations: int = 12
    """Band / background / fit iterations of the sub-pixel refinement (at most; they stop when the centre moves
    less than ``converged``)."""
    converged: float = 1e-3
    """The refinement stops when an iteration moves the intersection less than this (px)."""
    taper: float = 1.0
    """Standard deviation of the Gaussian taper across the line, in bar half-widths (0: a plain centroid)."""
    offset_floor: float = 0.03
    """Model error (px) added in quadrature to each line's fitted offset: the grey-weighted centroid of a thin
    bar whose edges were integrated over the pixel area (and not blurred before sampling) is aliased by up to a
    few hundredths of a pixel (measured: 0.02-0.05 px RMS per axis on axis-aligned 1-3 px bars of
    aerofid.synth); the fit's scatter cannot see it when every slice has the same sub-pixel phase. Applied to
    every line: on tilted lines (where the phases average out) it makes sigma somewhat pessimistic, never
    optimistic."""
    min_contrast: float = 5.0
    """Each line's median slice weight must be this many times its noise standard deviation (a bar, not an
    edge)."""
    max_side_foreground: float = 0.4
    """A bar has ground beside it: at most this fraction of the strips beside a line's band may be foreground
    (the ring of a Wild mark crossing them takes a little)."""
    max_asymmetry: float = 0.1
    """Beyond the seed: the largest share of the structure within the longest arm's reach (+2 px, so that a
    blob's edge is inside) that may change under a half turn about the intersection
    (:func:`aerofid.detect.asymmetry.point_asymmetry`). A '+' is centrally symmetric about its crossing; chords
    through a dot or a bull's-eye cross off its centre (answers 1.5-4.5 px off in docs/benchmarks_marks.md
    before this check; at 0.2 a dot's chords still crossed 1-1.3 px off its centre): half the limit ``auto``
    applies to every answer, as for ``symmetry``'s own check."""

    def validate(self) -> None:
        """Refuse, in one line, any value that would fail or exhaust memory later."""
        check(is_int(self.region) and 2 <= self.region <= 256, f"region must be an integer in [2, 256] px, "
              f"not {self.region!r}")
        check(number_in(self.theta_step, 0.1, 45.0),
              f"theta_step must be in [0.1, 45] degrees, not {self.theta_step!r}")
        check(number_in(self.rho_step, 0.25, 20.0), f"rho_step must be in [0.25, 20] px, not {self.rho_step!r}")
        check(number_in(self.min_angle, 0.0, 90.0, lo_open=True),
              f"min_angle must be in (0, 90] degrees, not {self.min_angle!r}")
        for name in ("min_peak_ratio", "min_arm_ratio", "max_side_foreground"):
            value = getattr(self, name)
            check(number_in(value, 0.0, 1.0), f"{name} must be a fraction in [0, 1], not {value!r}")
        for name in ("band_margin", "taper", "offset_floor", "min_contrast", "converged"):
            value = getattr(self, name)
            check(number_in(value, 0.0, 1e6), f"{name} must be a finite number >= 0, not {value!r}")
        check(is_int(self.min_arm) and self.min_arm >= 0, f"min_arm must be an integer >= 0, not {self.min_arm!r}")
        check(is_int(self.iterations) and 1 <= self.iterations <= 1000,
              f"iterations must be an integer in [1, 1000], not {self.iterations!r}")
        check(number_in(self.max_asymmetry, 0.0, math.inf) or self.max_asymmetry == math.inf,
              f"max_asymmetry must be a number >= 0, not {self.max_asymmetry!r}")


__all__ = ["LinesParams"]
