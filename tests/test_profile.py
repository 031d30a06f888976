"""A roll's profile (aerofid learn, orient --profile): learnt from one frame, it orients the roll's other frames
at their true centres, settles a symmetric layout's lie, and flags a frame that disagrees with it."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest
import tifffile

import aerofid
from aerofid.errors import AerofidInputError
from aerofid.formats.camera_file import write_camera
from aerofid.frame import marks as marks_module
from aerofid.frame.profile import RollProfile, read_profile
from aerofid.frame.report import frame_text
from aerofid.orientation.camera import Camera
from aerofid.synth_frame import frame_spec, render_frame, wild_rc10_camera, write_frame

CAMERA = wild_rc10_camera()
COARSE_MM = 0.08


def _cli(*args, cwd):
    return subprocess.run([sys.executable, "-m", "aerofid", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd)


@pytest.fixture(scope="module")
def roll(tmp_path_factory):
    """Three frames of one roll (the film lying 90 degrees mirrored) and a fourth scanned the other way round."""
    folder = tmp_path_factory.mktemp("roll")
    truths = {}
    for name, seed, lie in (("a.tif", 3, (90, True)), ("b.tif", 5, (90, True)), ("c.tif", 8, (180, False))):
        spec = frame_spec(CAMERA, COARSE_MM, np.random.default_rng(seed), rotation_deg=lie[0], mirrored=lie[1])
        truths[name] = write_frame(spec, folder / name, "tiled")
    write_camera(folder / "cam.json", CAMERA)
    return folder, truths


@pytest.fixture(scope="module")
def learnt(roll):
    """The profile ``aerofid learn`` writes from the roll's first frame."""
    folder, _ = roll
    r = _cli("learn", "a.tif", "--camera", "cam.json", "-o", "roll.json", cwd=folder)
    assert r.returncode == 0, r.stderr
    return read_profile(folder / "roll.json")


def test_a_profile_learnt_from_one_frame_orients_the_next_one(roll, learnt):
    folder, truths = roll
    profile = learnt
    assert (profile.rotation_deg, profile.mirrored) == (90, True)
    learnt_frame = aerofid.orient_frame(folder / "a.tif", CAMERA)
    assert profile.polarity == learnt_frame.found[0].located.polarity
    assert profile.pixel_size_mm == pytest.approx(COARSE_MM, rel=1e-3)
    assert 1.5 < profile.mark_radius_mm < 2.5                   # the synthetic ring-and-cross marks: 4 mm across
    res = aerofid.orient_frame(folder / "b.tif", CAMERA, profile=profile)
    assert res.status == "ok", res.reasons
    assert res.pixel_size_source == "profile"
    marks = truths["b.tif"].marks
    err = [math.hypot(f.x - marks[f.name][0], f.y - marks[f.name][1]) for f in res.fiducials if f.x is not None]
    assert len(err) == 8 and max(err) < 0.1, err
    assert sum(f.method == profile.method for f in res.fiducials) >= 6


def test_the_next_frame_is_measured_in_the_roll_areas_without_screening(roll, learnt):
    """The profile keeps where a.tif's fiducials lay; b.tif (its film shifted up to 6 mm and turned up to 1 degree
    from a.tif's) is measured in the areas around them, nothing screened, at the marks the whole-frame search
    finds, each mark's window sized by its own learnt radius; a profile without positions (an earlier aerofid's)
    searches the whole frame."""
    folder, truths = roll
    assert [n for n, _, _ in learnt.positions_px] == [f.name for f in CAMERA.fiducials]
    radii = dict(learnt.mark_radii_mm)
    assert sorted(radii) == sorted(f.name for f in CAMERA.fiducials)
    assert learnt.mark_radius_mm == pytest.approx(float(np.median(list(radii.values()))))
    assert sorted(n for n, _ in learnt.mark_templates) == sorted(radii)
    assert RollProfile.from_dict(learnt.to_dict()) == learnt
    res = aerofid.orient_frame(folder / "b.tif", CAMERA, profile=learnt)
    assert (res.status, res.searched, res.features) == ("ok", "roll areas", 0), res.reasons
    old = {k: v for k, v in learnt.to_dict().items() if k != "positions_px"}
    whole = aerofid.orient_frame(folder / "b.tif", CAMERA, profile=RollProfile.from_dict(old))
    assert (whole.status, whole.searched) == ("ok", "whole frame") and whole.features > 0
    # each mark's window sized by its own learnt radius (the whole frame's: the marks' median): within 0.05 px
    apart = [math.hypot(f.x - g.x, f.y - g.y) for f, g in zip(res.fiducials, whole.fiducials, strict=True)]
    assert max(apart) < 0.05, apart
    marks = truths["b.tif"].marks
    assert max(math.hypot(f.x - marks[f.name][0], f.y - marks[f.name][1]) for f in res.fiducials) < 0.1
    assert "marks sought in the roll areas" in frame_text(res)
    assert res.to_dict()["screening"]["searched"] == "roll areas"


