"""Helpers shared by the raster tests (tests/test_raster.py, tests/test_raster_reduced.py): test images of
every dtype, TIFF writing, and a record of which TIFF segments were decoded."""

import numpy as np
import tifffile

HEIGHT, WIDTH = 203, 157  # not multiples of any tile, strip or reduction factor the tests use


def random_image(dtype, bands, seed=0, shape=(HEIGHT, WIDTH)):
    """Random samples covering the dtype's range (floats in [0, 1])."""
    rng = np.random.default_rng(seed)
    full_shape = shape if bands == 1 else (*shape, bands)
    if np.dtype(dtype).kind == "f":
        return rng.random(full_shape).astype(dtype)
    return rng.integers(0, np.iinfo(dtype).max, full_shape, endpoint=True, dtype=dtype)


def write_tiff(path, image, **kwargs):
    """Write ``image`` as a TIFF, RGB if it has 3 bands, and return ``path``."""
    photometric = "rgb" if image.ndim == 3 else "minisblack"
    tifffile.imwrite(path, image, photometric=photometric, **kwargs)
    return path


def record_decoded_segments(monkeypatch):
    """Make every ``TiffPage.decode`` call append the segment index to the returned list."""
    decoded = []
    make_decoder = tifffile.TiffPage.__dict__["decode"].func  # the cached_property's function

    def counting_decoder(page):
        decode = make_decoder(page)

        def counting_decode(data, index, **kwargs):
            decoded.append(index)
            return decode(data, index, **kwargs)

        return counting_decode

    monkeypatch.setattr(tifffile.TiffPage, "decode", property(counting_decoder))
    return decoded
