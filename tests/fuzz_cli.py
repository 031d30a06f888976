"""A fuzzer of the ``aerofid`` command line, shared by ``tests/test_fuzz_cli.py`` (a few hundred cases) and
``benchmarks/fuzz.py`` (10000 and more).

A :class:`Workspace` is a temporary folder of inputs: good scans (TIFF, JPEG, PNG, RGB), camera and measurements
files (JSON, YAML, CSV, MicMac XML), every corrupt or lying file of :mod:`hostile_files`, and special files made
there (a FIFO named like a scan, a character device when the user may make one, a symbolic-link loop, a
symbolic link to an input, a folder named like a file). :func:`random_case` draws one command as a careless or
hostile user would type it: any input, boxes that are empty, huge, text or outside, any parameter with any
value, outputs that name inputs or special files. :func:`run_case` runs it in a forked child of this process
(the CLI's ``main``, so that a case costs milliseconds, not an interpreter start) under an address-space limit
and a time limit, with standard output sometimes a closed pipe or a full device. :func:`judge` says what went
wrong: a traceback, a hang, an undocumented exit status, noise on stderr, or a file changed that the command
was not asked to write (or written although the command failed).
"""

from __future__ import annotations

import contextlib
import fnmatch
import os
import random
import resource
import shutil
import signal
import stat
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hostile_files import encoded, scan_image, write_corpus

DOCUMENTED_STATUSES = (0, 1, 2)
"""0 found, 1 not found, 2 bad input or failed output (README, docs/errors.md)."""
MEMORY_LIMIT = 3 * 2**30
"""Address space a case may add to this process's (bytes): the fork shares the interpreter already loaded."""
TIME_LIMIT = 60.0
"""A case running longer than this (s) is a hang."""
ALLOWED_STDERR = ("error: ", "note: ", "warning: ")

CAMERA_JSON = '{"name": "c", "fiducials": {"P1": [-100, 100], "P2": [100, 100], "P3": [100, -100], "P4": [-100, -100]}}'
CAMERA_YAML = "name: c\nfiducials:\n  P1: [-100, 100]\n  P2: [100, 100]\n  P3: [100, -100]\n  P4: [-100, -100]\n"
MEASURES_JSON = ('{"image": "good.tif", "points": {"P1": [10, 10], "P2": [150, 10], "P3": [150, 150], '
                 '"P4": [10, 150.5]}}')
MEASURES_CSV = "name,x,y\nP1,10,10\nP2,150,10\nP3,150,150\nP4,10,150.5\n"
MEASURES_XML = ("<SetOfMesureAppuisFlottants><MesureAppuiFlottant1Im><NameIm>good.tif</NameIm>"
                + "".join(f"<OneMesureAF1I><NamePt>{n}</NamePt><PtIm>{x} {y}</PtIm></OneMesureAF1I>"
                          for n, x, y in (("P1", 10, 10), ("P2", 150, 10), ("P3", 150, 150), ("P4", 10, 150.5)))
                + "</MesureAppuiFlottant1Im></SetOfMesureAppuisFlottants>")
TEXT_FILES = {
    "cam.json": CAMERA_JSON, "cam.yaml": CAMERA_YAML, "m.json": MEASURES_JSON, "m.csv": MEASURES_CSV,
    "MeasuresIm-good.tif.xml": MEASURES_XML,
    "cam_dup.json": '{"name": "c", "name": "d", "fiducials": {}}',
    "m_dup.json": '{"image": "a", "points": {"P1": [1, 2], "P1": [3, 4], "P3": [5, 6]}}',
    "m_badrow.csv": "P1,a,b\nP2,150,10\nP3,150,150\nP4,10,150\n",
    "m_huge.json": '{"points": {"P1": [1e308, 1e308], "P2": [-1e308, 1e308], "P3": [1e308, -1e308], "P4": [1, 2]}}',
    "m_nan.json": '{"points": {"P1": [NaN, 1], "P2": [1, 2], "P3": [3, 4]}}',
    "m_nulls.json": '{"points": [{"name": "P1", "status": "not_found", "x": null, "y": null}]}',
    "m_unicode.csv": "P1,1,2\nP\u00e9,3,4\nP3,5,\u0661\n",
    "boxes.csv": "name,x0,y0,x1,y1\nA,40,40,120,120\nB,0,0,60,60\n",
    "boxes_bad.csv": "A,x,y,1,2\n",
    "boxes_dup.csv": "A,1,1,50,50\nA,2,2,60,60\n",
    "binary.json": "\x00\x01\x02\xff",
}
GOOD_IMAGES = ("good.tif", "good.jpg", "good.png", "good_rgb.tif")
GOOD_CAMERAS = ("cam.json", "cam.yaml")
GOOD_MEASUREMENTS = ("m.json", "m.csv", "MeasuresIm-good.tif.xml")
MARK_OPTIONS = ("external", "panel", "auto", "ring")
METHOD_OPTIONS = ("auto", "hough", "symmetry", "circles", "lines", "nope")
PARAM_NAMES = ("theta_step", "rho_step", "window_size", "max_asymmetry", "radii", "min_radius", "max_radius",
               "enlarge", "edge_margin", "region", "iterations", "overlap", "verify", "n_circles", "canny_sigma",
               "radius", "crop_margin", "min_agree", "max_agree", "interval", "bogus", "", "mark")
