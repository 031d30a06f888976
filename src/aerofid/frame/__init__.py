"""Whole frames: the camera's fiducials found on a scan from the camera file alone, and the interior
orientation with a verdict per fiducial and per frame (issue 12)."""
