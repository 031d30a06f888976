"""Reading scans and writing outputs: lazy, windowed and reduced raster reads (:mod:`.raster`, with
:mod:`.reduce` and :mod:`.jpeg`), arrays read like scans (:mod:`.array`), colour policy (:mod:`.colour`) and
atomic writes (:mod:`.atomic`). Imports nothing above :mod:`aerofid.errors` and :mod:`aerofid.robust`."""
