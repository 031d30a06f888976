"""method="auto" (aerofid.detect.auto): the right detector's accuracy per style, explicit not_found for every
rejection case, never a found centre far from the truth, and each step of the rule alone. Every assertion is
against synthetic truth; every scene comes from a fixed seed."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from matplotlib.figure import Figure

import aerofid
from aerofid import synth, testing
from aerofid.detect import auto
from aerofid.detect.auto import AutoParams, AutoResult, Check, detect
from aerofid.detect.hough.cross_fit import CrossFit
from aerofid.detect.hough.detector import HoughResult
from aerofid.detect.hough.params import HoughParams
from aerofid.detect.params import MethodParams
from aerofid.detect.registry import METHODS, SEED_METHODS
from aerofid.detect.result import Detection
from aerofid.errors import AerofidInputError

STYLES = ("cross", "ring_x_dot", "ring_cross", "dot", "bullseye", "notch_dot")
APPLY = {"cross": ("hough", "lines"), "ring_x_dot": ("circles", "symmetry"), "ring_cross": ("circles", "symmetry"),
         "dot": ("symmetry",), "bullseye": ("circles", "symmetry"), "notch_dot": ()}
"""The single methods that find (nearly) every mark of a style (benchmarks/bench_marks.py)."""


def _scene(style, rng, size=None):
    size = size if size is not None else rng.uniform(24, 40)
    return synth.mark_scene(style, size=size, window=120, rng=rng, noise_sigma=0.02,
                            angle_deg=0.0 if style == "notch_dot" else rng.uniform(0, 90),
                            blur_sigma=rng.uniform(0.5, 1.0), contrast=rng.uniform(0.6, 0.85))


def _found(x=10.0, y=10.0, sigma=0.05, score=0.9, method="symmetry"):
    return Detection(status="found", x=x, y=y, score=score, sigma=sigma, method=method)


# --- the whole rule --------------------------------------------------------------------------------------

@pytest.mark.parametrize("style", STYLES)
def test_auto_finds_each_style_at_its_best_methods_accuracy(style):
    rng = np.random.default_rng(100 + STYLES.index(style))
    err_auto, err_best = [], {m: [] for m in APPLY[style]}
    for _ in range(4):
        sc = _scene(style, rng)
        m = sc.marks[0]
        d = detect(sc.image)
        assert d.found, d.reason
        err_auto.append(np.hypot(d.x - m.x, d.y - m.y))
        for meth in err_best:
            r = METHODS[meth].detect(sc.image)
            err_best[meth].append(np.hypot(r.x - m.x, r.y - m.y) if r.found else np.inf)
    rms_auto = float(np.sqrt(np.mean(np.square(err_auto))))
    assert rms_auto <= 0.1
    # no single method that finds every mark does markedly better
    finite = [float(np.sqrt(np.mean(np.square(e)))) for e in err_best.values() if np.all(np.isfinite(e))]
    if finite:
        assert rms_auto <= 1.5 * min(finite) + 0.02


SIGMA_BAND = {"cross": (0.7, 1.5), "ring_x_dot": (0.3, 1.0), "dot": (0.4, 1.0), "notch_dot": (0.4, 1.0)}
"""Observed RMS error per axis / mean reported sigma (24 marks per style, seeds 500-501 measured 0.84-0.89 for
'+' (the cross fit's sigma), 0.41-0.46 for rings, 0.60-0.63 for dots: ``symmetry``'s sigma, which ``auto``
returns for them, is conservative by up to 2.5x; never optimistic)."""


@pytest.mark.parametrize("style", SIGMA_BAND)
def test_auto_sigma_is_honest(style):
    rng = np.random.default_rng(500 + STYLES.index(style))
    err2, sig = [], []
    for _ in range(12):
        sc = _scene(style, rng)
        m = sc.marks[0]
        d = detect(sc.image)
        assert d.found, d.reason
        err2 += [(d.x - m.x) ** 2, (d.y - m.y) ** 2]
        sig.append(d.sigma)
    lo, hi = SIGMA_BAND[style]
    assert lo <= np.sqrt(np.mean(err2)) / np.mean(sig) <= hi


def test_auto_finds_panels_on_aerial_ground_with_mark_panel():
    """Cloth panels (3 x their size boxes, as locate would cut them): found with mark="panel", none far off."""
    rng = np.random.default_rng(7)
    found = 0
    for _ in range(6):
        sc = synth.panel_scene(rng, shape_hw=(160, 160), size=rng.uniform(8, 11), contrast=0.3)
        m = sc.marks[0]
        x0, y0, x1, y1 = m.box
        r = detect(sc.image[y0:y1, x0:x1], AutoParams(mark="panel"))
        if r.found:
            found += 1
            assert np.hypot(r.x + x0 - m.x, r.y + y0 - m.y) < 0.2
        else:
            assert r.reason
    assert found >= 5


def test_two_cloth_panels_in_a_box_are_ambiguous():
    """Two panels of one survey in a box (testing.two_panels): the second is found by the first's own image, turned
    (panel_twins), and the box is refused as ambiguous; hough's search of the blanked box let 5 of 40 such boxes
    through."""
    rng = np.random.default_rng(3)
    twins = 0
    for _ in range(20):
        d = detect(testing.two_panels(rng), AutoParams(mark="panel"))
        assert not d.found, (d.x, d.y)
        twins += "a second mark-like feature (hough)" in d.reason
    assert twins >= 15


def _two_panels_at(first, second):
    rng = np.random.default_rng(12)
    img = synth.panel_scene(rng, shape_hw=(100, 100), centre=first, size=9.0, angle_deg=20.0, contrast=0.3,
                            blur_sigma=0.0, noise_sigma=0.0).image
    img = synth.panel_scene(rng, centre=second, size=9.3, angle_deg=55.0, contrast=0.3, blur_sigma=0.0,
                            noise_sigma=0.0, ground=img).image
    return np.clip(synth.add_gaussian_noise(synth.blur(img, 0.6), 0.015, rng), 0, 1).astype(np.float32)


@pytest.mark.parametrize("room", [13.0, 20.0, 30.0])
def test_two_panels_are_ambiguous_wherever_the_first_lies(room):
    d = detect(_two_panels_at((99.0 - room, 99.0 - room), (22.3, 48.6)), AutoParams(mark="panel"))
    assert not d.found and "second mark-like feature" in d.reason, d.reason


def test_two_panels_near_the_box_edges_are_ambiguous_by_hough_s_search(monkeypatch):
    """The panel's turned image needs 11 px of room around it (half-size 7); with 10.5 px panel_twins cannot look
    and hough's search of the blanked box looks for the second panel, as before."""
    calls = []
    real = auto.panel_twins
    monkeypatch.setattr(auto, "panel_twins", lambda *a: calls.append(real(*a)) or calls[-1])
    d = detect(_two_panels_at((88.5, 88.5), (10.5, 10.5)), AutoParams(mark="panel"))
    assert calls == [None]
    assert not d.found and "second mark-like feature (hough)" in d.reason, d.reason


def test_a_lone_panel_is_not_refused_for_clutter_that_resembles_it():
    """One panel in aerial clutter that correlates with it up to 0.8: the best places are fitted, and none is a '+'
    like the panel (hough's spiral over the blanked box refused the third of these for a clutter '+')."""
    rng = np.random.default_rng(2026)
    for _ in range(4):
        size = rng.uniform(7, 11)
        sc = synth.panel_scene(rng, shape_hw=(200, 200), size=size, contrast=rng.uniform(0.2, 0.35),
                               angle_deg=rng.uniform(0, 90))
        d = detect(sc.image, AutoParams(mark="panel"))
        m = sc.marks[0]
        assert d.found and np.hypot(d.x - m.x, d.y - m.y) < 0.1, d.reason


def test_a_panel_s_box_is_not_searched_for_concentric_circles(monkeypatch):
    """Uniqueness of a cloth panel on aerial ground: the blanked box is searched by ``symmetry`` and the panel's twins,
    not by ``circles`` (two concentric circles are no panel); ``circles`` runs nowhere in a panel's box."""
    from aerofid.detect import circles, symmetry
    seen: list[str] = []
    for module in (circles, symmetry):
        real = module.detect
        monkeypatch.setattr(module, "detect", lambda w, p, real=real, name=module.__name__: seen.append(name)
                            or real(w, p))
    sc = synth.panel_scene(np.random.default_rng(2026), shape_hw=(200, 200), size=9.0, contrast=0.3,
                           angle_deg=30.0)
    d = detect(sc.image, AutoParams(mark="panel"))
    m = sc.marks[0]
    assert d.found and np.hypot(d.x - m.x, d.y - m.y) < 0.1, d.reason
    assert d.structure_left and d.second_marks == ()       # the blanked box was searched
    assert seen.count("aerofid.detect.symmetry") >= 2 and "aerofid.detect.circles" not in seen


def test_a_second_panel_s_fit_ends_well_within_its_evaluations(monkeypatch):
    """``panel_twins``' fits stop at LIKE_EVALUATIONS a pass. With no such cap (the search's 100), the second panel of
    boxes with two (made noisier, where its fits take the most) converges within half of it, and the boxes are
    answered as with the cap; beside a lone panel the places on clutter are fitted with the cap, and the panel found."""
    import aerofid.detect.hough.cross_fit as cf
    from aerofid.detect.hough import detector as hd

    passes: list = []
    solve, like = cf.levenberg_marquardt, auto.verify_like

    def counted(residuals, jacobian, x0, max_evaluations):
        got = solve(residuals, jacobian, x0, max_evaluations)
        passes.append((max_evaluations, got.nfev, got.success))
        return got

    monkeypatch.setattr(cf, "levenberg_marquardt", counted)
    monkeypatch.setattr(auto, "verify_like", lambda *a, **k: passes.append("like") or like(*a, **k))

    def twin_passes():                  # the solver's passes from the first verify_like on
        return [p for p in passes[passes.index("like"):] if p != "like"] if "like" in passes else []

    rng = np.random.default_rng(5)
    boxes = [testing.two_panels(rng) for _ in range(10)]
    boxes = [np.clip(b + rng.normal(0.0, 0.035, b.shape), 0, 1).astype(np.float32) for b in boxes]
    capped = [detect(b, AutoParams(mark="panel")) for b in boxes]
    cap = hd.LIKE_EVALUATIONS
    monkeypatch.setattr(hd, "LIKE_EVALUATIONS", cf.MAX_EVALUATIONS)
    refused = 0
    for b, with_cap in zip(boxes, capped, strict=True):
        passes.clear()
        d = detect(b, AutoParams(mark="panel"))
        assert (d.found, d.x, d.y, d.reason) == (with_cap.found, with_cap.x, with_cap.y, with_cap.reason)
        if "a second mark-like feature (hough)" in d.reason:
            refused += 1
            converged = [n for _, n, ok in twin_passes() if ok]
            assert converged and max(converged) <= cap // 2, converged
    assert refused >= 6
    monkeypatch.setattr(hd, "LIKE_EVALUATIONS", cap)
    lone = synth.panel_scene(np.random.default_rng(2026), shape_hw=(200, 200), size=9.0, contrast=0.25)
    passes.clear()
    d = detect(lone.image, AutoParams(mark="panel"))
    assert d.found and twin_passes() and all(cap == hd.LIKE_EVALUATIONS for cap, _, _ in twin_passes())


@pytest.mark.parametrize("cx", [10.3, 15.3])
def test_a_mark_cut_by_the_box_edge_is_refused_with_its_centre_and_extent(cx):
    """A 40 px '+' whose centre lies 10-15 px from the box's left edge is refused as cut by the edge, and the refusal
    says where the mark lies and how large it is (:attr:`AutoResult.cut_at`, :attr:`AutoResult.mark_extent`, from
    :attr:`Check.cut`). The same mark in a box that holds it is found at its centre, and has none."""
    img = synth.mark_scene("cross", size=40.0, window=60, centre=(cx, 30.6), rng=np.random.default_rng(0)).image
    d = detect(np.ascontiguousarray(img, dtype=np.float32))
    assert not d.found and "cut by the box edge" in d.reason and d.check is not None and d.check.cut
    assert d.cut_at is not None and np.hypot(d.cut_at[0] - cx, d.cut_at[1] - 30.6) < 0.05
    assert 20.0 < d.mark_extent < 24.0
    whole = synth.mark_scene("cross", size=40.0, window=64, centre=(31.5 + cx % 1, 30.6), rng=np.random.default_rng(0))
    again = detect(np.ascontiguousarray(whole.image, dtype=np.float32))
    assert again.found and again.cut_at is None and again.check is not None and not again.check.cut
    assert np.hypot(again.x - 31.5 - cx % 1, again.y - 30.6) < 0.05


def test_a_mark_beside_mark_like_dots_is_refused_with_its_centre():
    """A ring, X and dot with a second mark-like dot in the box is refused as ambiguous, and the refusal says where
    the mark it verified lies (:attr:`AutoResult.ambiguous_at`): on a box centred there without the dot it is found
    at the same centre. A mark alone has none."""
    rng = np.random.default_rng(0)
    img = synth.mark_scene("ring_x_dot", size=24.0, window=120, centre=(70.3, 64.6), rng=rng).image.copy()
    yy, xx = np.mgrid[0:120, 0:120]
    for cx, cy in ((22.0, 20.0), (25.0, 40.0)):          # two number dots, as beside a Wild corner mark
        img[np.hypot(xx - cx, yy - cy) <= 6] = 0.85
    img = synth.blur(img, 0.7).astype(np.float32)
    d = detect(img)
    assert not d.found and "ambiguous" in d.reason and d.ambiguous_at is not None
    x, y = d.ambiguous_at
    assert np.hypot(x - 70.3, y - 64.6) < 0.05
    again = detect(np.ascontiguousarray(img[27:104, 32:109]))   # 38 px about (70, 65): the dots left out
    assert again.found and again.ambiguous_at is None
    assert np.hypot(again.x + 32 - x, again.y + 27 - y) < 0.01


def test_clutter_only_is_not_found():
    rng = np.random.default_rng(11)
    for _ in range(4):
        img = synth.aerial_ground((120, 120), rng)
        d = detect(img)
        assert not d.found and d.reason


TRAPS = {"two marks": (200, STYLES), "half mark": (300, STYLES), "film-border edge": (400, STYLES[:-1])}
"""Rejection cases (:data:`aerofid.testing.TRAPS`): (seed base, styles); every found answer is wrong or
ambiguous."""


@pytest.mark.parametrize("trap,style", [(t, s) for t, (_, styles) in TRAPS.items() for s in styles])
def test_trap_scenes_are_not_found(trap, style):
    seed, _ = TRAPS[trap]
    rng = np.random.default_rng(seed + STYLES.index(style))
    for _ in range(3):
        d = detect(testing.TRAPS[trap](rng, style))
        assert not d.found, (d.x, d.y, d.rule)
        assert d.reason


def test_auto_never_returns_a_found_centre_far_from_the_truth():
    """A few dozen random cases, marks and rejection cases mixed: found means within 1.5 px of a truth."""
    rng = np.random.default_rng(2024)
    n_found = 0
    for i in range(36):
        style = STYLES[i % len(STYLES)]
        kind = i // len(STYLES) % 3
        if kind == 0:
            sc = _scene(style, rng, size=rng.uniform(20, 44))
            img, truth = sc.image, [(sc.marks[0].x, sc.marks[0].y)]
        elif kind == 1:
            img, truth = testing.two_marks(rng, style), []
        else:
            img, truth = testing.half_mark(rng, style), []
        d = detect(img)
        if d.found:
            n_found += 1
            assert truth and min(np.hypot(d.x - x, d.y - y) for x, y in truth) <= 1.5
    assert n_found >= 10


def test_locate_auto_reports_the_detector_and_a_comparable_score():
    rng = np.random.default_rng(9)
    sc = _scene("ring_x_dot", rng, size=36)
    m = sc.marks[0]
    r = aerofid.locate(sc.image, (0, 0, 120, 120))
    assert r.found and r.method in ("circles", "symmetry", "lines", "hough")
    assert np.hypot(r.x - m.x, r.y - m.y) < 0.1 and 0.5 < r.score <= 1
    one = aerofid.locate(sc.image, (0, 0, 120, 120), method="circles")
    assert one.method == "circles" and one.found


def test_auto_is_deterministic():
    rng = np.random.default_rng(13)
    sc = _scene("notch_dot", rng, size=34)
    a, b = detect(sc.image), detect(sc.image)
    assert a.found
    assert (a.status, a.x, a.y, a.score, a.rule) == (b.status, b.x, b.y, b.score, b.rule)


def test_auto_does_not_modify_its_window():
    """Blanking (uniqueness) and isolating (step 4) work on copies: float32 windows are used without a copy."""
    rng = np.random.default_rng(19)
    for style in ("notch_dot", "cross", "ring_cross"):
        img = _scene(style, rng).image
        assert img.dtype == np.float32
        before = img.copy()
        assert detect(img).found
        np.testing.assert_array_equal(img, before)


def test_a_small_zeiss_dot_close_to_its_notchs_walls_is_found():
    """Small marks: the notch's walls come closer than twice the dot's radius, so only a narrow flat moat
    surrounds the dot (docs/benchmarks_marks.md had 2 of 30 such dots not found)."""
    rng = np.random.default_rng(17)
    for _ in range(4):
        sc = _scene("notch_dot", rng, size=rng.uniform(20, 23))
        m = sc.marks[0]
        d = detect(sc.image)
        assert d.found, d.reason
        assert d.rule == "isolated compact dot: symmetry + centroid"
        assert np.hypot(d.x - m.x, d.y - m.y) < 0.1


def test_the_result_is_typed_and_tells_how_it_decided():
    rng = np.random.default_rng(9)
    sc = _scene("ring_x_dot", rng, size=36)
    d = detect(sc.image)
    assert isinstance(d, AutoResult) and d.found and d.method == "symmetry"
    assert d.rule.startswith("corroborated by") and len(d.members) >= 2 and d.member is not None
    assert (d.x, d.y, d.sigma) == (d.member.x, d.member.y, d.member.sigma)
    assert isinstance(d.check, Check) and d.check.ok and d.extent == d.check.extent == d.mark_extent
    assert {"circles@crop", "symmetry"} <= set(d.answers) and d.second_marks == ()
    assert d.shifted(10, 20).x == d.x + 10 and d.to_dict()["method"] == "symmetry"


def test_unusable_windows_are_not_found_with_a_reason():
    assert detect(np.zeros((64, 64), np.float32)).reason == "homogeneous window (grey range below 0.02): no mark"
    assert "16 x 16" in detect(np.eye(10, dtype=np.float32)).reason
    bad = np.full((32, 32), 0.5, np.float32)
    bad[3, 3] = np.nan
    assert "NaN" in detect(bad).reason


def test_plot_draws_the_members_figure_or_every_answer():
    rng = np.random.default_rng(9)
    img = _scene("ring_x_dot", rng, size=36).image
    d = detect(img)
    fig = Figure()
    d.plot(fig, img)
    assert fig.axes and f"auto: {d.rule}" in fig.get_suptitle()
    miss = detect(testing.two_marks(np.random.default_rng(200), "dot"))
    fig = Figure()
    miss.plot(fig, img)
    assert "not found" in fig.axes[0].get_title()


# --- parameters --------------------------------------------------------------------------------------------

def test_auto_params_are_validated():
    assert AutoParams().mark == "auto" and AutoParams().max_disc_asymmetry == 0.2
    for bad in ({"mark": "ring"}, {"min_agree": 2.0}, {"crop_margin": -1}, {"crop_margin": 2.5},
                {"max_disc_asymmetry": 0.0}, {"lone_factor": 1.5}, {"extent_percentile": 0.0},
                {"cross_check_crossing_gap": -1.0}):
        with pytest.raises(ValueError):
            AutoParams(**bad)
    with pytest.raises(AerofidInputError, match="valid: mark"):
        AutoParams.from_mapping({"max_asymmetry": 0.3}, "auto")


def test_the_cross_check_limits_hough_unless_the_user_limits_it_more():
    """``hough`` re-examining a lone answer gets ``cross_check_rejections`` and ``cross_check_crossing_gap``, or the
    user's own ``max_rejections`` and ``max_crossing_gap`` where those are lower, and the external window alone for a
    mark wider than the panel window; ``lines`` stops refining at
    ``cross_check_converged`` unless the user's own ``converged`` is looser; ``symmetry`` runs as it is."""

    def overrides(params, method="hough", extent=5.0, **mine):
        seeds = auto.seed_params(params, {method: METHODS[method].params_type(**mine)})
        return auto._cross_check_params(auto._Context(np.zeros((8, 8), np.float32), 0.01, params, seeds), method,
                                        extent)

    assert overrides(AutoParams(), "lines") == {"converged": 0.01}
    assert overrides(AutoParams(cross_check_converged=0.002), "lines", converged=0.05) == {"converged": 0.05}
    assert overrides(AutoParams(), "symmetry") == {}

    assert overrides(AutoParams()) == {"max_rejections": 2, "max_crossing_gap": 1.0}
    assert overrides(AutoParams(), max_rejections=None) == {"max_rejections": 2, "max_crossing_gap": 1.0}
    assert overrides(AutoParams(cross_check_crossing_gap=2.5), max_rejections=1, max_crossing_gap=0.5) == {
        "max_rejections": 1, "max_crossing_gap": 0.5}
    assert overrides(AutoParams(cross_check_rejections=5), max_crossing_gap=3.0) == {
        "max_rejections": 5, "max_crossing_gap": 1.0}
    # a mark wider than the panel window is sought with the external window alone, unless the user chose
    assert overrides(AutoParams(), extent=8.5) == {"max_rejections": 2, "max_crossing_gap": 1.0, "window_size": 40}
    assert "window_size" not in overrides(AutoParams(), extent=8.0)
    assert "window_size" not in overrides(AutoParams(), extent=20.0, window_size=24)
    assert "window_size" not in overrides(AutoParams(mark="panel"), extent=20.0)


def test_hough_run_because_nothing_else_answered_gives_up_after_fallback_rejections():
    """Step 1's ``hough`` (``circles`` and ``symmetry`` found no mark) gives up after ``fallback_rejections`` refused
    candidates, or the user's own ``max_rejections`` where that is lower. On a Zeiss dot in its notch, which neither
    method finds, step 4 then finds the dot at the same centre, with the same score, as with the whole box's 8."""
    sc = synth.mark_scene("notch_dot", size=40, window=200, rng=np.random.default_rng(0), noise_sigma=0.02,
                          blur_sigma=0.75, contrast=0.7, angle_deg=0.0)
    mark = sc.marks[0]
    two, eight = auto.detect(sc.image), auto.detect(sc.image, AutoParams(fallback_rejections=8))
    mine = auto.detect(sc.image, methods={"hough": HoughParams(max_rejections=1)})
    assert [len(r.answers["hough"].rejected) for r in (two, eight, mine)] == [2, 8, 1]
    assert two.found and abs(two.x - mark.x) < 0.2 and abs(two.y - mark.y) < 0.2
    assert (two.x, two.y, two.score, two.rule) == (eight.x, eight.y, eight.score, eight.rule)
    with pytest.raises(ValueError, match="fallback_rejections"):
        AutoParams(fallback_rejections=0)


def test_circles_looks_at_symmetry_s_answer_on_its_crop_before_the_whole_box(monkeypatch):
    """Step 1: ``circles`` runs on the crop about ``symmetry``'s answer; on a ring it agrees there and its whole-box
    search is not run (it would agree too, and the centre is ``symmetry``'s). On a dot, which it does not find on
    the crop, it searches the whole box as well, and step 2's cross-check takes the crop's answer already given."""
    from aerofid.detect import circles
    real, shapes = circles.detect, []
    monkeypatch.setattr(circles, "detect", lambda w, p=circles.DEFAULT: shapes.append(w.shape) or real(w, p))
    rng = np.random.default_rng(5)
    ring = _scene("ring_x_dot", rng, size=36)
    res = detect(ring.image)
    x0, y0, x1, y1 = res.windows["circles@crop"]
    assert shapes == [(y1 - y0, x1 - x0)] and x1 - x0 < ring.image.shape[1]
    assert res.found and res.rule == "corroborated by circles, symmetry" and "circles" not in res.answers
    assert (res.x, res.y) == (res.answers["symmetry"].x, res.answers["symmetry"].y)
    whole = real(ring.image)
    assert whole.found and auto.agree(whole, res.answers["circles@crop"])
    shapes.clear()
    dot = _scene("dot", rng, size=24)
    res = detect(dot.image)
    assert res.found and res.rule == "lone symmetry" and not res.answers["circles"].found
    assert len(shapes) == 2 and shapes[1] == dot.image.shape and shapes[0] != dot.image.shape
    m = dot.marks[0]
    assert np.hypot(res.x - m.x, res.y - m.y) < 0.1


def test_a_small_cross_on_plain_ground_is_found_by_the_panel_window():
    """An 8 px '+' at noise 0.05 that neither ``circles`` nor ``symmetry`` finds: step 1's ``hough`` with
    ``mark="auto"`` searches with both windows, and the panel window's finds it (the external one alone does not:
    found in review of a change that searched there with the external window alone)."""
    rng = np.random.default_rng(1)
    sc = synth.mark_scene("cross", size=8, window=48, rng=rng, noise_sigma=0.05, blur_sigma=0.75, contrast=0.5,
                          angle_deg=float(rng.uniform(0, 90)))
    mark = sc.marks[0]
    res = auto.detect(sc.image)
    assert res.found and res.method == "hough" and np.hypot(res.x - mark.x, res.y - mark.y) < 0.3
    alone = auto.detect(sc.image, methods={"hough": HoughParams(window_size=40)})
    assert not alone.found


def test_auto_params_do_not_take_a_seed_methods_name_for_something_else():
    """route_params sends a name to every method that has it: only ``mark`` is shared, meaning the same."""
    ours = set(AutoParams.names())
    for name in SEED_METHODS:
        theirs = METHODS[name].params_type
        if issubclass(theirs, MethodParams):
            assert ours & set(theirs.names()) <= {"mark"}, name


def test_each_seed_method_runs_with_its_own_parameters():
    rng = np.random.default_rng(100 + STYLES.index("dot"))
    img = _scene("dot", rng).image
    sym = METHODS["symmetry"].params_type
    assert detect(img).found
    strict = dataclasses.replace(sym(), **{"max_asymmetry": 1e-6})
    d = detect(img, methods={"symmetry": strict})
    assert not d.answers["symmetry"].found and not d.found
    with pytest.raises(TypeError, match="symmetry"):
        detect(img, methods={"symmetry": AutoParams()})
    assert auto.seed_params(AutoParams(mark="panel"), None)["hough"].mark == "panel"


# --- the steps alone -------------------------------------------------------------------------------------

def test_agreement_and_grouping():
    a, b, far = _found(10.0, 10.0), _found(10.3, 10.0, method="circles"), _found(30.0, 10.0, 0.2, method="hough")
    assert auto.agree(a, b) and not auto.agree(a, far)
    assert not auto.agree(a, _found(11.2, 10.0, sigma=1.0))  # capped at max_agree
    assert auto.agree(a, _found(11.2, 10.0, sigma=1.0), AutoParams(max_agree=1.5))
    assert [[d.method for d in g] for g in auto.group_answers([far, b, a])] == [["circles", "symmetry"], ["hough"]]


def test_disagreement_on_one_mark_and_several_marks():
    img = np.full((80, 80), 0.1, np.float32)
    img[36:45, 36:45] = 0.9
    same = [[_found(40.0, 40.0)], [_found(42.0, 40.0, method="circles")]]
    assert auto.disagreement(img, same, 0.01).startswith("methods disagree")
    apart = [[_found(20.0, 20.0)], [_found(60.0, 60.0, method="circles")]]
    assert "2 different marks" in auto.disagreement(img, apart, 0.01)
    assert auto.disagreement(img, same[:1], 0.01) is None


def test_verification_refuses_a_cut_or_lopsided_mark():
    img = np.full((60, 60), 0.1, np.float32)
    img[27:34, 27:34] = 0.9
    assert auto.verify_centre(img, 30.0, 30.0, 5.0, 0.01).ok
    cut = auto.verify_centre(img, 30.0, 30.0, 28.0, 0.01)
    assert not cut.ok and "cut by the box edge" in cut.reason
    img[27:34, 34:40] = 0.9  # a bar on one side only
    lop = auto.verify_centre(img, 30.0, 30.0, 8.0, 0.01)
    assert not lop.ok and "not centrally symmetric" in lop.reason and lop.asymmetry > 0.2


def test_structure_left_finds_a_second_dot_only():
    img = np.full((80, 80), 0.1, np.float32)
    img[18:23, 18:23] = 0.9
    img[58:63, 58:63] = 0.9
    blanked = auto.blank_disc(img, 20.0, 20.0, 7.0, 0.0)
    assert blanked[20, 20] == pytest.approx(0.1) and img[20, 20] == pytest.approx(0.9)
    rest, blobs = auto.structure_left(blanked, img, 20.0, 20.0, 4.0, 0.01)
    assert rest > 0 and len(blobs) == 1 and blobs[0][:2] == (57, 57)
    alone = auto.blank_disc(blanked, 60.0, 60.0, 7.0, 0.0)
    assert auto.structure_left(alone, img, 20.0, 20.0, 4.0, 0.01) == (0, [])


def test_a_flat_blob_and_its_centroid():
    rng = np.random.default_rng(3)
    img = np.clip(0.1 + rng.normal(0, 0.01, (60, 60)), 0, 1).astype(np.float32)
    img = synth.paint_shape(img, (30.3, 29.6), synth.disc(3.0), 0.9, 8, extent=5)
    bx, by, r, moat = auto.find_flat_blob(img, 0.01, 0.1)
    assert (bx, by) == (30, 30) and 2.0 <= r <= 4.0 and moat >= r + 2.5
    c = auto.blob_centroid(img, _found(float(bx), float(by)), moat, r)
    assert c is not None and c.method == "centroid" and np.hypot(c.x - 30.3, c.y - 29.6) < 0.1
    img[20:40, 34:36] = 0.9  # a wall next to the blob: no flat moat
    assert auto.flat_blob(img, 30, 30, 0.01, 0.1) == "the compact blob's surroundings are not flat"


def test_a_lone_answer_needs_a_score_and_symmetry_a_core():
    rng = np.random.default_rng(100 + STYLES.index("dot"))
    img = _scene("dot", rng).image
    ctx = auto._Context(img, 0.02, AutoParams(), auto.seed_params(AutoParams(), None))
    trace = auto._Trace(noise=0.02)
    weak = _found(60.0, 60.0, score=0.3)
    assert "low score" in auto.lone_answer_refused(ctx, trace, weak, 10.0)
    hollow = _found(5.0, 5.0, score=0.9)  # no core on plain ground
    assert "no compact core" in auto.lone_answer_refused(ctx, trace, hollow, 3.0)
    assert abs(trace.core_snr) < auto.AutoParams().min_core_snr


def test_score_and_size():
    chk = Check(True, "", 0.0, 10.0)
    assert auto.auto_score([_found(score=0.9)], chk) == pytest.approx(0.72)
    assert auto.auto_score([_found(score=0.9), _found(score=0.5, method="circles")], chk) == pytest.approx(0.95)
    assert auto.similar_size(None, 5.0) and not auto.similar_size(25.0, 5.0)


def test_a_crosss_extent_is_bounded_by_what_its_fit_saw():
    """Arms that run out of the fitted patch have undetermined lengths (a fit on a crop returned 1e270 px):
    the mark's extent is what the patch shows, so a cross corroborated on a crop is not 'cut by the box'."""
    fit = CrossFit(x=20.0, y=20.0, sigma_x=0.01, sigma_y=0.01, theta1=0.0, theta2=90.0, length1=1e270,
                   length2=30.0, width=2.0, blur=0.8, amplitude=0.6, sigma0=0.02, noise=0.02,
                   arm_contrast=(0.6, 0.6, 0.6, 0.6), patch_half=23.0)
    d = HoughResult(status="found", x=20.0, y=20.0, score=0.9, sigma=0.01, method="hough", refinement=fit)
    img = np.zeros((40, 40), np.float32)
    assert auto.group_extent(img, [d, _found(20.0, 20.0)], 0.02) == pytest.approx(23.0 + 1.0 + 0.8)
    short = dataclasses.replace(d, refinement=dataclasses.replace(fit, length1=30.0))
    assert auto.group_extent(img, [short], 0.02) == pytest.approx(15.0 + 1.0 + 0.8)


@given(st.integers(1, 30), st.lists(st.tuples(st.integers(0, 29), st.integers(0, 6)), max_size=200),
       st.floats(0.0, 100.0))
def test_ring_percentiles_are_numpys_percentile_per_ring(n, pairs, percentile):
    """Step 3's radial profile: each ring's percentile (ties in value included) as np.percentile gives it."""
    ring = np.array([r % n for r, _ in pairs], int)
    values = np.array([v / 4.0 for _, v in pairs], float)
    ours = auto.ring_percentiles(values, ring, n, percentile)
    for i in range(n):
        on = values[ring == i]
        assert ours[i] == pytest.approx(np.percentile(on, percentile) if on.size else 0.0, abs=1e-12)


def test_ring_percentiles_refuse_rings_beyond_n_and_percentiles_beyond_0_100():
    with pytest.raises(ValueError, match="ring numbers"):
        auto.ring_percentiles(np.array([1.0, 2.0]), np.array([0, 3]), 2, 50.0)
    for q in (-10.0, 150.0, float("nan")):
        with pytest.raises(ValueError, match="percentile"):
            auto.ring_percentiles(np.array([1.0, 2.0]), np.array([0, 1]), 2, q)


def test_a_cross_larger_than_half_the_box_beats_a_dust_speck():
    """A '+' that ``circles`` and ``symmetry`` miss is ``hough``'s before step 4 looks for an isolated dot: a dust
    speck with a flat moat must not be answered instead (the dot's uniqueness only counts structure up to half the
    box across). Found in review of a reordering that ran step 4 first."""
    sc = synth.mark_scene("cross", size=70, window=120, rng=np.random.default_rng(3), noise_sigma=0.02,
                          angle_deg=20.0, blur_sigma=0.8, contrast=0.7)
    speck = synth.blur(synth.coverage(sc.image.shape, (20.3, 98.6), synth.disc(2.5)), 0.8)
    img = synth.paint(sc.image, speck, float(sc.image.max())).astype(np.float32)
    d = detect(img)
    m = sc.marks[0]
    assert d.found and np.hypot(d.x - m.x, d.y - m.y) < 0.1, (d.x, d.y, d.reason)


@given(x=st.floats(-40, 190), y=st.floats(-40, 160), r_in=st.floats(0, 30), width=st.floats(0, 60))
def test_blank_and_ground_level_read_the_disc_as_the_whole_window_defines_it(x, y, r_in, width):
    """The disc and annulus are read from the pixels that can lie in them (asymmetry.in_disc); every pixel of the
    window within the radius, for discs inside, cut by and outside the window, in the window's order."""
    img = np.random.default_rng(3).random((120, 150)).astype(np.float32)
    yy, xx = np.mgrid[0:120, 0:150]
    d = np.hypot(xx - x, yy - y)
    r_out = r_in + width
    ring = (d >= r_in) & (d <= r_out)
    level = float(np.median(img[ring])) if ring.sum() >= 8 else float(np.median(img))
    assert auto.ground_level(img, x, y, r_in, r_out) == level
    disc = d <= r_out
    want = img.copy()
    want[disc] = np.asarray(0.5 + np.random.default_rng(auto.SEED).normal(0.0, 0.02, int(disc.sum())), np.float32)
    assert np.array_equal(auto.blank_disc(img, x, y, r_out, 0.02, level=0.5), want)
