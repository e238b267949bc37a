"""The generalization benchmark's summary counts largely blind worlds apart without hiding them (issue 23)."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import generalization


def _row(world: str, slam: float, odometry: float, blind_distance: float, blind_yaw: float = 0.0) -> dict:
    return {"world": world, "status": "ok", "ate_rmse_m.slam": str(slam), "ate_rmse_m.odometry": str(odometry),
            "distance_m": "500", "loop_closures": "10", "false_loop_closures": "0", "level_accuracy": "1.0",
            "experiences": "100", "blind_share.distance": str(blind_distance), "blind_share.yaw": str(blind_yaw)}


def test_worlds_blind_on_more_than_a_quarter_of_their_frames_are_counted_apart():
    rows = generalization.world_rows([_row("a", 1.0, 4.0, 0.10), _row("b", 12.0, 13.0, 0.40),
                                      _row("c", 3.0, 4.0, 0.25), _row("d", 9.0, 10.0, 0.0, blind_yaw=0.3)])
    summary = generalization.distribution(rows)
    assert summary["worlds"] == 4 and summary["targets"]["halves"]["met"] == 1  # every world is counted
    assert summary["targets"]["no_catastrophe"]["met"] == 2
    apart = summary["largely_blind"]
    assert apart["worlds"] == ["b", "d"]  # 0.25 is not more than a quarter
    others = apart["others"]
    assert others["worlds"] == 2 and others["targets"]["no_catastrophe"]["met"] == 2
    assert others["slam_ate_m"]["worst"] == 3.0
    printed = "\n".join(generalization.report(summary))
    assert "2 of them blind in distance or yaw on more than 25% of their frames (b, d)" in printed


def test_a_run_without_blind_worlds_reports_them_all_alike():
    rows = generalization.world_rows([_row("a", 1.0, 4.0, 0.10), _row("b", 3.0, 4.0, 0.0)])
    summary = generalization.distribution(rows)
    assert "largely_blind" not in summary
    assert "blind in distance" not in "\n".join(generalization.report(summary))
