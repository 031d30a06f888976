"""aerofid: fiducial marks and premarked ground points in scanned aerial photographs.

Public API:
    locate(image, box, mark="auto", method="auto", **params) -> Location
"""

__version__ = "0.1.0"
