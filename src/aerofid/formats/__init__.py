"""Interchange files: camera files (:mod:`.camera_file`), measurements (:mod:`.measurements`: JSON, CSV,
MicMac), MicMac XML (:mod:`.micmac`). Depends on :mod:`aerofid.orientation`'s types, never the reverse."""
