"""What a user sees in the exported playback page, measured in headless Chromium (one browser session).

The robot fills the 3-D view (pixels that change when the robot node is hidden, over the view's pixels),
the picture changes with time, the slider and a click on a plot seek (the picture then equals the page
opened at that time), the plot cursor follows playback, ur5's meshes are drawn. Screenshots go to
test-artifacts/.
"""
import time
import warnings

import numpy as np
import pytest
from browser import HAVE_BROWSER, Browser
from conftest import ROOT

import manipdyn as md
from manipdyn import viz

pytestmark = pytest.mark.skipif(not HAVE_BROWSER, reason="Debian's chromium and chromium-driver are not installed")
ART = ROOT / "test-artifacts"
SIZE = (1000, 640)                 # window; the 3-D view is about 660 × 460 of it
COVERAGE = 0.15                    # share of the 3-D view's pixels the robot must cover
FRACTIONS = (0.25, 0.5, 0.75)      # times (share of the motion) at which coverage is measured


def zoo(name):
    from manipdyn.validation import robots_dir
    return robots_dir() / {"ur5": "ur_description/urdf/ur5_robot.urdf",
                           "panda": "panda_description/urdf/panda.urdf"}[name]


@pytest.fixture(scope="module")
def browser():
    with Browser(*SIZE) as b:
        yield b


_PAGES = {}


def page(name, tmp_path_factory):
    """(file, scene) of a model's demo page, built once per test session."""
    if name not in _PAGES:
        path = zoo(name) if name in ("ur5", "panda") else ROOT / "urdf" / f"{name}.urdf"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", viz.GeometryWarning)
            model = md.load_urdf(path)
            m = viz.demo_motion(model, path)
            out = tmp_path_factory.mktemp("pages") / f"{name}.html"
            sc = viz.export_html(model, path, m.pop("t"), m.pop("Q"), out, **m)
        _PAGES[name] = (out, sc)
    return _PAGES[name]


_loads = [0]


def open_at(b, out, t=None):
    """Open the page (a fresh load each time: a new query string), paused at t when given."""
    _loads[0] += 1
    b.open(f"file://{out}?load={_loads[0]}" + ("" if t is None else f"#t={t:.6f}"))
    b.frames(3)


def pane(b):
    """(x, y, w, h) of the 3-D view in the screenshot."""
    r = b.run("var r = document.getElementById('meshcat-pane').getBoundingClientRect();"
              "return [r.left, r.top, r.width, r.height];")
    return [int(round(v)) for v in r]


def robot_pixels(b, shot):
    """Pixels of the 3-D view where the robot is: the picture against the same one with /manipdyn hidden."""
    b.run("viewer.set_property(['manipdyn'], 'visible', false); viewer.set_dirty();")
    b.frames(3)
    empty = b.shot()
    b.run("viewer.set_property(['manipdyn'], 'visible', true); viewer.set_dirty();")
    b.frames(3)
    x, y, w, h = pane(b)
    return (np.abs(shot - empty).sum(axis=2) > 30)[y:y + h, x:x + w]


@pytest.mark.parametrize("name", ["aau_arm", "spm", "fourbar"])
def test_bundled_robot_fills_the_view_and_moves(name, browser, tmp_path_factory):
    out, sc = page(name, tmp_path_factory)
    cover, shots = [], []
    for k, f in enumerate(FRACTIONS):
        t = sc.t0 + f * sc.times[-1]
        open_at(browser, out, t)
        shots.append(browser.shot(ART / f"play_{name}_{k}.png"))
        cover.append(robot_pixels(browser, shots[-1]).mean())
        assert browser.run("return window.manipdyn.state.playing") is False       # #t= opens paused
    moved = (np.abs(shots[0] - shots[-1]).sum(axis=2) > 30).mean()
    print(f"\n{name}: robot covers {', '.join(f'{c:.1%}' for c in cover)} of the 3-D view at "
          f"{FRACTIONS} of the motion; {moved:.1%} of the page changes between the first and last")
    assert min(cover) >= COVERAGE, cover
    assert moved > 0.01


def test_ground_is_under_the_robot():
    # nothing drawn goes below the ground, and the ground is under the base (at or below the base origin)
    for name in ("aau_arm", "spm", "fourbar"):
        path = ROOT / "urdf" / f"{name}.urdf"
        model = md.load_urdf(path)
        t, Q = viz.demo(model, path)
        sc = viz.scene_for(model, path, t, Q, plots=False)
        lowest = min(float(T[:, 2, 3].min()) for T in sc.frames.values())
        assert sc.view["ground_z"] <= min(lowest, 0.0) + 1e-12, name


def test_slider_seeks_and_cursor_follows(browser, tmp_path_factory):
    out, sc = page("aau_arm", tmp_path_factory)
    a, b_ = 1.0, 4.0
    open_at(browser, out, b_)
    reference = browser.shot(ART / "play_seek_reference.png")
    open_at(browser, out, a)
    before = browser.shot()
    x0 = float(browser.run("return document.querySelector('#manipdyn-plot-q .manipdyn-cursor').getAttribute('x1')"))
    browser.run("var s = document.getElementById('manipdyn-time'); s.value = arguments[0];"
                "s.dispatchEvent(new Event('input'));", str(b_))
    browser.frames(3)
    after = browser.shot(ART / "play_seek_after.png")
    state = browser.run("return [window.manipdyn.state.t, window.manipdyn.state.playing,"
                        "viewer.animator.actions[0].time, document.getElementById('manipdyn-clock').textContent,"
                        "document.querySelector('#manipdyn-plot-tau .manipdyn-cursor').getAttribute('x1')]")
    assert abs(state[0] - b_) < 1e-9 and state[1] is False and abs(state[2] - b_) < 1e-6
    assert "4.000" in state[3]
    x1 = float(state[4])
    # the cursor moved right by (b − a) / span of the plot width (viewBox units: 46 .. 412)
    assert abs((x1 - x0) - (b_ - a) / sc.times[-1] * (420 - 46 - 8)) < 0.05, (x0, x1)
    same = (np.abs(after - reference).sum(axis=2) > 30).mean()
    differs = (np.abs(after - before).sum(axis=2) > 30).mean()
    print(f"\nseek: {differs:.1%} of the page changed; {same:.2%} differs from the page opened at {b_} s")
    assert differs > 0.01 and same < 0.002


