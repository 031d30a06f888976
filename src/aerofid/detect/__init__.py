"""Finding one mark in one grey window: one module per seed's method (:mod:`.hough`, :mod:`.symmetry`,
:mod:`.circles`, :mod:`.lines`), the measures they share (:mod:`.noise`, :mod:`.threshold`,
:mod:`.asymmetry`, :mod:`.hough_lines`), the common result and parameter types (:mod:`.result`,
:mod:`.params`), the registry of the methods (:mod:`.registry`) and ``auto`` (:mod:`.auto`), which runs them
and cross-checks their answers. Every method: ``detect(window, params) -> <Method>Result``."""
