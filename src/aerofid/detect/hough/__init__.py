"""The ``hough`` method: Hunt, Ryan & Gifford (seed 001, PE&RS 1993; thesis 000).

- :mod:`.analysis`: one window - optimum threshold, Hough accumulator, theta projection (eq. 5), matched
  filter, decoding of the centre (eq. 2), the similarity metric;
- :mod:`.search`: the search over a box - spiral windows, two tiers, recursion;
- :mod:`.cross_fit`: the sub-pixel blurred-cross model fit (beyond the seed);
- :mod:`.detector`: verification of the candidates and :func:`detect`.
"""

from aerofid.detect.hough.analysis import HoughParams
from aerofid.detect.hough.detector import detect
from aerofid.detect.hough.search import SearchParams

__all__ = ["HoughParams", "SearchParams", "detect"]