def test_the_first_marks_are_sought_where_their_templates_correlate(roll, learnt, monkeypatch):
    """b.tif's first marks are sought where their learnt templates correlate best (above 0.9); templates that
    correlate nowhere (another mark's look, here noise), or none (an earlier profile), leave the search to the
    method: the same marks, the same centres."""
    folder, truths = roll
    marks = truths["b.tif"].marks
    places = []
    real = marks_module.match_template

    def recorded(area, template):
        got = real(area, template)
        places.append(got)
        return got

    monkeypatch.setattr(marks_module, "match_template", recorded)
    res = aerofid.orient_frame(folder / "b.tif", CAMERA, profile=learnt)
    monkeypatch.undo()
    assert (res.status, res.searched) == ("ok", "roll areas"), res.reasons
    assert places and all(p is not None and p[2] > 0.9 for p in places), places
    # where the templates placed the first marks: within a pixel of each
    starts = []
    real_matched = marks_module._matched
    monkeypatch.setattr(marks_module, "_matched", lambda *a: starts.append(got := real_matched(*a)) or got)
    aerofid.orient_frame(folder / "b.tif", CAMERA, profile=learnt)
    monkeypatch.undo()
    assert len(starts) == len(places)
    near = [min(math.hypot(c.x - x, c.y - y) for x, y in marks.values()) for c in starts]
    assert max(near) < 1.0, near
    rng = np.random.default_rng(0)
    noise = tuple((n, replace(t, levels=rng.integers(0, 256, len(t.levels), np.uint8).tobytes()))
                  for n, t in learnt.mark_templates)
    nowhere = []
    monkeypatch.setattr(marks_module, "match_template", lambda area, t: nowhere.append(real(area, t)) or nowhere[-1])
    aerofid.orient_frame(folder / "b.tif", CAMERA, profile=replace(learnt, mark_templates=noise))
    monkeypatch.undo()
    assert nowhere and all(p is None for p in nowhere)
    for templates in (noise, ()):
        again = aerofid.orient_frame(folder / "b.tif", CAMERA, profile=replace(learnt, mark_templates=templates))
        assert (again.status, again.searched) == ("ok", "roll areas"), again.reasons
        apart = [math.hypot(f.x - g.x, f.y - g.y) for f, g in zip(res.fiducials, again.fiducials, strict=True)]
        assert max(apart) < 0.01, apart
    assert max(math.hypot(f.x - marks[f.name][0], f.y - marks[f.name][1]) for f in res.fiducials) < 0.1


def test_a_frame_whose_film_lies_beyond_the_roll_areas_is_searched_whole(roll, learnt):
    """b.tif's scan widened by 500 px on the left: its film lies 250 px (20 mm) off the place the profile's
    positions give it from the scan's centre, beyond ROLL_SHIFT_MM, and the whole frame is searched."""
    folder, truths = roll
    image = tifffile.imread(folder / "b.tif")
    res = aerofid.orient_frame(np.pad(image, ((0, 0), (500, 0)), mode="edge"), CAMERA, profile=learnt)
    assert (res.status, res.searched) == ("ok", "whole frame"), res.reasons
    marks = truths["b.tif"].marks
    assert max(math.hypot(f.x - 500 - marks[f.name][0], f.y - marks[f.name][1]) for f in res.fiducials) < 0.1


