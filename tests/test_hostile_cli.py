"""Issue 11, case by case through the real command line: outputs never destroy inputs or special files, a failed
command writes nothing, every input is checked before work, third-party chatter stays off stderr, and every
ending has its documented exit status with one ``error:`` line. The commands run in forked children of this
process (tests/fuzz_cli.py) with real file descriptors, an address-space limit and a time limit; two run as a
fresh interpreter too."""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import pytest

from fuzz_cli import Case, judge, make_workspace, run_case, snapshot, warm_up

LIMIT = 2 * 2**30


@pytest.fixture(scope="module")
def ws(tmp_path_factory):
    workspace = make_workspace(tmp_path_factory.mktemp("ws"))
    warm_up(workspace, tmp_path_factory.mktemp("warm"))
    return workspace


@pytest.fixture
def run(ws, tmp_path):
    """Run one command in the workspace: (outcome, verdict); the verdict must be clean."""
    def go(*args: str, outputs: tuple[str, ...] = (), stdout: str = "file", status: int | None = 2):
        before = snapshot(ws.root)
        outcome = run_case(Case(args, outputs, stdout), ws, tmp_path, time_limit=30)
        after = snapshot(ws.root)
        verdict = judge(Case(args, outputs, stdout), outcome, before, after)
        assert verdict.ok, (verdict, outcome.stderr)
        if status is not None:
            assert outcome.status == status, outcome.stderr
        if status == 2:
            assert outcome.stderr.startswith("error: "), outcome.stderr
        for p in set(after) - set(before):  # leave the workspace as it was for the next test
            (ws.root / p).unlink()
        return outcome
    return go


BOX = ("--box", "40,40,120,120")


@pytest.mark.parametrize("target", ["good.tif", "link_to_good.png", "fifo.tif", "folder.json", "readonly.png",
                                    "null.png", "loop_a.json"])
@pytest.mark.parametrize("option", ["--overlay", "--plot", "-o"])
def test_locate_output_never_replaces_an_input_or_a_special_file(run, ws, target, option):
    if not (ws.root / target).exists() and not (ws.root / target).is_symlink():
        pytest.skip(f"{target} could not be made here (device nodes need root)")
    out = run("locate", "good.tif", *BOX, option, target, outputs=(target,))  # -o: refused for its suffix too
    assert target in out.stderr or ".json" in out.stderr


def test_orient_report_never_replaces_the_camera_or_the_measurements(run):
    for target in ("cam.json", "m.json"):
        out = run("orient", "--camera", "cam.json", "--measurements", "m.json", "-o", target, outputs=(target,))
        assert "is an input" in out.stderr


def test_one_failed_output_writes_none(run):
    out = run("locate", "good.tif", *BOX, "--overlay", "ok.png", "--plot", "/proc/aerofid-test/d.png",
              outputs=("ok.png", "/proc/aerofid-test/d.png"))
    assert "/proc/aerofid-test/d.png" in out.stderr
    run("orient", "--camera", "cam.json", "--measurements", "m.json", "-o", "r.html", "--micmac", "micmac_trap",
        outputs=("r.html", "micmac_trap/MeasuresIm-good.tif.xml", "micmac_trap/MeasuresCamera.xml",
                 "micmac_trap/good.tif-AffinePlane-px2mm.xml"))


def test_the_outputs_of_a_good_command_are_all_written(run, ws):
    run("orient", "--camera", "cam.json", "--measurements", "m.json", "-o", "r.html", "--micmac", "micmac",
        outputs=("r.html", "micmac/MeasuresIm-good.tif.xml", "micmac/MeasuresCamera.xml",
                 "micmac/good.tif-AffinePlane-px2mm.xml"), status=0)


def test_empty_output_path_is_one_line(run):
    out = run("locate", "good.tif", *BOX, "--overlay", "")
    assert "--overlay is empty" in out.stderr


@pytest.mark.parametrize("image", ["fifo.tif", "folder.json", "loop_a.json", "missing.tif"])
def test_special_or_missing_image_is_one_line(run, image):
    start = time.monotonic()
    run("locate", image, *BOX)
    assert time.monotonic() - start < 20  # a FIFO is never opened


@pytest.mark.parametrize(("name", "words"), [
    ("lie80k_tile.tif", "memory budget"), ("lie200k_tile.tif", "memory budget"), ("lie80k_strip.tif", "lie80k"),
    ("lie30k.jpg", "lie30k"), ("lie60k.jpg", "too large"), ("lie30k.png", "lie30k"), ("lie1e9.png", "lie1e9"),
    ("trunc.tif", "corrupt"), ("trunc_head.tif", "corrupt"), ("trunc.jpg", "corrupt"), ("trunc.png", "corrupt"),
    ("empty.tif", "empty"), ("text.tif", "not a supported"),
])
def test_corrupt_and_lying_images_are_one_line_in_bounded_memory(run, name, words):
    out = run("locate", name, *BOX)
    assert words in out.stderr
    assert out.max_rss_kb < 1_000_000  # kB: nothing near the declared gigabytes was allocated


