"""A batch's settings and each frame's outputs: their names in the output folder, and when a frame is complete.

A frame is **complete** when its orientation JSON can be read, was made with the same settings (the
:attr:`BatchSettings.fingerprint` of the camera and the options, stored in it), from the same scan (its size
and modification time), and every other output it lists is present. A rerun of the same batch skips complete
frames and redoes the others (:func:`read_complete`); the JSON is the last file of a frame put in place
(:mod:`aerofid.batch.job`), so a frame whose writing was cut short is never complete.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from aerofid.errors import AerofidInputError
from aerofid.frame.profile import read_profile
from aerofid.io.resolution import checked_pixel_size
from aerofid.orientation.camera import Camera
from aerofid.resample.frame import MICMAC_PREFIX
from aerofid.resample.warp import DEFAULT_KERNEL, KERNELS

MICMAC_FOLDER = "Ori-InterneScan"
"""The output folder's subfolder of MicMac files (MicMac's name for the scans' interior orientation)."""
RESAMPLED_FOLDER = "resampled"
"""The output folder's subfolder of the resampled frames (``--resample``), named as MicMac's ReSampFid names them."""
CROPS_FOLDER = "crops"
"""The output folder's subfolder of each frame's mark crops (one PNG per frame, for the summary's gallery)."""
MEASURES_CAMERA = "MeasuresCamera.xml"
"""The camera's calibrated fiducials for MicMac, one file per batch in :data:`MICMAC_FOLDER`."""
FINGERPRINT_CHARS = 16
"""Hex digits of the settings' SHA-256 kept as their fingerprint."""
MODELS = ("affine", "similarity", "projective")
"""The adjustment's models (:func:`aerofid.orient_frame`)."""


@dataclass(frozen=True)
class BatchSettings:
    """What every frame of a batch is processed with (small and picklable: it travels to each worker).

    ``camera_path`` and ``outdir`` are absolute, so that a worker in another folder or on another machine that
    sees the same files finds them. ``fingerprint`` identifies the camera and the options (:func:`batch_settings`).
    ``profile_path``: the roll's profile (``--profile``, :mod:`aerofid.frame.profile`), its content in the
    fingerprint. ``resample_mm``: each frame oriented ok is also resampled into its camera's film mm at this pixel
    size with ``kernel`` (``--resample``, :func:`aerofid.resample.resample_frame`).
    """

    camera_path: str
    outdir: str
    model: str
    pixel_size_mm: float | None
    lie: tuple[int, bool] | None
    fingerprint: str
    profile_path: str | None = None
    resample_mm: float | None = None
    kernel: str = DEFAULT_KERNEL

    def options(self) -> dict[str, Any]:
        """The options as JSON holds them (the summary's header)."""
        d = asdict(self)
        d["lie"] = None if self.lie is None else list(self.lie)
        return d


def batch_settings(camera: Camera, camera_path: str | os.PathLike[str], outdir: str | os.PathLike[str], *,
                   model: str = "affine", pixel_size_mm: float | None = None,
                   lie: tuple[int, bool] | None = None,
                   profile_path: str | os.PathLike[str] | None = None, resample_mm: float | None = None,
                   kernel: str = DEFAULT_KERNEL) -> BatchSettings:
    """The settings of a batch, with the fingerprint of ``camera`` (its calibration as read, not the file's
    bytes), of the roll profile (as read) and of the options.

    Raises
    ------
    AerofidInputError
        An unknown model or a pixel size that is not a length in mm (checked here, before any frame).
    """
    if model not in MODELS:
        raise AerofidInputError(f"model {model!r}: choose {', '.join(MODELS)}")
    pixel_size_mm = None if pixel_size_mm is None else checked_pixel_size(pixel_size_mm)
    profile = read_profile(profile_path) if profile_path is not None else None
    if profile is not None:
        profile.check_camera(camera.name)
    what = {"camera": camera.to_dict(), "model": model, "pixel_size_mm": pixel_size_mm,
            "lie": None if lie is None else list(lie), "profile": None if profile is None else profile.to_dict(),
            "resample_mm": resample_mm, "kernel": kernel if resample_mm is not None else None}
    digest = hashlib.sha256(json.dumps(what, sort_keys=True).encode("utf-8")).hexdigest()[:FINGERPRINT_CHARS]
    if resample_mm is not None and not 0 < resample_mm < 1:
        raise AerofidInputError(f"--resample {resample_mm!r} mm: give the resampled frame's pixel size in mm, e.g. "
                                "0.021")
    if kernel not in KERNELS:
        raise AerofidInputError(f"kernel {kernel!r}: choose {', '.join(KERNELS)}")
    return BatchSettings(os.path.abspath(camera_path), os.path.abspath(outdir), model, pixel_size_mm, lie, digest,
                         None if profile_path is None else os.path.abspath(profile_path), resample_mm, kernel)


