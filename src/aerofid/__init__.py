"""aerofid: fiducial marks and premarked ground points in scanned aerial photographs.

Public API:
    locate(image, box, mark="auto", method="auto", **params) -> Location
    Camera.load(path) -> Camera
    orient(camera, measurements, model="affine", ...) -> InteriorOrientation
"""

from aerofid.camera import Camera
from aerofid.errors import AerofidInputError
from aerofid.locate import Location, locate
from aerofid.orientation import AmbiguousCorrespondenceError, InteriorOrientation, orient

__version__ = "0.1.0"

__all__ = ["AerofidInputError", "AmbiguousCorrespondenceError", "Camera", "InteriorOrientation", "Location", "locate", "orient", "__version__"]
