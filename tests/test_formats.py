"""Measurement files (JSON, CSV, MicMac MeasuresIm) and MicMac AffinitePlane."""

from __future__ import annotations

import numpy as np
import pytest

from aerofid.errors import AerofidInputError
from aerofid.formats.camera_file import read_camera
from aerofid.formats.measurements import read_measurements, write_measurements
from aerofid.formats.micmac import (
    affine_plane_xml,
    read_affine_plane,
    read_measures_im,
    read_mesure_appuis,
    write_affine_plane,
    write_measures_camera,
)
from aerofid.io.atomic import write_text_atomic
from aerofid.orientation.camera import Camera
from aerofid.orientation.measurements import Measurements
from aerofid.orientation.transform import AffineTransform

M = Measurements(np.array([[167.5, 212.5], [5215.0, 234.0], [148.5, 5259.5], [5194.5, 5279.25]]),
                 ("P1", "P2", "P3", "P4"), "scan.tif")


@pytest.mark.parametrize("ext", ["json", "csv", "xml"])
def test_named_round_trip(tmp_path, ext):
    path = tmp_path / f"MeasuresIm-scan.tif.{ext}"
    write_measurements(path, M)
    back = read_measurements(path)
    assert back.names == M.names
    np.testing.assert_array_equal(back.xy, M.xy)
    assert back.image == "scan.tif"


@pytest.mark.parametrize("ext", ["json", "csv"])
def test_unnamed_round_trip(tmp_path, ext):
    m = Measurements(M.xy, None, "scan.tif")
    write_measurements(tmp_path / f"m.{ext}", m)
    back = read_measurements(tmp_path / f"m.{ext}")
    assert back.names is None
    np.testing.assert_array_equal(back.xy, m.xy)


def test_csv_variants(tmp_path):
    p = tmp_path / "m.csv"
    p.write_text("# measured by hand\nname;x;y\nP1; 1.5; 2\nP2;3;4.25\n\nP3;5;6  # note\n")
    m = read_measurements(p)
    assert m.names == ("P1", "P2", "P3")
    np.testing.assert_array_equal(m.xy, [[1.5, 2], [3, 4.25], [5, 6]])
    p.write_text("P1 1 2\nP2 3 4\nP3 5 6\n")
    assert read_measurements(p).names == ("P1", "P2", "P3")


def test_json_list_of_objects(tmp_path):
    p = tmp_path / "m.json"
    p.write_text('{"image": "a.tif", "points": [{"name": "A", "x": 1, "y": 2}, {"name": "B", "x": 3, "y": 4}]}')
    m = read_measurements(p)
    assert m.names == ("A", "B") and m.image == "a.tif"


@pytest.mark.parametrize("name,text,match", [
    ("m.json", '{"points": {"P1": [1]}}', r"\[x, y\]"),
    ("m.json", '{"points": {"P1": [1, "z"]}}', "number"),
    ("m.json", '{"pts": {}}', "points"),
    ("m.json", "{", "not valid JSON"),
    ("m.csv", "P1,1,2\nP1,3,4\n", "duplicate"),
    ("m.csv", "P1,1,2,3\n", "name,x,y"),
    ("m.csv", "P1,1,nan\n", "finite"),
    ("m.csv", "", "no measured points"),
    ("m.xml", "<Foo/>", "not a MicMac measures file"),
    ("m.xml", "<SetOfMesureAppuisFlottants><MesureAppuiFlottant1Im><NameIm>a</NameIm><OneMesureAF1I>"
              "<NamePt>P1</NamePt><PtIm>1</PtIm></OneMesureAF1I></MesureAppuiFlottant1Im>"
              "</SetOfMesureAppuisFlottants>", "two numbers"),
    ("m.xml", "<Set", "not valid XML"),
    ("m.dat", "x", "unknown measurements format"),
])
def test_bad_measurement_files(tmp_path, name, text, match):
    p = tmp_path / name
    p.write_text(text)
    with pytest.raises(AerofidInputError, match=match):
        read_measurements(p)


def test_micmac_multi_image_needs_a_choice(tmp_path):
    xml = ("<SetOfMesureAppuisFlottants>" + "".join(
        f"<MesureAppuiFlottant1Im><NameIm>{im}</NameIm><OneMesureAF1I><NamePt>P1</NamePt><PtIm>1 2</PtIm>"
        "</OneMesureAF1I></MesureAppuiFlottant1Im>" for im in ("a.tif", "b.tif")) + "</SetOfMesureAppuisFlottants>")
    p = tmp_path / "m.xml"
    p.write_text(xml)
    with pytest.raises(AerofidInputError, match="say which image"):
        read_measures_im(p)
    assert read_measures_im(p, image="b.tif").image == "b.tif"
    assert set(read_mesure_appuis(p)) == {"a.tif", "b.tif"}


def test_micmac_real_bare_root_file(realdata):
    m = read_measures_im(realdata("unbc_bc_wild_rc20/MeasuresCamera.xml"))
    assert m.image == "15BCC02013_114.jpg"
    assert m.names == ("P1", "P2", "P3", "P4")
    np.testing.assert_array_equal(m.xy[2], [-106.007, 106.006])


def test_micmac_measures_camera_round_trip(tmp_path):
    cam = Camera.from_dict({"name": "c", "fiducials": {"P1": [1, 2], "P2": [100, 2], "P3": [50, 80]}})
    write_measures_camera(tmp_path / "MeasuresCamera.xml", cam)
    back = read_camera(tmp_path / "MeasuresCamera.xml")
    assert back.names == cam.names
    np.testing.assert_array_equal(back.xy_mm, cam.xy_mm)


def test_affine_plane_layout_and_round_trip(tmp_path):
    H = np.array([[0.021, 0.0001, -115.4], [0.0002, -0.02099, 118.5]])
    text = affine_plane_xml(H)
    # MicMac: P -> I00 + x V10 + y V01
    assert "<I00>-115.4 118.5</I00>" in text
    assert "<V10>0.021 0.0002</V10>" in text
    assert "<V01>0.0001 -0.02099</V01>" in text
    write_affine_plane(tmp_path / "a.xml", H)
    back = read_affine_plane(tmp_path / "a.xml")
    np.testing.assert_array_equal(back, H)
    # the meaning of the elements: I00 is the image of (0, 0), I00 + V10 of (1, 0), I00 + V01 of (0, 1)
    i00, v10, v01 = back[:, 2], back[:, 0], back[:, 1]
    np.testing.assert_allclose(AffineTransform(H)([[0, 0], [1, 0], [0, 1]]), [i00, i00 + v10, i00 + v01])


def test_affine_plane_refuses_projective():
    with pytest.raises(AerofidInputError, match="projective"):
        affine_plane_xml(np.array([[1, 0, 0], [0, 1, 0], [1e-6, 0, 1]]))


def test_atomic_write_leaves_no_partial_file(tmp_path):
    with pytest.raises(AerofidInputError, match="does not exist"):
        write_text_atomic(tmp_path / "nope" / "x.txt", "a")
    write_text_atomic(tmp_path / "x.txt", "hello")
    assert (tmp_path / "x.txt").read_text() == "hello"
    assert [p.name for p in tmp_path.iterdir()] == ["x.txt"]
