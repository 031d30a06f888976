"""Reading scans and writing outputs: lazy, windowed raster reads (:mod:`.raster`) and atomic writes
(:mod:`.atomic`). Imports nothing above :mod:`aerofid.errors` and :mod:`aerofid.robust`."""
