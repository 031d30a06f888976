"""`aerofid batch`: a roll of synthetic frames with known marks, corrupt frames among them, a batch killed and
resumed, local processes and a real Dask cluster (scheduler and two workers on 127.0.0.1) giving the same
results as one process."""

from __future__ import annotations

import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import tifffile
from click.testing import CliRunner

from aerofid.batch import runners
from aerofid.batch.driver import plan_batch
from aerofid.batch.inputs import expand_inputs, frame_keys
from aerofid.batch.job import FrameRecord, run_frame_job
from aerofid.batch.plan import batch_settings, frame_outputs, read_complete
from aerofid.cli import batch_cmd, main
from aerofid.errors import AerofidInputError
from aerofid.formats.camera_file import write_camera
from aerofid.synth_frame import frame_spec, wild_rc10_camera, write_frame

CAMERA = wild_rc10_camera()
PIXEL_MM = 0.2
"""1250 x 1250 px frames: 2-4 s each through orient_frame."""
GOOD = {"a.tif": (1, 0, False), "b.tif": (2, 90, True), "c.tif": (3, 180, False)}
"""The good frames: seed, rotation, mirrored."""
BAD = ("d_truncated.tif", "e_text.tif")
TRUTH_PX = 0.1
"""How far a found mark may lie from its true centre (the frame tests' bound, test_frame.py)."""


