"""The folder tree is the architecture: the imports between aerofid's modules form no cycle, each layer
imports only the layers below it, no import hides inside a function (the way cycles were hidden before), and
every function is short enough to read at once.

Layers, lowest first (a module may import its own layer and those below):
``conventions, errors, robust, parallel, scipy_kernels, kept, windows`` < ``io`` < ``detect``, ``orientation`` <
``formats`` < ``synth, synth_frame, methods, resample`` < ``find, testing`` < ``locate, frame`` < ``render, batch`` <
``cli``.
``detect`` and ``orientation`` are independent of each other.
"""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

from aerofid.synth_frame import wild_rc10_camera
from conftest import realdata_path

SRC = Path(__file__).resolve().parents[1] / "src" / "aerofid"

LAYER = {"conventions": 0, "errors": 0, "robust": 0, "parallel": 0, "scipy_kernels": 0, "kept": 0, "windows": 0,
         "io": 1, "detect": 2, "orientation": 2, "formats": 3,
         "synth": 4, "synth_frame": 4, "methods": 4, "resample": 4, "testing": 5, "find": 5, "locate": 6, "frame": 6,
         "render": 7, "batch": 7, "cli": 8, "__init__": 9, "__main__": 10}
"""Each top-level part of the package and its layer."""
INDEPENDENT = {frozenset({"detect", "orientation"}), frozenset({"detect", "formats"})}
"""Parts that must not import each other although their layers would allow it."""


