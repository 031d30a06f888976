"""Resampling a scanned frame into its camera's fiducial (film mm) frame, like MicMac ReSampFid, block by block
into a Cloud-Optimized GeoTIFF (GDAL's COG layout, with overviews; docs/resample.md)."""

from aerofid.resample.api import make_grid, resample_frame
from aerofid.resample.frame import Resampled, output_name, resample_scan, sidecar_path
from aerofid.resample.warp import DEFAULT_KERNEL, KERNELS

__all__ = ["DEFAULT_KERNEL", "KERNELS", "Resampled", "make_grid", "output_name", "resample_frame", "resample_scan",
           "sidecar_path"]
