"""Interior orientation, pure (no file is read here; see :mod:`aerofid.formats`): the camera certificate
(:mod:`.camera`), measured fiducials (:mod:`.measurements`), pixel -> mm transformations as objects
(:mod:`.transform`), the least-squares adjustment (:mod:`.adjustment`), blunder detection (:mod:`.blunders`),
the 8 film arrangements (:mod:`.correspondence`), :func:`~.interior.orient` (:mod:`.interior`) and its result
(:mod:`.result`), reports (:mod:`.report`)."""