def _module_name(path: Path) -> str:
    rel = path.relative_to(SRC.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _names_a_module(text: str) -> bool:
    """Whether ``text`` is exactly the name of one of aerofid's modules (``aerofid.detect.lines``): not a prefix
    (``"aerofid."``), not a name with no file."""
    parts = text.split(".")
    if parts[0] != "aerofid" or len(parts) < 2 or not all(p.isidentifier() for p in parts):
        return False
    where = SRC.parent.joinpath(*parts)
    return where.with_suffix(".py").is_file() or (where / "__init__.py").is_file()


def _imports(path: Path) -> tuple[set[str], list[int]]:
    """The aerofid modules ``path`` imports (also those it names in a string, to import them by that name), and the
    line numbers of imports inside functions."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out: set[str] = set()
    nested: list[int] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import | ast.ImportFrom):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:  # "from aerofid import synth" imports aerofid.synth, not the package's __init__
                names = [f"{node.module}.{a.name}" for a in node.names]
                names += [node.module or ""] if node.module != "aerofid" else []
            out |= {n for n in names if n == "aerofid" or n.startswith("aerofid.")}
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and _names_a_module(node.value):
            out.add(node.value)  # a module imported by its name at its first use (the registry's methods)
    for fn in ast.walk(tree):
        if isinstance(fn, ast.FunctionDef | ast.AsyncFunctionDef):
            for n in ast.walk(fn):
                mods = ([a.name for a in n.names] if isinstance(n, ast.Import)
                        else [n.module or ""] if isinstance(n, ast.ImportFrom) else [])
                if any(m == "aerofid" or m.startswith("aerofid.") for m in mods):
                    nested.append(n.lineno)
    return out, nested


def _graph() -> dict[str, set[str]]:
    files = {_module_name(p): p for p in SRC.rglob("*.py")}
    graph = {}
    for name, path in files.items():
        deps, _ = _imports(path)
        # "from aerofid.x import y" names module aerofid.x.y when that is a module, else aerofid.x
        graph[name] = {d if d in files else d.rsplit(".", 1)[0] for d in deps} & set(files) - {name}
    return graph


def _part(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def test_no_import_cycle():
    graph = _graph()
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(n: str) -> None:
        state[n] = 1
        stack.append(n)
        for m in sorted(graph[n]):
            if state.get(m) == 1:
                raise AssertionError("import cycle: " + " -> ".join(stack[stack.index(m):] + [m]))
            if m not in state:
                visit(m)
        stack.pop()
        state[n] = 2

    for n in sorted(graph):
        if n not in state:
            visit(n)


def test_layers_import_only_downwards():
    bad = []
    for mod, deps in _graph().items():
        a = _part(mod)
        for d in deps:
            b = _part(d)
            if b == "__init__" and d != "aerofid":
                continue
            if a != b and (LAYER[b] > LAYER[a] or frozenset({a, b}) in INDEPENDENT):
                bad.append(f"{mod} imports {d}")
    assert not bad, bad


@pytest.mark.parametrize("path", sorted(p for p in SRC.rglob("*.py") if "cli" not in p.parts),
                         ids=lambda p: str(p.relative_to(SRC)))
def test_no_import_inside_a_function(path):
    """Outside the CLI (which imports lazily to start fast), every aerofid import is at module level."""
    _, nested = _imports(path)
    assert not nested, f"{path.name}: aerofid imports inside functions at lines {nested}"


def test_every_part_has_a_layer():
    parts = {_part(m) for m in _graph()}
    assert parts <= set(LAYER), parts - set(LAYER)


MAX_FUNCTION_LINES = 60
"""A function's body (without its docstring) fits on a screen: each pipeline step is a named function."""


@pytest.mark.parametrize("path", sorted(SRC.rglob("*.py")), ids=lambda p: str(p.relative_to(SRC)))
def test_functions_are_short_enough_to_read_at_once(path):
    long = []
    for fn in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(fn, ast.FunctionDef | ast.AsyncFunctionDef):
            body = fn.body[1:] if ast.get_docstring(fn) is not None and len(fn.body) > 1 else fn.body
            lines = (fn.end_lineno or fn.lineno) - body[0].lineno + 1
            if lines > MAX_FUNCTION_LINES:
                long.append(f"{fn.name} ({lines} lines, line {fn.lineno})")
    assert not long, long


def test_import_aerofid_loads_no_part_until_a_name_is_used():
    """``import aerofid`` is lazy (PEP 562): no part is imported until one of its public names is used; then
    every name in ``__all__`` is the object of the module that defines it (the ``TYPE_CHECKING`` imports)."""
    code = ("import sys, aerofid; print(sorted(m for m in sys.modules if m.startswith('aerofid.') "
            "or m.split('.')[0] in ('numpy', 'scipy', 'cv2')))")
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert loaded.strip() == "[]", loaded
    bound = "import aerofid.locate, aerofid; print(callable(aerofid.locate), aerofid.locate.__module__)"
    out = subprocess.run([sys.executable, "-c", bound], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["True", "aerofid.locate"], out  # the function, not the submodule of that name
    import aerofid

    tree = ast.parse((SRC / "__init__.py").read_text(encoding="utf-8"))
    declared = {a.name: n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module
                and n.module.startswith("aerofid.") for a in n.names}
    assert set(aerofid.__all__) == set(declared) | {"__version__"}
    for name, module in declared.items():
        assert getattr(aerofid, name) is getattr(__import__(module, fromlist=[name]), name), name
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        aerofid.nothing  # noqa: B018


START_UP_HEAVY = ("scipy.ndimage", "scipy.sparse", "scipy.stats", "scipy.spatial", "matplotlib", "aerofid.batch",
                  "aerofid.frame", "aerofid.resample", "tifffile", "yaml", "aerofid.detect.lines", "json", "xml")
"""What a one-box ``aerofid locate`` of a ring must not import (issue 10: a call pays only for what it uses): the
``lines`` method, which no check of a ring runs (the registry imports a method at its first call), and JSON and XML
with no file to read or write."""


def _locate_loads(setup: str, image: str, box: str, prefixes: tuple[str, ...]) -> str:
    """Stdout of one ``aerofid locate IMAGE --box BOX --mark external`` in a fresh interpreter (after ``setup``), then
    its exit status and the loaded modules of ``prefixes`` (each a module and its submodules), a line each."""
    code = (
        "import sys\n" + setup +
        "from aerofid.cli import main\n"
        "try:\n"
        f"    main(['locate', {image!r}, '--box', {box!r}, '--mark', 'external'])\n"
        "except SystemExit as e:\n"
        "    print('status', e.code)\n"
        f"print(sorted(m for m in sys.modules if any(m == p or m.startswith(p + '.') for p in {prefixes!r})))\n"
    )
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout


def test_a_box_that_needs_a_jpeg_s_whole_decode_starts_it_before_the_detectors_import(tmp_path):
    """``aerofid locate`` opens the scan before it imports the detection modules (``aerofid.cli.locate_cmd``
    imports none of them): a JPEG box whose rows need the whole decode has it running in its own thread while they
    import; the mark is found all the same."""
    jpg = str(tmp_path / "ring.jpg")
    setup = (
        "import numpy as np, cv2\n"
        "yy, xx = np.mgrid[0:400, 0:300]\n"
        "img = 40 + 160 * np.exp(-(np.hypot(xx - 147.3, yy - 348.6) - 12.0) ** 2 / 3.0)\n"
        f"cv2.imwrite({jpg!r}, np.clip(img, 0, 255).astype(np.uint8), [cv2.IMWRITE_JPEG_QUALITY, 95])\n"
        "import aerofid.cli.locate_cmd, aerofid.io.jpeg as J\n"
        "print('detectors at import', 'aerofid.find' in sys.modules)\n"
        "start = J.decoding\n"
        "def decoding(*a, **k):\n"
        "    print('detectors at the decode', 'aerofid.find' in sys.modules)\n"
        "    return start(*a, **k)\n"
        "J.decoding = decoding\n"
    )
    out = _locate_loads(setup, jpg, "120,320,176,376", ("aerofid.find",))
    assert "detectors at import False" in out and "detectors at the decode False" in out, out
    found = out.split("\n")[2].split()
    assert found[0] == "found" and abs(float(found[1][2:]) - 147.3) < 0.1 and abs(float(found[2][2:]) - 348.6) < 0.1


def test_a_one_box_locate_imports_only_what_it_uses(tmp_path):
    """The CLI imports the command it runs (``aerofid.cli.COMMANDS``), and a ring that ``circles`` and ``symmetry``
    corroborate needs no scipy module (the spline coefficients and moving means are aerofid's own, and so are a
    reduced JPEG source's weights; a '+' fitted loads scipy's MINPACK and ``ndtr`` alone, and scipy.optimize when its
    bounded solver retries a fit); a PNG needs no tifffile, a box list no PyYAML."""
    png = str(tmp_path / "ring.png")
    setup = (
        "import numpy as np, cv2\n"
        "yy, xx = np.mgrid[0:96, 0:96]\n"
        "img = 40 + 160 * np.exp(-(np.hypot(xx - 47.3, yy - 48.6) - 12.0) ** 2 / 3.0)\n"
        "img += np.random.default_rng(0).normal(0, 2, img.shape)\n"
        f"cv2.imwrite({png!r}, np.clip(img, 0, 255).astype(np.uint8))\n"
    )
    out = _locate_loads(setup, png, "20,20,76,76", START_UP_HEAVY)
    found = out.split()
    assert found[0] == "found" and abs(float(found[1][2:]) - 47.3) < 0.05 and abs(float(found[2][2:]) - 48.6) < 0.05
    assert out.strip().splitlines()[-2:] == ["status 0", "[]"], out


def test_what_always_holds_arrays_in_a_one_box_locate_compares_by_identity():
    """A dataclass of the modules a one-box ``aerofid locate`` imports whose array fields are all required, and the
    mutable traces the detectors fill, have no generated ``__eq__`` or ``__hash__`` (``eq=False``): numpy's ``==`` is
    elementwise, so a field-by-field ``__eq__`` raises on them unless they share their arrays, and each generated
    method is a compile at start-up (issue 10). Results whose arrays are optional (``Location``, ``SymmetryResult``...)
    keep theirs."""
    code = ("import sys, dataclasses\nimport aerofid.cli.locate_cmd, aerofid.locate\n"
            "for name, module in sorted(sys.modules.items()):\n"
            "    for c in vars(module).values() if name.startswith('aerofid') else ():\n"
            "        if isinstance(c, type) and dataclasses.is_dataclass(c) and c.__module__ == name:\n"
            "            arrays = [str(f.type) for f in dataclasses.fields(c) if 'ndarray' in str(f.type)]\n"
            "            print(name, c.__name__, c.__eq__ is object.__eq__, bool(arrays),\n"
            "                  all('None' not in a for a in arrays), c.__dataclass_params__.frozen)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    classes = [line.split() for line in out.splitlines()]
    identity = {f"{m}.{c}" for m, c, same, *_ in classes if same == "True"}
    required = {f"{m}.{c}" for m, c, _, arrays, all_required, frozen in classes
                if (arrays == "True" and all_required == "True") or (c == "_Trace" and frozen == "False")}
    assert len(required) >= 20 and required <= identity, sorted(required - identity)
    assert {"aerofid.locate.Location", "aerofid.detect.symmetry.SymmetryResult"}.isdisjoint(identity)


def test_a_one_box_locate_of_the_real_rc20_ring_fits_no_cross():
    """The real RC20 ring's X has an open centre: ``hough``'s cross-check of the ring proposes two candidates where no
    stroke crosses, refused before any fit (``AutoParams.cross_check_crossing_gap``), so one ``aerofid locate`` of it
    loads neither scipy.optimize nor scipy.special (issue 10: 0.3-0.4 s of the call)."""
    jpeg = str(realdata_path("unbc_bc_wild_rc20/15BCC02013_114.jpg"))
    out = _locate_loads("", jpeg, "605,119,725,239", ("scipy.optimize", "scipy.special"))
    assert out.split()[0] == "found", out
    assert out.strip().splitlines()[-2:] == ["status 0", "[]"], out


def test_a_one_box_locate_of_a_cross_loads_neither_scipy_optimize_nor_scipy_special(tmp_path):
    """A '+' that ``hough`` fits is fitted by scipy's MINPACK and ``ndtr`` loaded by themselves
    (:mod:`aerofid.scipy_kernels`): the call loads neither scipy.optimize nor scipy.special, nor what they bring
    (0.6-0.7 s of a cold call), and finds the '+' where it is."""
    png = str(tmp_path / "cross.png")
    setup = (
        "import numpy as np, cv2\n"
        "yy, xx = np.mgrid[0:96, 0:96]\n"
        "d1, d2 = np.abs(xx - 47.3), np.abs(yy - 48.6)\n"
        "bar = lambda u, v: np.clip(2.0 - u, 0, 1) * np.clip(25.0 - v, 0, 1)\n"
        "img = 40 + 160 * np.maximum(bar(d1, d2), bar(d2, d1))\n"
        "img = cv2.GaussianBlur(img, (0, 0), 0.8) + np.random.default_rng(0).normal(0, 2, img.shape)\n"
        f"cv2.imwrite({png!r}, np.clip(img, 0, 255).astype(np.uint8))\n"
    )
    out = _locate_loads(setup, png, "10,10,86,86", ("scipy.optimize", "scipy.special", "scipy.sparse",
                                                   "scipy.linalg"))
    found = out.split()
    assert found[0] == "found" and "method=hough" in out, out
    assert abs(float(found[1][2:]) - 47.3) < 0.05 and abs(float(found[2][2:]) - 48.6) < 0.05
    assert out.strip().splitlines()[-2:] == ["status 0", "[]"], out


ORIENTATION_HEAVY = ("scipy", "yaml")
"""What the layout search and the adjustment with its F tests, on a JSON camera file, must not import: scipy.spatial's
k-d tree and scipy.special's F quantile cost a cold ``aerofid orient`` 0.5 s, PyYAML 20 ms (a '+' fitted loads two of
scipy's compiled modules, :mod:`aerofid.scipy_kernels`, and scipy's top package)."""


def test_the_layout_search_and_the_adjustment_import_no_scipy_nor_yaml(tmp_path):
    """In a fresh interpreter: the Wild RC10 layout (read from a JSON camera file) found among chance features at an
    unknown pixel size, and the interior orientation of its marks with the film's lie by the F test and the blunder
    tests."""
    camera = tmp_path / "camera.json"
    camera.write_text(json.dumps(wild_rc10_camera().to_dict()), encoding="utf-8")
    code = (
        "import sys\n"
        "import numpy as np\n"
        "from aerofid.formats.camera_file import read_camera\n"
        "from aerofid.frame.layout import layout_candidates\n"
        "from aerofid.orientation.interior import orient\n"
        f"cam = read_camera({str(camera)!r})\n"
        "rng = np.random.default_rng(1)\n"
        "marks = cam.xy_mm * [1, -1] / 0.021 + 5500 + rng.normal(0, 0.05, cam.xy_mm.shape)\n"
        "features = np.vstack([marks, rng.uniform(0, 11000, (200, 2))])\n"
        "best = layout_candidates(features, cam.xy_mm, cam.y_axis, scan_size=(11000, 11000))[0]\n"
        "io = orient(cam, marks, correspondence='auto')\n"
        "print(len([m for m in best.matched if m is not None]), round(float(np.mean(io.pixel_size_um)), 2))\n"
        f"print(sorted(m for m in sys.modules if m.split('.')[0] in {ORIENTATION_HEAVY!r}))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip().splitlines() == ["8 21.0", "[]"], out