@pytest.mark.parametrize("moved", ["off the scan", "all at one place", "far away"])
def test_positions_that_do_not_fit_the_scan_leave_the_whole_frame_to_search(roll, learnt, moved):
    """Positions learnt on a scan whose film lay 2000 px to the right (some now predicted off this scan), a
    profile edited to put every fiducial at one place or 1e300 px away: no error, the whole frame searched, ok."""
    folder, truths = roll
    positions = {"off the scan": tuple((n, dx + 2000.0, dy) for n, dx, dy in learnt.positions_px),
                 "all at one place": tuple((n, 5.0, 5.0) for n, _, _ in learnt.positions_px),
                 "far away": tuple((n, dx * 1e300, dy) for n, dx, dy in learnt.positions_px)}[moved]
    res = aerofid.orient_frame(folder / "b.tif", CAMERA, profile=replace(learnt, positions_px=positions))
    assert (res.status, res.searched) == ("ok", "whole frame"), res.reasons
    marks = truths["b.tif"].marks
    assert max(math.hypot(f.x - marks[f.name][0], f.y - marks[f.name][1]) for f in res.fiducials) < 0.1


def test_a_wrong_pixel_size_with_a_profile_gives_an_answer_not_an_error(roll, learnt):
    """--pixel-size twice the scan's: the profile's positions are predicted twice as far from the centre (off the
    scan): the frame is judged (not ok, with the reasons), never an exception."""
    folder, _ = roll
    res = aerofid.orient_frame(folder / "b.tif", CAMERA, profile=learnt, pixel_size_mm=2 * COARSE_MM)
    assert res.status in ("doubtful", "failed") and res.reasons


def test_a_frame_that_disagrees_with_the_profile_is_flagged_for_review(roll, learnt):
    folder, _ = roll
    res = aerofid.orient_frame(folder / "c.tif", CAMERA, profile=learnt)
    assert res.status == "doubtful"
    assert any(r.startswith("review: the film lies rotated 180 deg") for r in res.reasons), res.reasons
    assert (res.rotation_deg, res.mirrored) == (180, False)     # the answer is still the frame's own lie


def test_the_profile_settles_the_lie_a_symmetric_layout_leaves_open():
    nominal = Camera.from_dict({"name": "nominal", "fiducials": {
        f.name: [round(f.x_mm), round(f.y_mm)] for f in CAMERA.fiducials}})
    image = render_frame(frame_spec(CAMERA, COARSE_MM, np.random.default_rng(3)))
    assert aerofid.orient_frame(image, nominal, pixel_size_mm=COARSE_MM).status == "doubtful"
    profile = RollProfile(camera="nominal", pixel_size_mm=COARSE_MM, rotation_deg=0, mirrored=False,
                          polarity="bright", method="symmetry", mark_radius_mm=2.0)
    res = aerofid.orient_frame(image, nominal, profile=profile)
    assert res.status == "ok", res.reasons
    assert (res.rotation_deg, res.mirrored) == (0, False)


def test_learning_from_a_doubtful_frame_writes_nothing(tmp_path):
    nominal = {"name": "nominal", "fiducials": {f.name: [round(f.x_mm), round(f.y_mm)] for f in CAMERA.fiducials}}
    (tmp_path / "cam.json").write_text(json.dumps(nominal))
    write_frame(frame_spec(CAMERA, COARSE_MM, np.random.default_rng(3)), tmp_path / "f.tif", "tiled")
    r = _cli("learn", "f.tif", "--camera", "cam.json", "-o", "roll.json", cwd=tmp_path)
    assert r.returncode == 1
    assert "lie cannot be told" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "roll.json").exists()


