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