@dataclass(frozen=True)
class FrameOutputs:
    """A frame's outputs, relative to the output folder, named by its key (:func:`aerofid.batch.inputs.frame_keys`).

    ``measures_im`` and ``affine_plane`` (MicMac) are written only when the frame has an orientation, the
    AffinePlane not for the projective model.
    """

    key: str
    json: str
    html: str
    crops: str
    measures_im: str
    affine_plane: str | None
    resampled: str


def frame_outputs(key: str, model: str) -> FrameOutputs:
    """The names of frame ``key``'s outputs.

    Examples
    --------
    >>> o = frame_outputs("x.tif", "affine")
    >>> o.json, o.html, o.crops, o.measures_im, o.affine_plane
    ('x.tif.json', 'x.tif.html', 'crops/x.tif.png', 'Ori-InterneScan/MeasuresIm-x.tif.xml', \
'Ori-InterneScan/x.tif-AffinePlane-px2mm.xml')
    """
    return FrameOutputs(key, f"{key}.json", f"{key}.html", f"{CROPS_FOLDER}/{key}.png",
                        f"{MICMAC_FOLDER}/MeasuresIm-{key}.xml",
                        None if model == "projective" else f"{MICMAC_FOLDER}/{key}-AffinePlane-px2mm.xml",
                        f"{RESAMPLED_FOLDER}/{MICMAC_PREFIX}{Path(key).stem}.tif")


def scan_identity(path: str | os.PathLike[str]) -> dict[str, int]:
    """The scan's size and modification time (ns): a frame made from another version of it is not complete."""
    st = os.stat(path)
    return {"size": st.st_size, "mtime_ns": st.st_mtime_ns}


def read_complete(path: str | os.PathLike[str], key: str, settings: BatchSettings) -> dict[str, Any] | None:
    """Frame ``key``'s orientation document (its JSON) when the frame is complete (module docstring), else None."""
    outdir = Path(settings.outdir)
    try:
        doc = json.loads((outdir / frame_outputs(key, settings.model).json).read_text(encoding="utf-8"))
        batch = doc["batch"]
        same = batch["fingerprint"] == settings.fingerprint and batch["scan"] == scan_identity(path)
        present = all((outdir / name).is_file() for name in batch["outputs"])
    except (OSError, ValueError, TypeError, KeyError):
        return None
    return doc if same and present else None


def prepare_outdir(outdir: str | os.PathLike[str]) -> Path:
    """Create the output folder and its subfolders (:data:`CROPS_FOLDER`, :data:`MICMAC_FOLDER`).

    Raises
    ------
    AerofidInputError
        The folder cannot be created or written.
    """
    out = Path(outdir)
    try:
        for sub in (CROPS_FOLDER, MICMAC_FOLDER):
            (out / sub).mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise AerofidInputError(f"cannot create output folder {str(out)!r}: {e.strerror or e}") from None
    if not os.access(out, os.W_OK | os.X_OK):
        raise AerofidInputError(f"output folder {str(out)!r} is not writable; give another -o")
    return out


__all__ = ["CROPS_FOLDER", "MEASURES_CAMERA", "MICMAC_FOLDER", "MODELS", "BatchSettings", "FrameOutputs",
           "batch_settings", "frame_outputs", "prepare_outdir", "read_complete", "scan_identity"]
