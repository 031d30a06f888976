"""A batch's roll-level exports for other tools: the Metashape script of every frame oriented ok
(``aerofid batch --metashape``: OUTDIR/metashape_fiducials.py, :mod:`aerofid.formats.metashape`).

The script is made from the frames' orientation JSON as written (a rerun's complete frames included), so that it
says what the frames' files say; a frame that is not ok (doubtful, failed, an error) is left out and listed in
its header with the reason.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from aerofid.batch.job import FrameRecord
from aerofid.batch.plan import BatchSettings, frame_outputs
from aerofid.errors import AerofidInputError
from aerofid.formats.metashape import SCRIPT_FILE, LeftOut, metashape_script
from aerofid.formats.orientation import StoredOrientation, read_orientation
from aerofid.frame.result import OK
from aerofid.io.atomic import Staging
from aerofid.orientation.camera import Camera


def roll_orientations(records: Sequence[FrameRecord], settings: BatchSettings
                      ) -> tuple[list[StoredOrientation], list[LeftOut]]:
    """The orientations of the frames oriented ok (read from their JSON), and the other frames with why."""
    frames, left = [], []
    for r in records:
        name = Path(r.path).name
        if r.status != OK:
            left.append(LeftOut(name, f"{r.status}: {r.error or '; '.join(r.reasons) or 'no reason given'}"))
            continue
        try:
            frames.append(read_orientation(Path(settings.outdir) / frame_outputs(r.frame, settings.model).json))
        except AerofidInputError as e:
            left.append(LeftOut(name, str(e)))
    return frames, left


def write_metashape(records: Sequence[FrameRecord], settings: BatchSettings, camera: Camera) -> Path:
    """Write the roll's Metashape script (:data:`~aerofid.formats.metashape.SCRIPT_FILE` in the output folder,
    staged and renamed into place); its path."""
    path = Path(settings.outdir) / SCRIPT_FILE
    frames, left = roll_orientations(records, settings)
    with Staging() as staging:
        staging.put(path, metashape_script(frames, camera, left))
        staging.commit()
    return path


__all__ = ["roll_orientations", "write_metashape"]
