"""aerofid: fiducial marks and premarked ground points in scanned aerial photographs.

Public API:
    locate(image, box, mark="auto", method="auto", **params) -> Location
    find_marks(image, region=None, mark="auto", ...) -> MarkSearch (every mark in a region)
    read_camera(path) -> Camera;  read_measurements(path) -> Measurements
    orient(camera, measurements, model="affine", ...) -> InteriorOrientation
"""

from aerofid.errors import AerofidInputError
from aerofid.find import MarkSearch, find_marks
from aerofid.formats.camera_file import read_camera, write_camera
from aerofid.formats.measurements import read_measurements, write_measurements
from aerofid.locate import Location, locate
from aerofid.orientation.camera import Camera, Fiducial
from aerofid.orientation.correspondence import AmbiguousCorrespondenceError
from aerofid.orientation.interior import orient
from aerofid.orientation.measurements import Measurements
from aerofid.orientation.result import InteriorOrientation
from aerofid.orientation.transform import AffineTransform, ProjectiveTransform, SimilarityTransform

__version__ = "0.1.0"

__all__ = ["AerofidInputError", "AffineTransform", "AmbiguousCorrespondenceError", "Camera", "Fiducial",
           "InteriorOrientation", "Location", "MarkSearch", "Measurements", "ProjectiveTransform",
           "SimilarityTransform", "__version__", "find_marks", "locate", "orient", "read_camera", "read_measurements",
           "write_camera", "write_measurements"]
