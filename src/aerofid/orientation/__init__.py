"""Interior orientation: the camera certificate (:mod:`.camera`), measured fiducials (:mod:`.measurements`),
the pixel -> mm adjustment with blunder rejection and correspondence (:mod:`.interior`), reports
(:mod:`.report`). Pure: no file is read here (see :mod:`aerofid.formats`)."""
