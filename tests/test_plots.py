"""The report figure (neuroslam.lab.plots.plot_report): what it shows with and without ground truth."""

from __future__ import annotations

import numpy as np

from neuroslam.lab.plots import plot_report


def _run(frames: int = 60, height: float = 0.0):
    t = np.arange(frames) * 0.1
    truth = np.column_stack([np.cos(t / 3) * 5, np.sin(t / 3) * 5, np.full(frames, height), t / 3 + np.pi / 2])
    estimate = truth + np.column_stack([np.full(frames, 0.1), np.zeros((frames, 3))])
    arguments = {"odometry": truth * 1.05, "estimate": estimate, "experiences": estimate[::5],
                 "experience_frames": np.arange(0, frames, 5),
                 "links": np.column_stack([np.arange(11), np.arange(1, 12)]),
                 "template_ids": np.arange(frames) // 5, "experience_ids": np.arange(frames) // 5, "times": t}
    return arguments, truth


def test_the_report_marks_closures_colours_levels_and_heads_with_numbers(tmp_path):
    arguments, truth = _run()
    levels = (np.arange(60) >= 30).astype(int)
    figure, (top, _space, _ids, errors, side) = plot_report(
        truth=truth, **arguments, title="a run", headline="SLAM ATE 0.10 m", closure_frames=np.array([40, 50]),
        true_levels=levels, path=tmp_path / "report.png")
    assert (tmp_path / "report.png").read_bytes()[:4] == b"\x89PNG"
    labels = [text.get_text() for text in top.get_legend().get_texts()]
    assert {"ground truth, level 0", "ground truth, level 1", "SLAM", "odometry", "loop closure (2)"} <= set(labels)
    assert "SLAM ATE 0.10 m" in figure._suptitle.get_text()
    assert len(errors.lines) == 2 + 2  # SLAM and odometry errors, one line per closure
    low, high = side.get_ylim()
    assert high - low >= 1.0  # a flat route: a metre of height axis at least, not magnified round-off


def test_without_ground_truth_the_report_draws_the_estimate_and_says_there_is_no_score():
    arguments, _ = _run(height=3.0)
    _figure, (top, _space, _ids, errors, _side) = plot_report(truth=None, **arguments)
    labels = [text.get_text() for text in top.get_legend().get_texts()]
    assert "SLAM" in labels and not any("ground truth" in label for label in labels)
    assert not errors.axison and "no ground truth" in errors.texts[0].get_text()


def _link_lines(axes):
    """The line collections of ``axes`` (the map's links), 2-D or 3-D."""
    from matplotlib.collections import LineCollection

    return [collection for collection in axes.collections if isinstance(collection, LineCollection)]


def test_the_map_links_are_drawn_in_the_top_and_3d_views():
    """Each link of the map is one segment between its two experiences, in the top view and in 3-D (without
    ground truth the map is drawn where it is, not aligned)."""
    arguments, _ = _run()
    _figure, (top, space, _ids, _errors, _side) = plot_report(truth=None, **arguments)
    segments = arguments["experiences"][arguments["links"]][:, :, :3]
    (flat,), (solid,) = _link_lines(top), _link_lines(space)
    np.testing.assert_array_equal(np.array(flat.get_segments()), segments[:, :, :2])
    np.testing.assert_array_equal(np.array(solid._segments3d), segments)


def test_a_map_without_links_is_drawn():
    """A run too short to link two experiences (one experience, no links) still gets its report."""
    arguments, truth = _run(frames=4)
    arguments.update(experiences=arguments["estimate"][:1], experience_frames=np.array([0]),
                     links=np.zeros((0, 2), dtype=int))
    _figure, (top, space, _ids, _errors, _side) = plot_report(truth=truth, **arguments)
    assert not _link_lines(top) and not _link_lines(space)
