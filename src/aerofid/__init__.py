"""aerofid: fiducial marks and premarked ground points in scanned aerial photographs.

Public API:
    locate(image, box, mark="auto", method="auto", **params) -> Location
    find_marks(image, region=None, mark="auto", ...) -> MarkSearch (every mark in a region)
    read_camera(path) -> Camera;  read_measurements(path) -> Measurements
    orient(camera, measurements, model="affine", ...) -> InteriorOrientation
    orient_frame(image, camera, ...) -> FrameOrientation (a whole frame, no boxes)

``import aerofid`` loads none of these: each name is imported from its module on first use (PEP 562
``__getattr__``), so that a one-mark ``locate`` does not pay for the orientation's statistics (scipy.optimize,
scipy.special) and ``aerofid --help`` starts at once.
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the same names, for type checkers and readers (and the import graph of test_architecture)
    from aerofid.errors import AerofidInputError
    from aerofid.find import MarkSearch, find_marks
    from aerofid.formats.camera_file import read_camera, write_camera
    from aerofid.formats.measurements import read_measurements, write_measurements
    from aerofid.frame.orient import orient_frame
    from aerofid.frame.result import FrameOrientation
    from aerofid.locate import Location, locate
    from aerofid.orientation.camera import Camera, Fiducial
    from aerofid.orientation.correspondence import AmbiguousCorrespondenceError
    from aerofid.orientation.interior import orient
    from aerofid.orientation.measurements import Measurements
    from aerofid.orientation.result import InteriorOrientation
    from aerofid.orientation.transform import AffineTransform, ProjectiveTransform, SimilarityTransform

__version__ = "0.1.0"

_SOURCE = {
    "AerofidInputError": "aerofid.errors", "MarkSearch": "aerofid.find", "find_marks": "aerofid.find",
    "read_camera": "aerofid.formats.camera_file", "write_camera": "aerofid.formats.camera_file",
    "read_measurements": "aerofid.formats.measurements", "write_measurements": "aerofid.formats.measurements",
    "Location": "aerofid.locate", "locate": "aerofid.locate", "Camera": "aerofid.orientation.camera",
    "Fiducial": "aerofid.orientation.camera", "AmbiguousCorrespondenceError": "aerofid.orientation.correspondence",
    "orient": "aerofid.orientation.interior", "Measurements": "aerofid.orientation.measurements",
    "InteriorOrientation": "aerofid.orientation.result", "AffineTransform": "aerofid.orientation.transform",
    "ProjectiveTransform": "aerofid.orientation.transform", "SimilarityTransform": "aerofid.orientation.transform",
    "orient_frame": "aerofid.frame.orient", "FrameOrientation": "aerofid.frame.result",
}
"""Each public name and the module it comes from (the ``TYPE_CHECKING`` imports above, for the first use)."""

__all__ = ["AerofidInputError", "AffineTransform", "AmbiguousCorrespondenceError", "Camera", "Fiducial",
           "FrameOrientation", "InteriorOrientation", "Location", "MarkSearch", "Measurements",
           "ProjectiveTransform", "SimilarityTransform", "__version__", "find_marks", "locate", "orient",
           "orient_frame", "read_camera", "read_measurements", "write_camera", "write_measurements"]


def __getattr__(name: str) -> Any:
    """A public name, imported from its module on first use and kept (PEP 562)."""
    if name not in _SOURCE:
        raise AttributeError(f"module 'aerofid' has no attribute {name!r}")
    value = getattr(importlib.import_module(_SOURCE[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_SOURCE})


class _Package(types.ModuleType):
    """The package's module type: when the import system binds a submodule to the package under the name of
    the function it exports (``aerofid.locate``, once any module imported :mod:`aerofid.locate`), the name
    stays the function, as with eager imports."""

    def __setattr__(self, name: str, value: Any) -> None:
        if isinstance(value, types.ModuleType) and _SOURCE.get(name) == value.__name__:
            value = getattr(value, name)
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
