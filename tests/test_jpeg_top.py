"""A JPEG's top rows before its whole decode (aerofid.io.jpeg_top): the same samples as OpenCV's whole decode, and a
file that cannot be decoded whole stays an error."""

from __future__ import annotations

import threading

import cv2
import numpy as np
import pytest

from aerofid.errors import AerofidInputError
from aerofid.io import jpeg, jpeg_top
from aerofid.io.array import ArrayRaster
from aerofid.io.raster import open_raster


def _texture(shape, bands, seed=0):
    """Noisy, structured uint8 samples (JPEG keeps plenty of detail: every block's coefficients matter)."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[: shape[0], : shape[1]]
    planes = [127 + 80 * np.sin(x / (9 + k) + y / 13) + rng.normal(0, 20, shape) for k in range(bands)]
    image = np.clip(np.stack(planes, axis=-1), 0, 255).astype(np.uint8)
    return image[:, :, 0] if bands == 1 else image


def _write(path, image, *params):
    bgr = image if image.ndim == 2 else image[:, :, ::-1]
    path.write_bytes(cv2.imencode(".jpg", bgr, list(params))[1].tobytes())
    return path


def _whole(path):
    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    return image[:, :, None] if image.ndim == 2 else image[:, :, ::-1]


ENCODINGS = {
    "rgb 4:2:0": (3, [cv2.IMWRITE_JPEG_SAMPLING_FACTOR, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_420]),
    "rgb 4:4:4": (3, [cv2.IMWRITE_JPEG_SAMPLING_FACTOR, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_444]),
    "rgb progressive": (3, [cv2.IMWRITE_JPEG_PROGRESSIVE, 1]),
    "grey": (1, [cv2.IMWRITE_JPEG_QUALITY, 80]),
}


@pytest.mark.parametrize("encoding", ENCODINGS)
def test_top_rows_are_the_whole_decode_s_rows(tmp_path, encoding):
    """Any number of top rows (within an MCU row, at its end, all of them) of an odd-sized image are OpenCV's."""
    bands, params = ENCODINGS[encoding]
    path = _write(tmp_path / "scan.jpg", _texture((203, 157), bands), *params)
    header = jpeg.read_header(path, "jpeg")
    whole = _whole(path)
    for rows in (1, 7, 16, 17, 100, 203):
        top = jpeg_top.decode_top(path, rows, header)
        assert top is not None and top.shape == (rows, 157, bands)
        np.testing.assert_array_equal(top, whole[:rows])


@pytest.mark.parametrize("limit", [20_000, 10_000])
def test_a_scan_beyond_pillows_decompression_bomb_limit_gives_its_rows_without_a_warning(tmp_path, monkeypatch,
                                                                                         limit):
    """Pillow warns about an image of more than its ``MAX_IMAGE_PIXELS`` (89 million: a 9500 px square scan) and
    refuses one of twice that; the top rows of such a scan decode all the same, with no warning (warnings are errors
    here): aerofid's decode budget is the guard. The limit lowered to a small image's 2x or 4x its size."""
    from PIL import Image

    monkeypatch.setattr(Image, "MAX_IMAGE_PIXELS", limit)
    path = _write(tmp_path / "scan.jpg", _texture((203, 157), 1))
    header = jpeg.read_header(path, "jpeg")
    top = jpeg_top.decode_top(path, 64, header)
    assert top is not None
    np.testing.assert_array_equal(top, _whole(path)[:64])