def test_playback_moves_cursor_and_click_on_plot_seeks(browser, tmp_path_factory):
    out, sc = page("spm", tmp_path_factory)
    open_at(browser, out)                                      # no #t=: plays, at 0.25× for a 0.25 s motion
    # the page's time, its cursor and the rAF timestamp of the frame that set that time (st.last, in ms)
    cursor = ("return [window.manipdyn.state.t, +document.querySelector('#manipdyn-plot-tau .manipdyn-cursor')"
              ".getAttribute('x1'), window.manipdyn.state.last]")
    w0 = time.time()
    t0, x0, last0 = browser.run(cursor)
    while True:                            # a loaded machine renders fewer frames: wait up to 10 s for motion
        time.sleep(0.4)
        t1, x1, last1 = browser.run(cursor)
        wall = time.time() - w0
        if (last0 is not None and last1 is not None and (t1 - t0) % sc.times[-1] > 0.02) or wall > 10:
            break
    assert browser.run("return document.getElementById('manipdyn-speed').value") == "0.25"
    print(f"\nplaying: t {t0:.4f} -> {t1:.4f} s in {wall:.2f} s of wall time; cursor {x0:.1f} -> {x1:.1f}")
    # the motion time advanced by 0.25 x the page's own frame clock (looping over the 0.25 s motion): exact, so a
    # slow machine (sparse frames, slow round trips) cannot make it flaky; the frame clock ran no faster than the wall
    assert last0 is not None and last1 is not None, 'the page drew no frame in 10 s'
    T = sc.times[-1]
    page_s = (last1 - last0) / 1000
    advanced, expected = (t1 - t0) % T, (0.25 * page_s) % T
    assert 0.02 < advanced and min(abs(advanced - expected), T - abs(advanced - expected)) < 1e-9, (advanced, expected)
    assert 0 < page_s <= wall + 2.0 and x1 != x0        # (+ the age of the first frame read, < 2 s even when loaded)
    # the leg singularity is marked on the time axis of every plot
    assert browser.run("return document.querySelectorAll('#manipdyn-plot-tau .manipdyn-mark').length") == 1
    # a click at 40 % of the torque plot's time axis seeks there and pauses
    t_click = browser.run("""
        var svg = document.querySelector('#manipdyn-plot-tau svg'), r = svg.getBoundingClientRect();
        var x = 46 + 0.4 * (420 - 46 - 8);
        svg.dispatchEvent(new MouseEvent('click', {clientX: r.left + x / 420 * r.width, clientY: r.top + 20,
                                                   bubbles: true}));
        return [window.manipdyn.state.t, window.manipdyn.state.playing];""")
    axis_end = max(sc.times[-1], max(m["t"] for m in sc.plots["marks"]))
    assert abs(t_click[0] - 0.4 * axis_end) < 2e-3 and t_click[1] is False


def test_joint_picker_and_plot_series(browser, tmp_path_factory):
    out, sc = page("aau_arm", tmp_path_factory)
    open_at(browser, out, 1.0)
    n = browser.run("return document.querySelectorAll('#manipdyn-plot-q polyline').length")
    assert n == 5 and {g["key"] for g in sc.plots["groups"]} == {"q", "v", "tau"}
    browser.run("var c = document.querySelector('#manipdyn-joints input[data-joint=\"joint1\"]'); c.click();")
    shown = browser.run("return Array.from(document.querySelectorAll('#manipdyn-plot-tau polyline'))"
                        ".map(function (p) { return p.getAttribute('data-series'); })")
    assert shown == ["joint2", "joint3", "joint4", "joint5"]


@pytest.mark.parametrize("name", ["ur5", "panda"])
def test_zoo_arm_meshes_are_drawn(name, browser, tmp_path_factory):
    out, sc = page(name, tmp_path_factory)
    open_at(browser, out, 2.0)
    shot = browser.shot(ART / f"play_{name}.png")
    cover = robot_pixels(browser, shot).mean()
    # every link's DAE mesh was parsed into triangles (thousands of vertices in all)
    vertices = browser.run("""var n = 0, meshes = 0;
        viewer.scene_tree.find(['manipdyn']).object.traverse(function (o) {
          if (o.isMesh && o.geometry && o.geometry.attributes.position) { meshes++; n += o.geometry.attributes.position.count; } });
        return [meshes, n];""")
    has = browser.run("""return [!!document.querySelector('input[type=range]'), document.querySelectorAll('svg').length];""")
    print(f"\n{name}: {vertices[0]} meshes, {vertices[1]} vertices; robot covers {cover:.1%} of the 3-D view")
    assert vertices[0] >= 7 and vertices[1] > 10_000 and cover > 0.10
    assert has[0] and has[1] >= 3, has                       # the time slider and the q, q̇, τ plots
