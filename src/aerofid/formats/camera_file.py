"""Camera files: the calibration certificate as JSON, YAML or MicMac ``MeasuresCamera.xml``.

The JSON/YAML structure is described in :mod:`aerofid.orientation.camera` and docs/orientation.md; duplicate keys
(JSON and YAML would silently keep the last) and deep nesting are refused (:mod:`aerofid.formats.text`).
"""

from __future__ import annotations

import json
from pathlib import Path

from aerofid.formats.micmac import read_measures_camera, write_measures_camera
from aerofid.formats.text import load_json
from aerofid.formats.yaml_text import dump_yaml, load_yaml
from aerofid.io.atomic import write_text_atomic
from aerofid.io.files import input_file, read_text_input
from aerofid.orientation.camera import Camera


def read_camera(path: str | Path) -> Camera:
    """Read a camera file: ``.json``, ``.yaml``/``.yml`` or MicMac ``.xml`` (MeasuresCamera).

    Parameters
    ----------
    path : str or Path
        The file; its extension says the format (anything but ``.xml``, ``.yaml`` and ``.yml`` is JSON).

    Returns
    -------
    Camera

    Raises
    ------
    AerofidInputError
        The file is missing or unreadable, not valid JSON/YAML/XML, has duplicate keys, or describes an
        implausible camera (see :class:`aerofid.orientation.camera.Camera`).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "rc30.yaml").write_text(
    ...     "name: RC30\\nfocal_length_mm: 152.85\\nfiducials:\\n"
    ...     "  UL: [-106, 106]\\n  UR: [106, 106]\\n  LL: [-106, -106]\\n  LR: [106, -106]\\n")
    >>> cam = read_camera(folder / "rc30.yaml")
    >>> cam.names, cam.focal_length_mm, cam.y_axis
    (('UL', 'UR', 'LL', 'LR'), 152.85, 'up')
    """
    path = input_file(path, "camera file")
    suffix = path.suffix.lower()
    if suffix == ".xml":
        return read_measures_camera(path)
    path, text = read_text_input(path, "camera file")
    source = f"camera file {str(path)!r}"
    data = load_yaml(text, source) if suffix in (".yaml", ".yml") else load_json(text, source)
    return Camera.from_dict(data, source=str(path))


def write_camera(path: str | Path, camera: Camera) -> None:
    """Write ``camera`` as JSON, YAML (by extension) or MicMac MeasuresCamera ``.xml``, atomically.

    Parameters
    ----------
    path : str or Path
        The file: ``.yaml``/``.yml``, ``.xml`` (MicMac keeps only the fiducials), anything else JSON.
    camera : Camera

    Examples
    --------
    >>> import tempfile, pathlib
    >>> cam = Camera.from_dict({"name": "c", "fiducials": {"P1": [-100, 0], "P2": [100, 0], "P3": [0, 100]}})
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "c.json"
    >>> write_camera(path, cam)
    >>> read_camera(path) == cam
    True
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".xml":
        write_measures_camera(path, camera)
    elif suffix in (".yaml", ".yml"):
        write_text_atomic(path, dump_yaml(camera.to_dict()))
    else:
        write_text_atomic(path, json.dumps(camera.to_dict(), indent=2) + "\n")


__all__ = ["read_camera", "write_camera"]