PARAM_VALUES = ("0", "-1", "1", "2", "0.5", "0.01", "3", "7", "45", "100", "4096", "1e6", "1e308", "1" + "0" * 400,
                "inf", "-inf", "nan", "true", "false", "x", "", "None", "[1,2]", "5.0000001")
BOX_NUMBERS = ("0", "10", "40", "80", "120", "159", "160", "161", "-5", "1e9", "1e308", "1" + "0" * 400, "nan",
               "inf", "-inf", "x", "", "0x10", "1_0", "+3", "3.5")


@dataclass
class Workspace:
    """A folder of inputs (module docstring); ``names`` groups them by what they can stand for."""

    root: Path
    images: list[str] = field(default_factory=list)
    cameras: list[str] = field(default_factory=list)
    measurements: list[str] = field(default_factory=list)
    specials: list[str] = field(default_factory=list)
    full_device: str | None = None


def _mknod(path: Path, major: int, minor: int) -> bool:
    """Make a character device node at ``path`` (inside the workspace only); False when not permitted."""
    try:
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(major, minor))
    except (PermissionError, OSError):
        return False
    return True


def make_workspace(root: Path, seed: int = 0) -> Workspace:
    """Fill ``root`` with the inputs of the fuzz cases (module docstring)."""
    rng = np.random.default_rng(seed)
    ws = Workspace(root)
    image = scan_image(rng)
    for kind in ("tif", "jpg", "png"):
        (root / f"good.{kind}").write_bytes(encoded(image, kind))
        ws.images.append(f"good.{kind}")
    (root / "good_rgb.tif").write_bytes(encoded(np.dstack([image, image // 2, image // 3]), "tif"))
    ws.images.append("good_rgb.tif")
    for name, text in TEXT_FILES.items():
        (root / name).write_text(text, encoding="utf-8")
    ws.cameras += ["cam.json", "cam.yaml", "cam_dup.json", "MeasuresIm-good.tif.xml", "binary.json"]
    ws.measurements += ["m.json", "m.csv", "MeasuresIm-good.tif.xml", "m_dup.json", "m_badrow.csv", "m_huge.json",
                        "m_nan.json", "m_nulls.json", "m_unicode.csv", "binary.json"]
    corpus = write_corpus(root, rng)
    for name in corpus:
        (ws.images if name.split(".")[-1] in ("tif", "jpg", "png") else ws.cameras).append(name)
        if name.endswith((".json", ".yaml", ".xml")):
            ws.measurements.append(name)
    os.mkfifo(root / "fifo.tif")
    (root / "folder.json").mkdir()
    os.symlink("loop_b.json", root / "loop_a.json")
    os.symlink("loop_a.json", root / "loop_b.json")
    os.symlink("good.tif", root / "link_to_good.png")
    (root / "readonly.png").write_bytes(b"x")
    (root / "readonly.png").chmod(0o444)
    (root / "micmac").mkdir()
    (root / "micmac_trap").mkdir()
    (root / "micmac_trap" / "MeasuresCamera.xml").mkdir()
    ws.specials += ["fifo.tif", "folder.json", "loop_a.json", "link_to_good.png", "readonly.png", "missing.tif"]
    if _mknod(root / "null.png", 1, 3):
        ws.specials.append("null.png")
    if _mknod(root / "full", 1, 7):
        ws.full_device = "full"
    for group in (ws.images, ws.cameras, ws.measurements):
        group += ws.specials
    return ws


@dataclass(frozen=True)
class Case:
    """One command: its arguments, the outputs it asks for, and how its standard output behaves."""

    args: tuple[str, ...]
    outputs: tuple[str, ...]
    stdout: str = "file"  # "file", "closed" (a pipe with no reader), "full" (a full device)


def _box(r: random.Random) -> str:
    if r.random() < 0.8:
        x0, y0 = r.randrange(-20, 170), r.randrange(-20, 170)
        coords = [x0, y0, x0 + r.randrange(-5, 200), y0 + r.randrange(-5, 200)]
        text = ",".join(map(str, coords))
    else:
        text = ",".join(r.choice(BOX_NUMBERS) for _ in range(r.choice((4, 4, 4, 3, 5))))
    if r.random() < 0.3:
        text = r.choice(("P1", "UL", "a b", "", "x=y", "_q", "P1")) + "=" + text
    return text


def _output(r: random.Random, ws: Workspace, fresh: str, inputs: list[str]) -> str:
    """An output path: usually a fresh name, sometimes an input, a special file, a folder or nonsense."""
    roll = r.random()
    if roll < 0.75:
        return fresh
    if roll < 0.75:
        return r.choice(inputs)
    return r.choice(ws.specials + ["", ".", "nodir/x.png", "micmac", "/proc/aerofid-fuzz/x.png", "out_{name}.png"])


def _locate_case(r: random.Random, ws: Workspace, n: int) -> tuple[list[str], list[str]]:
    image = r.choice(GOOD_IMAGES if r.random() < 0.6 else ws.images)
    args = ["locate", image]
    inputs = [image]
    for _ in range(r.choice((0, 1, 1, 1, 1, 1, 2, 3))):
        args += ["--box", _box(r)]
    if r.random() < 0.15:
        boxes = r.choice(["boxes.csv", "boxes_bad.csv", "boxes_dup.csv", *ws.specials, "deep.json"])
        args += ["--boxes", boxes]
        inputs.append(boxes)
    for option, choices in (("--mark", MARK_OPTIONS), ("--method", METHOD_OPTIONS),
                            ("--polarity", ("bright", "dark", "auto")), ("--colour", ("auto", "red", "max"))):
        if r.random() < 0.3:
            args += [option, r.choice(choices)]
    for _ in range(r.choice((0, 0, 0, 0, 1, 2))):
        args += ["--param", f"{r.choice(PARAM_NAMES)}={r.choice(PARAM_VALUES)}"]
    outputs = []
    for option, suffix in (("--overlay", "png"), ("--plot", "png"), ("-o", "json")):
        if r.random() < 0.35:
            path = _output(r, ws, f"out{n}_{option.strip('-')}.{suffix}", inputs)
            args += [option, path]
            outputs.append(path)
    if r.random() < 0.3:
        args.append("--json")
    return args, outputs


def _orient_case(r: random.Random, ws: Workspace, n: int) -> tuple[list[str], list[str]]:
    camera = r.choice(GOOD_CAMERAS if r.random() < 0.6 else ws.cameras)
    meas = r.choice(GOOD_MEASUREMENTS if r.random() < 0.6 else ws.measurements)
    args = ["orient", "--camera", camera, "--measurements", meas]
    inputs = [camera, meas]
    if r.random() < 0.2:
        args.insert(1, r.choice(ws.images))
    if r.random() < 0.3:
        args += ["--model", r.choice(("affine", "similarity", "projective", "spline"))]
    if r.random() < 0.2:
        args += ["--correspondence", r.choice(("names", "auto"))]
    if r.random() < 0.2:
        args.append("--no-reject")
    outputs = []
    if r.random() < 0.4:
        path = _output(r, ws, f"report{n}.{r.choice(('json', 'html', 'txt'))}", inputs)
        args += ["-o", path]
        outputs.append(path)
    if r.random() < 0.25:
        folder = r.choice(("micmac", "micmac", "micmac_trap", "missing_dir", "cam.json"))
        args += ["--micmac", folder]
        outputs += [f"{folder}/MeasuresIm-good.tif.xml", f"{folder}/MeasuresCamera.xml",
                    f"{folder}/good.tif-AffinePlane-px2mm.xml"]
    if r.random() < 0.3:
        args.append("--json")
    return args, outputs


def random_case(r: random.Random, ws: Workspace, n: int) -> Case:
    """The ``n``-th random command (module docstring)."""
    roll = r.random()
    if roll < 0.03:
        args, outputs = [r.choice(("", "--version", "locate", "orient", "bogus", "--help"))], []
    elif roll < 0.7:
        args, outputs = _locate_case(r, ws, n)
    else:
        args, outputs = _orient_case(r, ws, n)
    stdout = "file"
    if r.random() < 0.05:
        stdout = "closed"
    elif ws.full_device and r.random() < 0.05:
        stdout = "full"
    return Case(tuple(args), tuple(outputs), stdout)


@dataclass(frozen=True)
class Outcome:
    """What a case did: exit status (None when it hung), stdout, stderr, seconds, peak memory (kB)."""

    status: int | None
    stdout: str
    stderr: str
    seconds: float
    max_rss_kb: int


def _child(case: Case, ws: Workspace, out: Path, err: Path, read_end: int | None) -> None:
    """The forked child: limits, standard streams, then the CLI's main; never returns."""
    code = 99
    try:
        os.chdir(ws.root)
        soft, hard = resource.getrlimit(resource.RLIMIT_AS)
        vm = int(Path("/proc/self/status").read_text().split("VmSize:")[1].split()[0]) * 1024
        resource.setrlimit(resource.RLIMIT_AS, (vm + MEMORY_LIMIT, hard))
        if read_end is not None:  # stdout is a pipe whose only reader is gone
            os.close(read_end)
        fd_err = os.open(err, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
        os.dup2(fd_err, 2)
        if case.stdout == "file":
            os.dup2(os.open(out, os.O_WRONLY | os.O_CREAT | os.O_TRUNC), 1)
        elif case.stdout == "full":
            os.dup2(os.open(ws.full_device or os.devnull, os.O_WRONLY), 1)
        sys.stdout = open(1, "w", closefd=False)  # noqa: SIM115
        sys.stderr = open(2, "w", closefd=False)  # noqa: SIM115
        signal.signal(signal.SIGPIPE, signal.SIG_IGN)
        from aerofid.cli import main

        main(list(case.args), prog_name="aerofid")
    except SystemExit as e:
        code = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
    except BaseException:  # a traceback the CLI let through
        import traceback

        traceback.print_exc()
        code = 98
    finally:
        with contextlib.suppress(Exception):
            sys.stderr.flush()
        with contextlib.suppress(Exception):
            sys.stdout.flush()
        os._exit(code)


def warm_up(ws: Workspace, scratch: Path) -> None:
    """Run a found locate with every output and an orient in this process (click's test runner), so that the
    modules the CLI imports lazily are loaded before any fork: a case then costs what its work costs."""
    from click.testing import CliRunner

    from aerofid.cli import main

    cwd = os.getcwd()
    os.chdir(ws.root)
    try:
        for args in (["locate", "good.tif", "--box", "40,40,120,120", "--overlay", str(scratch / "o.png"),
                      "--plot", str(scratch / "p.png"), "-o", str(scratch / "l.json")],
                     ["orient", "--camera", "cam.json", "--measurements", "m.json", "-o", str(scratch / "r.html")]):
            CliRunner().invoke(main, args)
    finally:
        os.chdir(cwd)


def run_case(case: Case, ws: Workspace, scratch: Path, time_limit: float = TIME_LIMIT) -> Outcome:
    """Run ``case`` in a forked child (module docstring)."""
    out, err = scratch / "stdout", scratch / "stderr"
    read_end = write_end = None
    if case.stdout == "closed":
        read_end, write_end = os.pipe()
    start = time.monotonic()
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid == 0:
        if write_end is not None:
            os.dup2(write_end, 1)
        _child(case, ws, out, err, read_end)
    if read_end is not None:
        os.close(read_end)
        os.close(write_end)  # type: ignore[arg-type]
    status: int | None = None
    rss = 0
    while True:
        done, wait_status, usage = os.wait4(pid, os.WNOHANG)
        if done:
            status = os.waitstatus_to_exitcode(wait_status)
            rss = usage.ru_maxrss
            break
        if time.monotonic() - start > time_limit:
            os.kill(pid, signal.SIGKILL)
            os.wait4(pid, 0)
            break
        time.sleep(0.005)
    return Outcome(status, _read(out) if case.stdout == "file" else "", _read(err), time.monotonic() - start, rss)


def _read(p: Path) -> str:
    return p.read_text(errors="replace") if p.exists() else ""


def snapshot(root: Path) -> dict[str, tuple[int, int, int, int]]:
    """Every entry under ``root`` (links not followed): (mode, inode, size, mtime) by relative path."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            st = p.lstat()
            mtime = 0 if stat.S_ISDIR(st.st_mode) else st.st_mtime_ns  # a folder's changes when an output is made
            out[str(p.relative_to(root))] = (st.st_mode, st.st_ino, st.st_size, mtime)
    return out


@dataclass(frozen=True)
class Verdict:
    """What went wrong in one case (empty lists: nothing)."""

    traceback: bool
    hang: bool
    undocumented_status: bool
    noise: tuple[str, ...]
    changed: tuple[str, ...]
    written_on_failure: tuple[str, ...]

    @property
    def ok(self) -> bool:
        return not (self.traceback or self.hang or self.undocumented_status or self.noise or self.changed
                    or self.written_on_failure)


def judge(case: Case, outcome: Outcome, before: dict, after: dict) -> Verdict:
    """The case's :class:`Verdict`: requested outputs may change only when the command succeeded (0 or 1)."""
    patterns = [os.path.normpath(p).replace("{name}", "*") for p in case.outputs if p]
    patterns += [str(Path(p).parent / "*") for p in case.outputs if "/MeasuresCamera.xml" in p]  # --micmac's files

    def is_requested(key: str) -> bool:
        return any(fnmatch.fnmatchcase(key, pattern) for pattern in patterns)

    changed = tuple(sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k)))
    outside = tuple(k for k in changed if not is_requested(k))
    on_failure = tuple(k for k in changed if is_requested(k)) if outcome.status not in (0, 1) else ()
    lines = [line for line in outcome.stderr.splitlines() if line.strip()]
    noise = tuple(line for line in lines if not line.startswith(ALLOWED_STDERR))
    if outcome.status == 2 and sum(line.startswith("error: ") for line in lines) != 1 and case.args[0] != "":
        noise += ("(not exactly one error: line)",)
    return Verdict(traceback="Traceback (most recent call last)" in outcome.stderr, hang=outcome.status is None,
                   undocumented_status=outcome.status not in DOCUMENTED_STATUSES and outcome.status is not None,
                   noise=noise, changed=outside, written_on_failure=on_failure)


def restore(ws: Workspace, before: dict, after: dict, pristine: Path) -> None:
    """Put the workspace back as it was: remove what the case created, copy back what it changed."""
    for key in set(after) - set(before):
        p = ws.root / key
        if p.is_dir() and not p.is_symlink():
            shutil.rmtree(p, ignore_errors=True)
        else:
            with contextlib.suppress(FileNotFoundError):
                p.unlink()
    for key in set(before):
        if before[key] == after.get(key):
            continue
        target, source = ws.root / key, pristine / key
        with contextlib.suppress(OSError):
            target.unlink()
        if source.is_symlink():
            os.symlink(os.readlink(source), target)
        elif source.is_file():
            shutil.copy2(source, target)
        elif stat.S_ISFIFO(before[key][0]):
            os.mkfifo(target)


def pristine_copy(ws: Workspace, dest: Path) -> Path:
    """A copy of the workspace's regular files and links, for :func:`restore`."""
    shutil.copytree(ws.root, dest, symlinks=True, ignore=lambda d, names: [
        n for n in names if not (Path(d, n).is_symlink() or Path(d, n).is_dir() or Path(d, n).is_file())])
    return dest


__all__ = ["Case", "Outcome", "Verdict", "Workspace", "judge", "make_workspace", "pristine_copy", "random_case",
           "restore", "run_case", "snapshot", "warm_up"]