def test_rows_beyond_a_truncated_file_s_data_are_not_given(tmp_path):
    """A file cut short: the rows its data reaches decode; rows beyond them give None (the whole decode tells)."""
    data = (_write(tmp_path / "scan.jpg", _texture((400, 300), 3))).read_bytes()
    path = tmp_path / "cut.jpg"
    path.write_bytes(data[: len(data) // 2])
    header = jpeg.read_header(path, "jpeg")
    assert jpeg_top.decode_top(path, 390, header) is None
    top = jpeg_top.decode_top(path, 48, header)
    assert top is not None
    np.testing.assert_array_equal(top, _whole(tmp_path / "scan.jpg")[:48])


def test_the_real_rc20_frame_s_top_rows_are_the_whole_decode_s(realdata):
    path = realdata("unbc_bc_wild_rc20/15BCC02013_114.jpg")
    top = jpeg_top.decode_top(path, 1100, jpeg.read_header(path, "jpeg"))
    assert top is not None
    np.testing.assert_array_equal(top, _whole(path)[:1100])


def _held_decode(monkeypatch):
    """The background whole decode held until the returned event is set."""
    release = threading.Event()
    real = jpeg._read_only

    def held(path, header=None):
        release.wait(60)
        return real(path, header)

    monkeypatch.setattr(jpeg, "_read_only", held)
    jpeg.forget_decodes()
    return release


def test_a_window_near_the_top_is_read_before_the_whole_decode_is_done(tmp_path, monkeypatch):
    """While the whole decode runs, a window in the top rows comes from them (the same samples); one below the top
    share waits for the whole decode."""
    path = _write(tmp_path / "big.jpg", _texture((2400, 1400), 3))
    whole = _whole(path)
    release = _held_decode(monkeypatch)
    try:
        with open_raster(path) as raster:
            np.testing.assert_array_equal(raster.read_window((100, 30, 400, 500)), whole[30:500, 100:400])
            assert raster._reader.served_top and not raster._reader.pending.future.done()
            release.set()
            np.testing.assert_array_equal(raster.read_window((10, 2000, 50, 2400)), whole[2000:2400, 10:50])
    finally:
        release.set()
        jpeg.forget_decodes()


def test_a_file_that_cannot_be_decoded_whole_is_an_error_though_its_top_rows_decode(tmp_path, monkeypatch):
    """A truncated frame: its top rows are read, and closing the raster raises the whole decode's error (one line),
    as a window that waited for it would have."""
    data = _write(tmp_path / "big.jpg", _texture((2400, 1400), 3)).read_bytes()
    path = tmp_path / "cut.jpg"
    path.write_bytes(data[: int(len(data) * 0.7)])
    release = _held_decode(monkeypatch)
    try:
        with pytest.raises(AerofidInputError) as excinfo, open_raster(path) as raster:
            raster.read_window((0, 0, 64, 64))
            assert raster._reader.served_top
            release.set()
        assert "corrupt or truncated" in str(excinfo.value) and "\n" not in str(excinfo.value)
    finally:
        release.set()
        jpeg.forget_decodes()


def _no_whole_decode(monkeypatch):
    """Fail any whole decode (the test's raster must not start one)."""
    def refused(path, header=None):
        raise AssertionError("a whole decode was started")

    monkeypatch.setattr(jpeg, "_read_only", refused)
    jpeg.forget_decodes()


def test_a_raster_opened_for_its_top_rows_decodes_them_alone(tmp_path, monkeypatch):
    """Opened for its top rows (``rows``), a JPEG's windows there are its whole decode's samples, read without
    starting the whole decode, nor does closing it start one (the file ends its scans); a window below the rows
    starts the whole decode and is right too."""
    path = _write(tmp_path / "big.jpg", _texture((2400, 1400), 3))
    whole = _whole(path)
    _no_whole_decode(monkeypatch)
    try:
        with open_raster(path, rows=600) as raster:
            np.testing.assert_array_equal(raster.read_window((100, 30, 400, 500)), whole[30:500, 100:400])
            np.testing.assert_array_equal(raster.read_window((0, 520, 64, 600)), whole[520:600, :64])
            assert raster._reader.served_top and raster._reader.pending is None and not raster.decoding
            assert raster._reader._top.shape[0] == 600
        assert not jpeg._DECODES
        monkeypatch.undo()
        with open_raster(path, rows=600) as raster:
            np.testing.assert_array_equal(raster.read_window((10, 2000, 50, 2400)), whole[2000:2400, 10:50])
            assert raster._reader.pending is not None
    finally:
        jpeg.forget_decodes()


def test_a_raster_opened_for_rows_beyond_the_top_share_decodes_whole_at_once(tmp_path):
    path = _write(tmp_path / "big.jpg", _texture((2400, 1400), 3))
    try:
        with open_raster(path, rows=int(jpeg_top.TOP_SHARE * 2400) + 1) as raster:
            assert raster._reader.pending is not None
    finally:
        jpeg.forget_decodes()


def test_a_kept_whole_decode_serves_a_raster_opened_for_its_top_rows(tmp_path):
    path = _write(tmp_path / "big.jpg", _texture((2400, 1400), 3))
    try:
        with open_raster(path) as first:
            first.check_decoded()
            kept = first._reader.pending
        with open_raster(path, rows=600) as raster:
            assert raster._reader.pending is kept
            np.testing.assert_array_equal(raster.read_window((0, 0, 8, 8)), _whole(path)[:8, :8])
            assert not raster._reader.served_top
    finally:
        jpeg.forget_decodes()


def test_a_truncated_file_opened_for_its_top_rows_is_an_error_on_closing(tmp_path):
    """Its top rows are read without the whole decode; closing it walks its markers, finds it cut short and decodes
    it whole to tell why (one line), as a raster that decoded it whole from the start does."""
    data = _write(tmp_path / "big.jpg", _texture((2400, 1400), 3)).read_bytes()
    path = tmp_path / "cut.jpg"
    path.write_bytes(data[: int(len(data) * 0.7)])
    jpeg.forget_decodes()
    try:
        with pytest.raises(AerofidInputError) as excinfo, open_raster(path, rows=600) as raster:
            raster.read_window((0, 0, 64, 64))
            assert raster._reader.served_top and raster._reader.pending is None
        assert "corrupt or truncated" in str(excinfo.value) and "\n" not in str(excinfo.value)
    finally:
        jpeg.forget_decodes()


def _jpeg_with_a_bullseye(tmp_path):
    """A 2400 x 1400 RGB JPEG (10 MB decoded: its top rows read alone), a bull's-eye centred at (560.3, 159.6)."""
    from aerofid import synth

    scene = synth.mark_scene("bullseye", size=30, window=120, centre=(60.3, 59.6), rng=np.random.default_rng(3))
    image = np.full((2400, 1400, 3), 40, np.uint8)
    image[100:220, 500:620] = (np.clip(scene.image, 0, 1) * 255).astype(np.uint8)[:, :, None]
    return _write(tmp_path / "frame.jpg", image, cv2.IMWRITE_JPEG_QUALITY, 95)


def _on_the_array_and_the_file(monkeypatch, path, call):
    """``call`` on the whole decode's samples of the JPEG at ``path`` (declared 4:2:0 like the file, whose windows are
    then measured in luminance), then on the file itself with no whole decode allowed (and none started,
    :func:`_no_whole_decode`): (expected, got)."""
    subsampled = jpeg.read_header(path, "jpeg").chroma_subsampled
    expected = call(ArrayRaster(_whole(path), chroma_subsampled=subsampled))
    _no_whole_decode(monkeypatch)
    try:
        got = call(path)
        assert not jpeg._DECODES
    finally:
        jpeg.forget_decodes()
    return expected, got


def test_locate_of_a_box_near_the_top_of_a_jpeg_does_not_decode_it_whole(tmp_path, monkeypatch):
    """``aerofid.locate`` of one box near a JPEG's top reads its top rows alone (no whole decode, opening nor closing)
    and answers as on the whole decode's samples."""
    import aerofid

    expected, got = _on_the_array_and_the_file(
        monkeypatch, _jpeg_with_a_bullseye(tmp_path),
        lambda image: aerofid.locate(image, (520, 120, 600, 200), mark="external"))
    assert expected.found and abs(expected.x - 560.3) < 0.2 and abs(expected.y - 159.6) < 0.2
    assert (got.status, got.x, got.y, got.sigma) == (expected.status, expected.x, expected.y, expected.sigma)


def test_a_raster_opened_for_its_top_rows_starts_its_whole_decode_when_asked_to_check_it(tmp_path):
    path = _write(tmp_path / "big.jpg", _texture((2400, 1400), 3))
    try:
        with open_raster(path, rows=600) as raster:
            raster.read_window((0, 0, 8, 8))
            assert raster._reader.pending is None
            raster.check_decoded()
            assert raster._reader.pending is not None and raster._reader.pending.future.done()
    finally:
        jpeg.forget_decodes()


def test_closing_without_the_check_leaves_a_truncated_file_s_top_rows_read_and_nothing_running(tmp_path):
    data = _write(tmp_path / "big.jpg", _texture((2400, 1400), 3)).read_bytes()
    path = tmp_path / "cut.jpg"
    path.write_bytes(data[: int(len(data) * 0.7)])
    jpeg.forget_decodes()
    raster = open_raster(path, rows=600)
    raster.read_window((0, 0, 64, 64))
    raster.close(check=False)
    assert raster._reader is None and not jpeg._DECODES
    assert not [t for t in threading.enumerate() if t.name == "aerofid-decode"]


def test_a_file_without_its_end_of_image_opened_for_its_top_rows_is_an_error_on_closing(tmp_path):
    data = _write(tmp_path / "big.jpg", _texture((2400, 1400), 3)).read_bytes()
    assert data.endswith(b"\xff\xd9")
    path = tmp_path / "no_eoi.jpg"
    path.write_bytes(data[:-2])
    assert jpeg.jpeg_structure(path) != "complete"
    jpeg.forget_decodes()
    try:
        with pytest.raises(AerofidInputError), open_raster(path, rows=600) as raster:
            raster.read_window((0, 0, 64, 64))
            assert raster._reader.served_top and raster._reader.pending is None
    finally:
        jpeg.forget_decodes()


def test_a_file_removed_after_its_top_rows_were_read_closes_quietly(tmp_path, monkeypatch):
    """Its rows were decoded whole (their last row checked); nothing is left to tell of a file that is gone."""
    path = _write(tmp_path / "big.jpg", _texture((2400, 1400), 3))
    _no_whole_decode(monkeypatch)
    try:
        with open_raster(path, rows=600) as raster:
            assert raster.read_window((0, 0, 8, 8)).shape == (8, 8, 3)
            path.unlink()
    finally:
        jpeg.forget_decodes()


def test_a_small_jpeg_opened_for_its_top_rows_is_decoded_whole_at_once(tmp_path):
    """Under MIN_DECODED_BYTES the top rows are not worth a decode of their own: the whole decode starts at once."""
    path = _write(tmp_path / "small.jpg", _texture((400, 300), 3))
    try:
        with open_raster(path, rows=50) as raster:
            assert raster._reader.pending is not None
            np.testing.assert_array_equal(raster.read_window((0, 0, 30, 20)), _whole(path)[:20, :30])
    finally:
        jpeg.forget_decodes()


def test_the_cli_s_boxes_open_the_scan_for_the_rows_their_searches_read(tmp_path, monkeypatch):
    """``locate_all``: boxes near the top alone, the scan opened for their rows; one lower box, for every row (its
    whole decode starts at once); no box, nothing searched."""
    from aerofid.cli import locate_cmd
    from aerofid.cli.boxes import NamedBox
    from aerofid.windows import rows_read

    path = _write(tmp_path / "big.jpg", _texture((2400, 1400), 3))
    opened = []
    real = locate_cmd.open_raster
    monkeypatch.setattr(locate_cmd, "open_raster", lambda image, rows=None: opened.append(rows) or real(image, rows))
    top = [NamedBox("a", (10.0, 10.0, 60.0, 60.0), "a", True), NamedBox("b", (100.0, 40.0, 160.0, 90.0), "b", True)]
    low = NamedBox("c", (10.0, 2000.0, 60.0, 2050.0), "c", True)
    try:
        assert len(locate_cmd.locate_all(str(path), top, mark="external")) == 2
        assert len(locate_cmd.locate_all(str(path), [*top, low], mark="external")) == 3
        assert locate_cmd.locate_all(str(path), []) == []
    finally:
        jpeg.forget_decodes()
    assert opened == [rows_read((100, 40, 160, 90)), rows_read((10, 2000, 60, 2050)), None]


def test_find_marks_in_a_region_near_the_top_of_a_jpeg_does_not_decode_it_whole(tmp_path, monkeypatch):
    import aerofid

    expected, got = _on_the_array_and_the_file(
        monkeypatch, _jpeg_with_a_bullseye(tmp_path),
        lambda image: aerofid.find_marks(image, (400, 60, 800, 260), mark="external"))
    assert len(expected.marks) == 1 and abs(expected.marks[0].x - 560.3) < 0.2
    assert [(m.x, m.y) for m in got.marks] == [(m.x, m.y) for m in expected.marks]


def test_the_next_raster_of_a_file_reads_the_top_rows_kept_from_the_last(tmp_path, monkeypatch):
    """``aerofid.locate(path, box)`` box after box near a JPEG's top decodes its top rows once; a file changed since
    (another modification time or size) is decoded again."""
    path = _write(tmp_path / "big.jpg", _texture((2400, 1400), 3))
    whole = _whole(path)
    decodes = []
    real = jpeg_top.decode_top
    monkeypatch.setattr(jpeg_top, "decode_top", lambda *a: decodes.append(a[1]) or real(*a))
    try:
        for box in ((100, 30, 400, 500), (0, 0, 50, 50), (700, 90, 900, 580)):
            with open_raster(path, rows=600) as raster:
                np.testing.assert_array_equal(raster.read_window(box), whole[box[1]:box[3], box[0]:box[2]])
        assert decodes == [600]
        changed = _write(tmp_path / "big.jpg", _texture((2400, 1400), 3, seed=1))
        with open_raster(changed, rows=600) as raster:
            np.testing.assert_array_equal(raster.read_window((0, 0, 50, 50)), _whole(changed)[:50, :50])
        assert decodes == [600, 600]
    finally:
        jpeg.forget_decodes()


def test_top_rows_read_while_the_whole_decode_runs_are_not_kept(tmp_path, monkeypatch):
    """A raster opened for every row (a whole frame's windows before its decode is done) keeps no top rows beyond it."""
    path = _write(tmp_path / "big.jpg", _texture((2400, 1400), 3))
    release = _held_decode(monkeypatch)
    try:
        with open_raster(path) as raster:
            raster.read_window((0, 0, 50, 50))
            assert raster._reader.served_top
            key = raster._reader._key
            release.set()
        assert key is not None and jpeg_top._TOPS.get(key) is None
    finally:
        release.set()
        jpeg.forget_decodes()