@pytest.mark.parametrize(("text", "message"), [
    ('{"camera": "x"}', "not a roll profile"),
    ('{"format": "aerofid-roll-profile", "version": 99}', "version 99"),
    ('{"format": "aerofid-roll-profile", "version": 1, "camera": "c", "pixel_size_mm": 0.02, '
     '"lie": {"rotation_deg": 45, "mirrored": false}, "polarity": "bright", "method": "symmetry", '
     '"mark_radius_mm": 2}', "lie"),
    ('{"format": "aerofid-roll-profile", "version": 1, "camera": "c", "pixel_size_mm": "big", '
     '"lie": {"rotation_deg": 0, "mirrored": false}, "polarity": "bright", "method": "symmetry", '
     '"mark_radius_mm": 2}', "mistypes"),
    ('{"format": "aerofid-roll-profile", "version": 1, "camera": "c", "pixel_size_mm": 0.02, '
     '"lie": {"rotation_deg": 0, "mirrored": false}, "polarity": "bright", "method": "symmetry", '
     '"mark_radius_mm": 2, "positions_px": {"1": [10.0]}}', "mistypes"),
    ('{"format": "aerofid-roll-profile", "version": 1, "camera": "c", "pixel_size_mm": 0.02, '
     '"lie": {"rotation_deg": 0, "mirrored": false}, "polarity": "bright", "method": "symmetry", '
     '"mark_radius_mm": 2, "mark_radii_mm": {"1": -2.0}}', "positive sizes"),
    ('{"format": "aerofid-roll-profile", "version": 1, "camera": "c", "pixel_size_mm": 0.02, '
     '"lie": {"rotation_deg": 0, "mirrored": false}, "polarity": "bright", "method": "symmetry", '
     '"mark_radius_mm": 2, "mark_templates": {"1": [1, 2]}}', "roll.json: a mark template must hold"),
    ('{"format": "aerofid-roll-profile", "version": 1, "camera": "c", "pixel_size_mm": 0.02, '
     '"lie": {"rotation_deg": 0, "mirrored": false}, "polarity": "bright", "method": "symmetry", '
     '"mark_radius_mm": 2, "mark_templates": {"1": {"factor": 1, "shape": [3, 3], "centre": [1, 1], '
     '"levels": "AAAA"}}}', "roll.json: template levels do not fill its shape"),
    ('{"format": "aerofid-roll-profile", "version": 1, "camera": "c", "pixel_size_mm": 0.02, '
     '"lie": {"rotation_deg": 0, "mirrored": false}, "polarity": "bright", "method": "symmetry", '
     '"mark_radius_mm": 2, "mark_templates": {"1": {"factor": 1, "shape": ["a", 3], "centre": [1, 1], '
     '"levels": "AAAA"}}}', "roll.json: template shape"),
])
def test_a_bad_profile_is_one_line(tmp_path, text, message):
    (tmp_path / "roll.json").write_text(text)
    with pytest.raises(AerofidInputError, match=message):
        read_profile(tmp_path / "roll.json")


def test_the_cli_refuses_a_profile_of_another_camera(roll, tmp_path):
    folder, _ = roll
    other = RollProfile(camera="another", pixel_size_mm=COARSE_MM, rotation_deg=0, mirrored=False,
                        polarity="bright", method="symmetry", mark_radius_mm=2.0)
    (tmp_path / "roll.json").write_text(json.dumps(other.to_dict()))
    r = _cli("orient", folder / "b.tif", "--camera", folder / "cam.json", "--profile", tmp_path / "roll.json",
             "-o", tmp_path / "r.json", cwd=tmp_path)
    assert r.returncode == 2
    assert r.stderr.startswith("error:") and "learnt with camera 'another'" in r.stderr
    assert not (tmp_path / "r.json").exists()


def test_a_profile_is_learnt_from_marks_measured_by_hand(roll):
    """The measurements give the lie and the pixel size (a symmetric layout needs no --lie) and the marks found
    must agree with them: clicks 1 px off agree, names swapped do not."""
    folder, truths = roll
    rng = np.random.default_rng(2)
    clicks = {n: (x + rng.uniform(-1, 1), y + rng.uniform(-1, 1)) for n, (x, y) in truths["a.tif"].marks.items()}
    nominal = {"name": CAMERA.name, "fiducials": {f.name: [round(f.x_mm), round(f.y_mm)] for f in CAMERA.fiducials}}
    (folder / "nominal.json").write_text(json.dumps(nominal))
    (folder / "clicks.csv").write_text("name,x,y\n" + "".join(f"{n},{x},{y}\n" for n, (x, y) in clicks.items()))
    r = _cli("learn", "a.tif", "--camera", "nominal.json", "-m", "clicks.csv", "-o", "hand.json", cwd=folder)
    assert r.returncode == 0, r.stderr
    profile = read_profile(folder / "hand.json")
    assert (profile.rotation_deg, profile.mirrored) == (90, True)
    assert profile.pixel_size_mm == pytest.approx(COARSE_MM, rel=0.01)
    swapped = dict(clicks, **{"1": clicks["3"], "3": clicks["1"]})
    (folder / "swapped.csv").write_text("name,x,y\n" + "".join(f"{n},{x},{y}\n" for n, (x, y) in swapped.items()))
    r = _cli("learn", "a.tif", "--camera", "nominal.json", "-m", "swapped.csv", "-o", "bad.json", cwd=folder)
    assert r.returncode in (1, 2) and r.stderr.startswith("error:") and len(r.stderr.strip().splitlines()) == 1
    assert not (folder / "bad.json").exists()
