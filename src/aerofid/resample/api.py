"""``resample_frame``: a scan and its stored interior orientation -> the resampled frame, its sidecar and any
other outputs, all written or none (docs/resample.md)."""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from aerofid.errors import AerofidInputError
from aerofid.formats.orientation import StoredOrientation
from aerofid.io.atomic import Staging, check_output, sweep_stale, temporary_beside
from aerofid.io.raster import open_raster
from aerofid.orientation.grid import ResampleGrid, bounding_extent
from aerofid.resample.frame import Resampled, resample_scan, sidecar_path
from aerofid.resample.warp import DEFAULT_KERNEL


class StreamedOutput:
    """A large output that a writer streams into a temporary file beside it (named as :mod:`aerofid.io.atomic`
    names its own, so that a killed run's file is swept by the next), renamed into place by :meth:`commit`,
    removed on leaving the ``with`` block otherwise."""

    def __init__(self, path: str | os.PathLike[str], what: str, inputs: Sequence[str | os.PathLike[str]] = ()):
        self.path = check_output(path, what, inputs)
        self._what, self._inputs = what, list(inputs)
        sweep_stale(self.path)
        fd, tmp = temporary_beside(self.path)
        os.close(fd)
        self.tmp: Path | None = Path(tmp)

    def commit(self) -> None:
        """Rename the temporary file into place (the path checked again first)."""
        if self.tmp is None:
            raise AerofidInputError(f"{str(self.path)!r} was already written or discarded")
        check_output(self.path, self._what, self._inputs)
        try:
            os.replace(self.tmp, self.path)
        except OSError as e:
            raise AerofidInputError(f"cannot write {str(self.path)!r}: {e.strerror}") from None
        self.tmp = None

    def __enter__(self) -> StreamedOutput:
        return self

    def __exit__(self, *exc_info: object) -> None:
        if self.tmp is not None:
            with contextlib.suppress(OSError):
                self.tmp.unlink()
            self.tmp = None


def make_grid(orientation: StoredOrientation, pixel_size_mm: float,
              extent_mm: Sequence[float] | None = None, y_axis: str | None = None) -> ResampleGrid:
    """The output grid: ``extent_mm`` or, as MicMac ReSampFid, the bounding box of the orientation's fiducials;
    the camera's y axis from ``y_axis``, else the orientation, else down (MicMac's)."""
    if extent_mm is None:
        if not orientation.fiducials:
            raise AerofidInputError(f"{orientation.source!r} has no fiducials to bound the output: give --extent "
                                    "XMIN YMIN XMAX YMAX in mm")
        extent_mm = bounding_extent(orientation.fiducials_mm)
    return ResampleGrid(pixel_size_mm, tuple(extent_mm), y_axis or orientation.y_axis or "down")  # type: ignore[arg-type]


def check_fits(orientation: StoredOrientation, width: int, height: int, image: str) -> None:
    """An input error when the orientation's measured fiducials lie outside the scan: it is another scan's (or
    another resolution's) orientation, whose resampling would be silently wrong."""
    outside = [f.name for f in orientation.fiducials
               if not (-0.5 <= f.x_px <= width - 0.5 and -0.5 <= f.y_px <= height - 0.5)]
    if outside:
        raise AerofidInputError(f"fiducial(s) {', '.join(outside)} of {orientation.source!r} lie outside {image!r} "
                                f"({width} x {height} px): is it this scan's orientation (image "
                                f"{orientation.image!r})?")


def resample_frame(image: str | os.PathLike[str], orientation: StoredOrientation, output: str | os.PathLike[str], *,
                   pixel_size_mm: float, extent_mm: Sequence[float] | None = None, kernel: str = DEFAULT_KERNEL,
                   y_axis: str | None = None, sidecar: bool = True,
                   extra_outputs: Mapping[str | os.PathLike[str], Callable[[Resampled], str]] | None = None,
                   ) -> Resampled:
    """Resample ``image`` into its camera's fiducial frame and write ``output`` (a Cloud-Optimized GeoTIFF,
    :mod:`aerofid.resample.tiff`), its sidecar ``OUT.px2mm.json`` (:func:`aerofid.resample.frame.sidecar_path`)
    and ``extra_outputs`` (path -> text made from the result), all checked before any work and written only once
    everything has succeeded.

    Parameters
    ----------
    orientation : StoredOrientation
        The scan's interior orientation (:func:`aerofid.formats.orientation.read_orientation`).
    pixel_size_mm, extent_mm, y_axis
        The output grid (:func:`make_grid`).
    kernel : str
        ``bilinear``, ``bicubic`` or ``lanczos`` (:data:`aerofid.resample.warp.KERNELS`).

    Raises
    ------
    AerofidInputError
        A bad grid, kernel, scan or output (nothing is written).
    """
    grid = make_grid(orientation, pixel_size_mm, extent_mm, y_axis)
    inputs = [image] + ([orientation.source] if orientation.source else [])
    with Staging(inputs) as staging, StreamedOutput(output, "output", inputs) as out:
        side = staging.plan(sidecar_path(output), "sidecar") if sidecar else None
        extras = {staging.plan(p, "export"): make for p, make in (extra_outputs or {}).items()}
        fiducials = tuple((f.name, f.x_mm, f.y_mm) for f in orientation.fiducials)
        with open_raster(image) as scan:
            check_fits(orientation, scan.width, scan.height, str(image))
            assert out.tmp is not None
            result = resample_scan(scan, orientation.transform, grid, out.tmp, kernel=kernel,
                                   image=out.path.name, fiducials=fiducials)
        if side is not None:
            staging.put(side, json.dumps(result.to_dict(), indent=2) + "\n")
        for p, make in extras.items():
            staging.put(p, make(result))
        out.commit()
        try:
            staging.commit()
        except AerofidInputError:
            with contextlib.suppress(OSError):
                out.path.unlink()
            raise
    return result


__all__ = ["DEFAULT_KERNEL", "StreamedOutput", "check_fits", "make_grid", "resample_frame"]
