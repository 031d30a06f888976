"""The ``hough`` method: Hunt, Ryan & Gifford (seed 001, PE&RS 1993; thesis 000).

- :mod:`.params`: :class:`HoughParams`, every parameter of the method (the seed's values as defaults);
- :mod:`.analysis`: one window - optimum threshold, Hough accumulator (:mod:`aerofid.detect.hough_lines`),
  theta projection (eq. 5), matched filter, decoding of the centre (eq. 2), the similarity metric;
- :mod:`.search`: the search over a box - spiral windows, two tiers, recursion;
- :mod:`.cross_fit`: the sub-pixel blurred-cross model fit (beyond the seed);
- :mod:`.detector`: verification of the candidates, :class:`HoughResult` and :func:`detect`.
"""

from aerofid.detect.hough.detector import HoughResult, detect
from aerofid.detect.hough.params import HoughParams

__all__ = ["HoughParams", "HoughResult", "detect"]