@pytest.fixture(scope="module")
def roll(tmp_path_factory):
    """A folder of three good frames, a truncated TIFF and a text file named .tif; the camera file; the truth."""
    root = tmp_path_factory.mktemp("roll")
    scans = root / "scans"
    scans.mkdir()
    truth = {}
    for name, (seed, rot, mir) in GOOD.items():
        spec = frame_spec(CAMERA, PIXEL_MM, np.random.default_rng(seed), rotation_deg=rot, mirrored=mir)
        truth[name] = write_frame(spec, scans / name, "tiled").marks
    whole = (scans / "a.tif").read_bytes()
    (scans / BAD[0]).write_bytes(whole[: len(whole) // 3])
    (scans / BAD[1]).write_text("not a scan\n")
    cam = root / "camera.json"
    write_camera(cam, CAMERA)
    return scans, cam, truth


def batch(*args, cwd=None, timeout=300):
    return subprocess.run([sys.executable, "-m", "aerofid.cli", "batch", *map(str, args)], capture_output=True,
                          text=True, cwd=cwd, timeout=timeout)


def results(outdir: Path) -> dict[str, dict]:
    """Every frame's record in the summary and its JSON document, without the times (which differ by run)."""
    summary = json.loads((outdir / "summary.json").read_text())
    out = {}
    for rec in summary["frames"]:
        rec.pop("seconds")
        doc = None
        if rec["status"] != "error":
            doc = json.loads((outdir / frame_outputs(rec["frame"], "affine").json).read_text())
            doc["batch"].pop("seconds")
        out[rec["frame"]] = {"record": rec, "document": doc}
    return out


@pytest.fixture(scope="module")
def sequential(roll, tmp_path_factory):
    """The roll run in one process: (completed process, output folder)."""
    scans, cam, _ = roll
    out = tmp_path_factory.mktemp("seq") / "out"
    r = batch(scans, "--camera", cam, "-o", out)
    assert (out / "summary.json").is_file(), r.stderr
    return r, out


def test_a_batch_with_corrupt_frames_finishes_every_good_frame_and_reports_every_bad_one(roll, sequential):
    _, _, truth = roll
    r, out = sequential
    assert r.returncode == 1, r.stderr                                  # a frame not ok: exit 1
    assert "Traceback" not in r.stderr
    assert r.stdout.strip().startswith("5 frames: 3 ok, 0 doubtful, 0 failed, 2 error")
    got = results(out)
    assert list(got) == sorted(list(GOOD) + list(BAD))
    for name, marks in truth.items():
        doc = got[name]["document"]
        assert got[name]["record"]["status"] == "ok" and doc["status"] == "ok"
        found = {f["name"]: f for f in doc["fiducials"] if f["x"] is not None}
        assert len(found) >= 6
        err = [math.hypot(f["x"] - marks[n][0], f["y"] - marks[n][1]) for n, f in found.items()]
        assert max(err) < TRUTH_PX, err
        o = frame_outputs(name, "affine")
        for rel in (o.html, o.crops, o.measures_im, o.affine_plane):
            assert (out / rel).is_file(), rel
    truncated, text = got[BAD[0]]["record"], got[BAD[1]]["record"]
    assert truncated["status"] == text["status"] == "error"
    assert "corrupt or truncated" in truncated["error"] and "not a supported image format" in text["error"]
    for rec in (truncated, text):                                       # one line each, no outputs
        assert "\n" not in rec["error"]
        assert not list(out.glob(f"{rec['frame']}*"))
        assert f"note: {rec['frame']}: error: {rec['error']}" in r.stderr
    # stderr is not a terminal: one log line per frame
    assert sum(line.startswith("frame ") for line in r.stderr.splitlines()) == 5
    assert (out / "Ori-InterneScan" / "MeasuresCamera.xml").is_file()
    rows = (out / "summary.csv").read_text().splitlines()
    assert rows[0].startswith("frame,path,status,rms_px") and len(rows) == 6


def test_the_summary_gallery_shows_every_mark_worst_frames_first(sequential):
    _, out = sequential
    page = (out / "summary.html").read_text()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["statistics"]["counts"] == {"error": 2, "failed": 0, "doubtful": 0, "ok": 3}
    assert summary["planned"] == 5 and "<h1>5 frames: " in page            # all done
    assert summary["statistics"]["residual_px"]["n"] >= 18
    frames = summary["frames"]
    marks = sum(len(f["marks"]) for f in frames)
    assert page.count('loading="lazy"') == marks == 24                  # every mark of the 3 good frames
    worst_ok = min((f for f in frames if f["status"] == "ok"),         # most marks not used, then largest RMS
                   key=lambda f: (-sum(m["status"] != "found" for m in f["marks"]), -f["rms_px"]))["frame"]
    table = page[page.index("Frames, worst first"):]
    assert table.index(BAD[0]) < table.index(worst_ok)                  # errors before any ok frame
    gallery = page[page.index("Every mark"):]
    firsts = [gallery.index(f"<h3 class=\"ok\">{f['frame']}") for f in frames if f["status"] == "ok"]
    assert min(firsts) == gallery.index(f'<h3 class="ok">{worst_ok}')


def test_a_batch_killed_part_way_resumes_and_redoes_only_what_is_incomplete(roll, tmp_path):
    scans, cam, _ = roll
    good = tmp_path / "good"
    good.mkdir()
    for name in GOOD:
        shutil.copy2(scans / name, good / name)
    out = tmp_path / "out"
    p = subprocess.Popen([sys.executable, "-m", "aerofid.cli", "batch", str(good), "--camera", str(cam), "-o",
                          str(out)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    second = out / frame_outputs("b.tif", "affine").json                # frames run in order: a, b, c
    deadline = time.monotonic() + 120
    while not second.exists() and time.monotonic() < deadline and p.poll() is None:
        time.sleep(0.05)
    p.send_signal(signal.SIGKILL)
    p.wait()
    assert second.exists()
    done = {n: (out / frame_outputs(n, "affine").json).stat().st_mtime_ns
            for n in GOOD if (out / frame_outputs(n, "affine").json).exists()}
    assert len(done) < len(GOOD)                                        # killed part-way
    summary = json.loads((out / "summary.json").read_text())
    assert summary["settings"]["model"] == "affine" and summary["planned"] == 3          # a whole summary
    assert f"{len(summary['frames'])} of 3 frames done" in (out / "summary.html").read_text()  # not the whole batch
    os.remove(out / frame_outputs("a.tif", "affine").html)             # one frame made incomplete
    (out / ".c.tif.json.aerofid-999999-x.tmp").write_text("{")         # a killed run's temporary file
    r = batch(good, "--camera", cam, "-o", out)
    assert r.returncode == 0, r.stderr
    assert f"{len(done) - 1} of 3 frames are complete" in r.stderr
    for name in GOOD:
        mtime = (out / frame_outputs(name, "affine").json).stat().st_mtime_ns
        assert (mtime == done.get(name)) == (name in done and name != "a.tif"), name
    assert all(v["record"]["status"] == "ok" for v in results(out).values()) and len(results(out)) == 3
    assert not list(out.glob(".*.tmp"))
    again = batch(good, "--camera", cam, "-o", out)                     # all complete: nothing redone
    assert again.returncode == 0 and "3 of 3 frames are complete" in again.stderr
    assert again.stdout.startswith("3 frames: 3 ok")


def test_a_frame_is_complete_only_with_the_same_settings_and_scan(roll, sequential):
    scans, cam, _ = roll
    _, out = sequential
    path = str(scans / "a.tif")
    same = batch_settings(CAMERA, cam, out)
    assert read_complete(path, "a.tif", same) is not None
    assert read_complete(path, "a.tif", batch_settings(CAMERA, cam, out, model="similarity")) is None
    assert read_complete(path, "a.tif", batch_settings(CAMERA, cam, out, lie=(0, False))) is None
    assert read_complete(str(scans / BAD[0]), BAD[0], same) is None


def test_local_processes_give_the_sequential_results(roll, sequential, tmp_path):
    scans, cam, _ = roll
    r, out = batch(scans, "--camera", cam, "-o", tmp_path / "out", "--workers", "2"), tmp_path / "out"
    assert r.returncode == 1, r.stderr
    assert results(out) == results(sequential[1])


def _dies(path, frame, settings):
    """A frame job for the pool tests: ``kill*`` frames end their worker every time, ``once*`` the first time only
    (a file beside ``path`` remembers it), after 0.3 s (1 s if ``slow`` is in the name); ``quick*`` frames return at
    once, the others after 0.2 s, so that they are in flight when one dies."""
    if frame.startswith("kill") or (frame.startswith("once") and not os.path.exists(path + ".died")):
        Path(path + ".died").touch()
        time.sleep(1.0 if "slow" in frame else 0.3)
        os.kill(os.getpid(), signal.SIGKILL)
    if not frame.startswith("quick"):
        time.sleep(0.2)
    return FrameRecord(frame, path, "ok")


def test_a_worker_killed_costs_only_the_frame_that_kills_it(tmp_path):
    frames = ("a", "kill", "b", "once", "c", "d", "kill2", "e")
    tasks = [(str(tmp_path / f), f) for f in frames]
    settings = batch_settings(CAMERA, tmp_path / "camera.json", tmp_path / "out")
    records = list(runners.process_runner(2, _dies)(tasks, settings))
    assert sorted(r.frame for r in records) == sorted(frames)          # every frame once
    bad = {r.frame: r.error for r in records if r.status != "ok"}
    assert sorted(bad) == ["kill", "kill2"]                           # the frames caught with them are done again
    assert all(runners.LOST_ALONE in e for e in bad.values())


def test_a_worker_that_dies_while_the_records_are_read_costs_no_frame(tmp_path):
    """The pool broke while the batch was busy with a record (writing the summary): the next frame's submission
    raised BrokenProcessPool out of the runner, and the batch stopped with no record of the rest (a review)."""
    frames = ("quick", "once_slow", "c", "d")
    tasks = [(str(tmp_path / f), f) for f in frames]
    settings = batch_settings(CAMERA, tmp_path / "camera.json", tmp_path / "out")
    records = []
    for rec in runners.process_runner(2, _dies)(tasks, settings):
        records.append(rec)
        if len(records) == 1:
            time.sleep(2.0)                                              # meanwhile once_slow's worker dies
    assert sorted(r.frame for r in records) == sorted(frames) and all(r.status == "ok" for r in records)


def test_bad_input_is_one_line_and_exit_2_before_any_work(roll, tmp_path):
    scans, cam, _ = roll
    (tmp_path / "empty").mkdir()
    bad_cam = tmp_path / "bad.json"
    bad_cam.write_text("{")
    blocker = tmp_path / "file"
    blocker.write_text("")
    cases = [((tmp_path / "empty", "--camera", cam, "-o", tmp_path / "o1"), "no scan"),
             ((scans / "*.png", "--camera", cam, "-o", tmp_path / "o2"), "no scan"),
             ((scans, "--camera", bad_cam, "-o", tmp_path / "o3"), "bad.json"),
             ((scans, "--camera", cam, "-o", blocker / "out"), "cannot create output folder"),
             ((scans, "--camera", cam, "-o", tmp_path / "o4", "--workers", "2", "--scheduler", "tcp://x:1"),
              "not both"),
             ((scans, "--camera", cam, "-o", tmp_path / "o5", "--lie", "45"), "--lie")]
    for args, words in cases:
        r = CliRunner().invoke(main, ["batch", *map(str, args)])            # in this process: no start-up
        assert r.exit_code == 2, (args, r.stderr)
        assert r.stderr.startswith("error: ") and words in r.stderr and len(r.stderr.splitlines()) == 1, r.stderr
    assert not any((tmp_path / f"o{i}").exists() for i in range(1, 6))


def test_inputs_expand_to_sorted_unique_scans_and_outputs_never_collide(tmp_path):
    for rel in ("r1/x.TIF", "r1/y.jpeg", "r1/notes.txt", "r1/.x.tif.aerofid-1-a.tmp.tif", "r2/x.tif",
                "r2/sub/z.png", "r2/out/crops/x.tif.png", "r2/out/resampled/OIS-Reech_x.tif"):
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_bytes(b"")
    out = tmp_path / "r2" / "out"      # the batch's crops and resampled frames are no input (they were read back)
    paths = expand_inputs([str(tmp_path / "r1"), str(tmp_path / "r1" / "x.TIF"), str(tmp_path / "r2" / "**")],
                          exclude=[out / "crops", out / "resampled"])
    assert [p.relative_to(tmp_path).as_posix() for p in paths] == ["r1/x.TIF", "r1/y.jpeg", "r2/sub/z.png",
                                                                   "r2/x.tif"]
    assert frame_keys(paths) == ("r1__x.TIF", "y.jpeg", "z.png", "r2__x.tif")
    (tmp_path / "link.tif").symlink_to(tmp_path / "r1" / "y.jpeg")
    assert expand_inputs([str(tmp_path / "link.tif"), str(tmp_path / "r1" / "y.jpeg")]) == (tmp_path / "link.tif",)
    with pytest.raises(AerofidInputError, match="no scan .* 'nowhere/\\*.tif'"):
        expand_inputs([str(tmp_path / "r1"), "nowhere/*.tif"])


def test_a_frame_done_again_leaves_none_of_its_earlier_outputs(roll, tmp_path):
    """A frame done again (its scan replaced, other settings) had its earlier outputs that the new run does not write
    left beside its new ones: an affine run's AffinePlane beside a projective run's JSON; a good scan's MicMac files
    beside the failed frame of the blank one that replaced it (a helper's audit)."""
    scans, cam, _ = roll
    (tmp_path / "in").mkdir()
    (tmp_path / "in" / "a.tif").write_bytes((scans / "a.tif").read_bytes())
    out = tmp_path / "out"
    plane = out / frame_outputs("a.tif", "affine").affine_plane
    assert batch(tmp_path / "in", "--camera", cam, "-o", out).returncode == 0 and plane.exists()
    assert batch(tmp_path / "in", "--camera", cam, "-o", out, "--model", "projective").returncode == 0
    assert not plane.exists() and (out / frame_outputs("a.tif", "projective").measures_im).exists()
    tifffile.imwrite(tmp_path / "in" / "a.tif", np.full((800, 800), 90, np.uint8))     # a blank frame
    assert batch(tmp_path / "in", "--camera", cam, "-o", out, "--model", "projective").returncode == 1
    assert json.loads((out / "a.tif.json").read_text())["status"] == "failed"
    assert not (out / frame_outputs("a.tif", "projective").measures_im).exists()


def test_an_interrupted_command_says_to_run_it_again(roll, tmp_path, monkeypatch):
    """Ctrl-C: one line that says what it means for the outputs and what to do ("error: aborted" said neither: a
    helper's audit), status 2."""

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    scans, cam, _ = roll
    monkeypatch.setattr(batch_cmd, "plan_batch", interrupted)
    r = CliRunner().invoke(main, ["batch", str(scans / "a.tif"), "--camera", str(cam), "-o", str(tmp_path / "o")])
    assert r.exit_code == 2 and r.stderr.strip().endswith(
        "error: interrupted: what was not finished is not written; run the command again (a batch resumes, its "
        "complete frames kept)"), r.stderr


def test_scans_whose_resampled_frames_would_share_a_name_are_refused_before_any_work(tmp_path):
    """ReSampFid's name drops the scan's ending: ``a.tif`` and ``a.TIFF`` were both resampled to
    ``OIS-Reech_a.tif``, the second over the first (a helper's audit). Refused when resampling, in one line."""
    cam = tmp_path / "cam.json"
    write_camera(cam, CAMERA)
    for name in ("a.tif", "a.TIFF", "b.jpg"):
        (tmp_path / "roll" / name).parent.mkdir(exist_ok=True)
        (tmp_path / "roll" / name).write_bytes(b"")
    inputs = [str(tmp_path / "roll")]
    assert len(plan_batch(inputs, cam, tmp_path / "out").frames) == 3            # not resampled: no clash
    with pytest.raises(AerofidInputError, match="'a.TIFF' and 'a.tif' would share the resampled frame "
                                                "'resampled/OIS-Reech_a.tif'"):
        plan_batch(inputs, cam, tmp_path / "out", resample_mm=0.1)


def test_a_job_never_raises_and_scheduler_without_dask_is_one_error(tmp_path, monkeypatch):
    cam = tmp_path / "cam.json"
    write_camera(cam, CAMERA)
    rec = run_frame_job(str(tmp_path / "missing.tif"), "missing.tif", batch_settings(CAMERA, cam, tmp_path))
    assert rec.status == "error" and "missing.tif: No such file" in rec.error
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(AerofidInputError, match=r"--scheduler needs Dask.*aerofid\[cluster\]"):
        with runners.open_runner(scheduler="tcp://127.0.0.1:1"):
            pass


@pytest.fixture
def dask_cluster(tmp_path):
    """A real Dask scheduler and two single-threaded workers on 127.0.0.1; its address; all ended after."""
    pytest.importorskip("distributed")
    with runners.local_cluster(tmp_path, workers=2) as address:
        yield address


def test_a_dask_cluster_gives_the_local_results(roll, sequential, dask_cluster, tmp_path):
    scans, cam, _ = roll
    out = tmp_path / "out"
    r = batch(scans, "--camera", cam, "-o", out, "--scheduler", dask_cluster)
    assert r.returncode == 1, r.stderr
    assert results(out) == results(sequential[1])


def test_a_batch_with_a_roll_profile_uses_it_and_flags_the_frames_that_disagree(roll, tmp_path):
    """--profile: the frames are measured with the profile learnt from frame a (lie 0); frame b, scanned at 90
    degrees mirrored, is doubtful for review; the profile's content is in the settings' fingerprint, so a batch
    with another profile redoes the frames."""
    scans, cam, truth = roll
    learnt = subprocess.run([sys.executable, "-m", "aerofid", "learn", scans / "a.tif", "--camera", cam, "-o",
                             tmp_path / "roll.json"], capture_output=True, text=True)
    assert learnt.returncode == 0, learnt.stderr
    out = tmp_path / "out"
    r = batch(scans / "a.tif", scans / "b.tif", "--camera", cam, "--profile", tmp_path / "roll.json", "-o", out)
    assert r.returncode == 1, r.stderr                                  # b is doubtful: exit 1
    got = results(out)
    a, b = got["a.tif"]["document"], got["b.tif"]["document"]
    assert a["status"] == "ok" and a["pixel_size_source"] == "profile"
    err = [math.hypot(f["x"] - truth["a.tif"][f["name"]][0], f["y"] - truth["a.tif"][f["name"]][1])
           for f in a["fiducials"] if f["x"] is not None]
    assert len(err) >= 6 and max(err) < TRUTH_PX
    assert b["status"] == "doubtful" and any(x.startswith("review: the film lies") for x in b["reasons"])
    profile = json.loads((tmp_path / "roll.json").read_text())
    profile["lie"] = {"rotation_deg": 180, "mirrored": False}          # another profile: another fingerprint
    (tmp_path / "roll2.json").write_text(json.dumps(profile))
    again = batch(scans / "a.tif", "--camera", cam, "--profile", tmp_path / "roll2.json", "-o", out)
    assert "complete" not in again.stderr                               # nothing skipped
    assert any(x.startswith("review: the film lies") for x in results(out)["a.tif"]["document"]["reasons"])


def test_a_batch_resamples_the_frames_oriented_ok_and_a_rerun_skips_them(roll, tmp_path):
    """--resample MM: each frame oriented ok also gives resampled/OIS-Reech_<scan>.tif and its pixel -> mm sidecar,
    listed among the frame's outputs (a rerun finds the frame complete); a frame that is not ok is not resampled."""
    scans, cam, _ = roll
    out = tmp_path / "out"
    r = batch(scans / "a.tif", scans / "e_text.tif", "--camera", cam, "--resample", "0.2", "-o", out)
    assert r.returncode == 1, r.stderr                                  # e_text.tif is an error
    image, side = out / "resampled" / "OIS-Reech_a.tif", out / "resampled" / "OIS-Reech_a.px2mm.json"
    assert image.is_file() and side.is_file()
    doc = json.loads((out / "a.tif.json").read_text())
    assert {"resampled/OIS-Reech_a.tif", "resampled/OIS-Reech_a.px2mm.json"} <= set(doc["batch"]["outputs"])
    grid = json.loads(side.read_text())
    assert grid                                                         # the resampled frame describes itself
    assert sorted(p.name for p in (out / "resampled").iterdir()) == ["OIS-Reech_a.px2mm.json", "OIS-Reech_a.tif"]
    again = batch(scans / "a.tif", "--camera", cam, "--resample", "0.2", "-o", out)
    assert again.returncode == 0 and "1 of 1 frames are complete" in again.stderr, again.stderr
    r = batch(scans / "a.tif", "--camera", cam, "--resample", "2", "-o", tmp_path / "bad")
    assert r.returncode == 2 and "--resample" in r.stderr and not (tmp_path / "bad").exists()


def test_a_batch_with_metashape_writes_one_script_of_the_frames_oriented_ok(roll, sequential, tmp_path):
    """--metashape: OUTDIR/metashape_fiducials.py places every frame oriented ok (its used fiducials at their found
    pixel positions, within the frame tests' bound of the truth) and lists the frames left out; a rerun that skips
    the complete frames writes the same script; without the flag there is none."""
    scans, cam, truth = roll
    out = tmp_path / "out"
    r = batch(scans / "a.tif", scans / "b.tif", scans / "e_text.tif", "--camera", cam, "--metashape", "-o", out)
    assert r.returncode == 1, r.stderr                                  # e_text.tif is an error
    text = (out / "metashape_fiducials.py").read_text()
    compile(text, "metashape_fiducials.py", "exec")
    head = text[:text.index("\ndef place_fiducials")]                  # the constants and the data, not the run
    data: dict = {}
    exec(compile(head.replace("import Metashape\n", ""), "head", "exec"), data)
    frames = {f["label"]: f for f in data["DATA"]["frames"]}
    assert sorted(frames) == ["a", "b"] and data["PIXEL_OFFSET"] == 0.5
    for label, f in frames.items():
        marks = truth[f"{label}.tif"]
        assert len(f["fiducials_px"]) >= 6
        for name, (x, y) in f["fiducials_px"].items():
            assert math.hypot(x - marks[name][0], y - marks[name][1]) < TRUTH_PX
    assert [d["image"] for d in data["DATA"]["left_out"]] == ["e_text.tif"]
    assert data["DATA"]["left_out"][0]["reason"].startswith("error: ") and "#   e_text.tif: error: " in text
    again = batch(scans / "a.tif", scans / "b.tif", scans / "e_text.tif", "--camera", cam, "--metashape", "-o", out)
    assert "2 of 3 frames are complete" in again.stderr, again.stderr
    assert (out / "metashape_fiducials.py").read_text() == text
    assert not (sequential[1] / "metashape_fiducials.py").exists()