@pytest.mark.parametrize(("camera", "measurements", "words"), [
    ("deep.json", "m.json", "nests deeper"), ("deep.yaml", "m.json", "nests deeper"),
    ("deep.xml", "m.json", "nests deeper"), ("cam.json", "deep.json", "nests deeper"),
    ("cam.json", "m_huge.json", "beyond any scan"), ("cam.json", "m_dup.json", "duplicate key"),
    ("cam_dup.json", "m.json", "duplicate key"), ("cam.json", "m_badrow.csv", "'a'"),
    ("folder.json", "m.json", "is a folder"), ("loop_a.json", "m.json", "symbolic-link loop"),
    ("cam.json", "fifo.tif", "FIFO"), ("binary.json", "m.json", "not valid JSON"),
])
def test_hostile_camera_and_measurements_are_one_line(run, camera, measurements, words):
    out = run("orient", "--camera", camera, "--measurements", measurements)
    assert words in out.stderr


@pytest.mark.parametrize(("method", "param", "words"), [
    ("lines", "theta_step=0", "theta_step"), ("lines", "rho_step=0", "rho_step"),
    ("hough", "theta_step=0.01", "theta_step"), ("circles", "canny_sigma=1e6", "canny_sigma"),
    ("circles", "max_radius=1e12", "max_radius"), ("symmetry", "enlarge=" + "1" + "0" * 400, "enlarge"),
    ("auto", "edge_margin=inf", "edge_margin"), ("symmetry", "smooth_sigma=1e12", "smooth_sigma"),
    ("auto", "mark=0", "--mark"), ("hough", "method=lines", "--method"),
])
def test_parameter_ranges_are_one_line(run, method, param, words):
    out = run("locate", "good.tif", *BOX, "--method", method, "--param", param)
    assert words in out.stderr


def test_stdout_closed_early_is_status_2_and_writes_nothing(run):
    out = run("locate", "good.tif", *BOX, "--overlay", "o.png", outputs=("o.png",), stdout="closed")
    assert "standard output" in out.stderr


def test_stdout_on_a_full_device_is_status_2_and_writes_nothing(run, ws):
    if ws.full_device is None:
        pytest.skip("a full device node cannot be made here (needs root)")
    out = run("orient", "--camera", "cam.json", "--measurements", "m.json", "-o", "r.json", outputs=("r.json",),
              stdout="full")
    assert "No space left" in out.stderr


def test_found_and_not_found_keep_stderr_clean(run):
    found = run("locate", "good.jpg", "--box", "60,60,100,100", status=0)
    assert found.stderr == ""
    missing = run("locate", "good.tif", "--box", "0,0,30,30", status=1)
    assert missing.stderr == ""


def test_stale_temporary_files_of_a_killed_run_are_swept(run, ws):
    pid = subprocess.Popen([sys.executable, "-c", "pass"])
    pid.wait()  # a process id that is gone
    stale = ws.root / f".r.json.aerofid-{pid.pid}-abc123.tmp"
    stale.write_text("half")
    other = ws.root / f".r.json.aerofid-{os.getpid()}-def456.tmp"  # this process is alive: kept
    other.write_text("mine")
    try:
        run("orient", "--camera", "cam.json", "--measurements", "m.json", "-o", "r.json",
            outputs=("r.json", stale.name), status=0)
        assert not stale.exists() and other.exists()
    finally:
        other.unlink()


def _limit_memory():
    resource.setrlimit(resource.RLIMIT_AS, (LIMIT, LIMIT))


def test_fresh_interpreter_under_a_memory_limit(ws):
    """The real console entry point, in a subprocess with a 2 GB address-space limit: a FIFO named like a scan
    and a TIFF declaring 80000^2 px are one line each, exit 2, quickly."""
    for image, words in (("fifo.tif", "FIFO"), ("lie80k_tile.tif", "memory budget")):
        start = time.monotonic()
        r = subprocess.run([sys.executable, "-m", "aerofid", "locate", image, *BOX], cwd=ws.root, capture_output=True,
                           text=True, timeout=60, preexec_fn=_limit_memory)
        assert r.returncode == 2, r.stderr
        assert r.stderr.startswith("error: ") and words in r.stderr and len(r.stderr.splitlines()) == 1
        assert time.monotonic() - start < 30
    assert Path(ws.root / "fifo.tif").is_fifo()


def test_a_decode_still_running_when_a_command_fails_says_nothing(tmp_path):
    """A JPEG's whole decode runs in a thread of its own; a command that fails before it ends waits for it with the
    libraries' chatter still kept off stderr (libjpeg warns of the 3 stray bytes here when it reaches them), so the
    one ``error:`` line stays the only one."""
    import cv2
    import numpy as np

    texture = np.random.default_rng(0).integers(0, 256, (1500, 1500), dtype=np.uint8)
    image = cv2.resize(texture, (15000, 15000), interpolation=cv2.INTER_LINEAR)   # 0.3-0.5 s to decode
    data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 90])[1].tobytes()
    path = tmp_path / "stray.jpg"
    path.write_bytes(data[:-2] + b"\x00\x00\x00" + data[-2:])
    out = subprocess.run([sys.executable, "-m", "aerofid", "locate", str(path), "--box", "50000,5000,51000,5100"],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 2
    assert out.stderr.startswith("error: ") and len(out.stderr.splitlines()) == 1, out.stderr
