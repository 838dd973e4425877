"""Output helpers: readable figures of long runs, the video overlay, links of the docs (issue 17,
cases 13-15)."""

import re
from pathlib import Path

import numpy as np
import pytest

from robust_ismpc.plotting.runs import DETAIL_S, OVERVIEW_POINTS, detail_window, plot_run
from robust_ismpc.runs.trace import CHANNELS, Trace

ROOT = Path(__file__).resolve().parent.parent


def _walk_trace(duration_s: float, dt: float = 0.01) -> Trace:
    """A synthetic straight walk at 0.2 m/s (every channel filled)."""
    t = np.arange(0.0, duration_s, dt)
    channels = {k: np.zeros((len(t), *shape)) for k, shape in CHANNELS.items()}
    channels["t_s"] = t
    channels["com_m"][:, 0] = 0.2 * t
    channels["zmp_m"][:, 0] = 0.2 * t
    channels["box_centre_m"][:, 0] = 0.2 * t
    channels["box_half_m"][:] = 0.02
    channels["feasibility_m"][:] = np.nan
    channels["sole_meas_m"][:] = np.nan  # as on the LIP
    n_steps = int(duration_s / 0.7) + 3
    touchdown = 0.7 * np.arange(n_steps)
    side = np.where(np.arange(n_steps) % 2 == 0, 1.0, -1.0)
    steps = np.column_stack([0.14 * np.arange(n_steps), 0.1 * side])
    return Trace(channels=channels, footsteps_m=steps, candidate_footsteps_m=steps, footstep_touchdown_s=touchdown,
                 footstep_side=side, footstep_yaw_rad=np.zeros(n_steps),
                 meta={"robot": "g1", "sim": "lip", "controller": "nominal", "sole_length_m": 0.17,
                       "sole_width_m": 0.05})


def test_long_run_figure_shows_the_last_seconds_and_an_overview(tmp_path, monkeypatch):
    """Case 15: a 600 s run is drawn over its last 20 s (top view and time axes) with a decimated
    overview of the whole run; a 10 s run is drawn whole."""
    import matplotlib.figure

    figures = []
    original = matplotlib.figure.Figure.savefig

    def keep(fig, *args, **kwargs):
        figures.append(fig)
        return original(fig, *args, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", keep)
    long_run = _walk_trace(600.0)
    assert detail_window(long_run) == pytest.approx((600.0 - 0.01 - DETAIL_S, 600.0 - 0.01))
    assert detail_window(_walk_trace(10.0)) == pytest.approx((0.0, 9.99))
    plot_run(long_run, tmp_path / "gait.png")
    top, ax_x, _, _, overview = figures[-1].axes
    assert top.get_xlim()[1] - top.get_xlim()[0] < 10.0  # metres: the last 20 s at 0.2 m/s, not 120 m
    assert ax_x.get_xlim()[0] > 570.0
    assert overview.get_xlim()[0] < 10.0 and overview.get_xlim()[1] > 590.0
    assert max(len(line.get_xdata()) for line in overview.lines) <= OVERVIEW_POINTS
    plot_run(_walk_trace(10.0), tmp_path / "short.png")
    assert len(figures[-1].axes) == 4


def test_with_imperfect_sensing_the_gait_figure_shows_the_velocity_read_against_the_truth(tmp_path, monkeypatch):
    """A run under a sensing model other than ideal gets a panel with the CoM velocity the
    controller read beside the true one (both drawn, per axis); an ideal run does not."""
    import matplotlib.figure

    figures = []
    original = matplotlib.figure.Figure.savefig
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig",
                        lambda fig, *a, **k: (figures.append(fig), original(fig, *a, **k))[1])
    trace = _walk_trace(10.0)
    trace.channels["com_vel_mps"][:, 0] = 0.2
    trace.channels["com_vel_read_mps"][:, 0] = 0.2 + 0.03 * np.sin(trace.channels["t_s"] * 40.0)
    trace.meta["sensing"] = {"name": "realistic"}
    plot_run(trace, tmp_path / "sensed.png")
    panel = figures[-1].axes[4]
    assert panel.get_ylabel() == "CoM velocity [m/s]"
    drawn = [line.get_ydata() for line in panel.lines]
    assert any(np.allclose(y, trace.channels["com_vel_read_mps"][:, 0]) for y in drawn)
    assert any(np.allclose(y, 0.2) for y in drawn)
    trace.meta["sensing"] = {"name": "ideal"}
    plot_run(trace, tmp_path / "ideal.png")
    assert len(figures[-1].axes) == 4


def test_the_gait_figure_is_drawn_once(tmp_path, monkeypatch):
    """Writing the gait figure renders it once (an operation count: a layout engine left on the
    figure makes ``savefig`` render it twice), and the PNG is complete."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    draws = []
    original = FigureCanvasAgg.draw

    def counting(canvas):
        draws.append(canvas)
        return original(canvas)

    monkeypatch.setattr(FigureCanvasAgg, "draw", counting)
    path = plot_run(_walk_trace(10.0), tmp_path / "gait.png")
    assert len(draws) == 1
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 10_000


def test_video_overlay_draws_time_label_and_a_push_arrow():
    """Case 14: the overlay writes text in the top-left corner, and a red arrow appears only while
    an external force acts."""
    mujoco = pytest.importorskip("mujoco")
    pytest.importorskip("PIL")
    from robust_ismpc.sim.video import draw_overlay

    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body><freejoint/><geom size='0.1'/></body></worldbody></mujoco>")
    data = mujoco.MjData(model)
    camera = mujoco.MjvCamera()
    camera.azimuth, camera.elevation = 135.0, -15.0
    blank = np.zeros((120, 160, 3), dtype=np.uint8)
    quiet = draw_overlay(blank, data, "robust", camera)
    assert quiet[4:20, 4:80].any() and not quiet[40:, :].any()
    data.xfrc_applied[1, :3] = [0.0, 30.0, 0.0]
    pushed = draw_overlay(blank, data, "robust", camera)
    red = (pushed[..., 0] > 150) & (pushed[..., 1] < 100)
    assert red[30:, :].sum() > 20
    assert not ((quiet[..., 0] > 150) & (quiet[..., 1] < 100)).any()


def _anchors(markdown: str) -> set[str]:
    """GitHub anchors of the headings of a Markdown text."""
    found = set()
    for heading in re.findall(r"^#+\s+(.*)$", markdown, flags=re.M):
        slug = re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")
        found.add(slug)
    return found


@pytest.mark.parametrize("page", ["README.md", *sorted(p.relative_to(ROOT).as_posix()
                                                       for p in (ROOT / "docs").glob("*.md"))])
def test_links_of_the_docs_resolve(page):
    """Case 13: every relative link of the README and the docs names an existing file and, with a
    #fragment, an existing heading."""
    path = ROOT / page
    text = path.read_text()
    for target in re.findall(r"\]\(([^)\s]+)\)", text):
        if re.match(r"[a-z]+://", target) or target.startswith("mailto:"):
            continue
        file_part, _, fragment = target.partition("#")
        linked = (path.parent / file_part).resolve() if file_part else path
        assert linked.exists(), f"{page}: {target} does not exist"
        if fragment and linked.suffix == ".md":
            assert fragment in _anchors(linked.read_text()), f"{page}: no heading for #{fragment} in {file_part}"


def test_a_run_figure_title_states_what_happened_in_the_run(tmp_path, monkeypatch):
    """The gait figure's title says whether the run fell (and when) or walked (and how long), with
    its step-timing adaptations and, when the run reports one, its path deviation."""
    import matplotlib.figure

    from robust_ismpc.plotting.runs import run_outcome

    titles = []
    original = matplotlib.figure.Figure.savefig

    def keep(fig, *args, **kwargs):
        titles.append(fig.axes[0].get_title())
        return original(fig, *args, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", keep)
    walked = _walk_trace(10.0)
    walked.meta.update(fell=False, timing_adaptations=0, path_deviation_m=0.012)
    fell = _walk_trace(3.4)
    fell.meta.update(fell=True, timing_adaptations=2)
    plot_run(walked, tmp_path / "walked.png", title="paper-bag seed 0: robust")
    plot_run(fell, tmp_path / "fell.png", title="paper-bag seed 0: nominal")
    assert "walked 10.0 s" in titles[0] and "fell" not in titles[0]
    assert "0 step-timing adaptations" in titles[0] and "path deviation 1.2 cm" in titles[0]
    assert "fell at 3.39 s" in titles[1] and "walked" not in titles[1]
    assert "2 step-timing adaptations" in titles[1] and "path deviation" not in titles[1]
    assert titles[0].startswith("paper-bag seed 0: robust\n") and titles[1].startswith("paper-bag seed 0: nominal\n")
    assert run_outcome(fell) in titles[1]
