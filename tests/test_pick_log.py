"""The pick log: each weighed grasp of a closed-loop run becomes a labelled sample in the
format of `collect`, runs append to it, and `train`'s loader reads it."""

import numpy as np
import pytest

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.dataset import load_samples, read_manifest
from tangle_drake.episode.demo import DemoOptions, run_demo
from tangle_drake.perception.crops import CropSpec
from tangle_drake.pick.outcome import Outcome
from tangle_drake.pick.pick_log import OUTCOME_CODES
from tangle_drake.scenario.files import resolve_scenario
from tangle_drake.tangle_cnn.training_data import load_checked_samples

FIELDS = ("label", "outcome", "weighed_parts", "sim_lifted", "sim_held", "crop", "depth_m",
          "pile_seed", "task", "rank", "u", "v")


def small_scenario():
    scenario = resolve_scenario("floating_gripper.yaml")
    scenario.view_cameras = []
    scenario.pile.parts[0].count = 4
    return scenario


def test_each_weighed_grasp_is_logged_with_its_weighing_as_the_label(tmp_path):
    log = tmp_path / "log"
    lines: list[str] = []
    first = run_demo(DemoOptions(picks=1, scenario=small_scenario(), seed=2, log_picks=log),
                     lines.append)
    samples = load_samples(log, FIELDS)
    weighed = [r for r in first if r.verdict is not None]
    assert len(samples["label"]) == len(weighed) >= 1
    manifest = read_manifest(log)
    spec = CropSpec(**manifest["crop"])
    assert f"{len(weighed)} grasp(s) added" in lines[-1]
    for row, record in enumerate(weighed):
        assert samples["outcome"][row] == OUTCOME_CODES[record.verdict]
        assert samples["label"][row] == {2: 1, 1: 0}.get(int(samples["outcome"][row]), -1)
        assert samples["weighed_parts"][row] == pytest.approx(record.estimate.parts)
        assert samples["sim_lifted"][row] == record.truth.lifted
        assert samples["sim_held"][row] == record.truth.held
        assert (samples["u"][row], samples["v"][row]) == pytest.approx(
            (record.candidate.u, record.candidate.v))
        np.testing.assert_array_equal(samples["crop"][row], record.crop)
        # Between the open fingers (the closing direction runs along the crop's rows) lies
        # the grasped part: above the fingertips, within their reach (elsewhere the crop may
        # show a wall's rim).
        c, half = spec.size_px // 2, round(record.candidate.width_m / 2 * spec.size_px
                                           / spec.size_m)
        between = record.crop[c - 4:c + 5, c - half:c + half + 1]
        assert record.candidate.depth_m - 0.03 < between.min() < record.candidate.depth_m
    assert (samples["pile_seed"] == 2).all()
    assert manifest["source"] == "pick log" and manifest["part"] == "u_hook"
    assert spec.size_px == record.crop.shape[0]

    run_demo(DemoOptions(picks=1, scenario=small_scenario(), seed=3, log_picks=log),
             lambda _: None)
    more = load_samples(log, FIELDS)
    assert len(more["label"]) > len(samples["label"])  # appended, the first run kept
    np.testing.assert_array_equal(more["crop"][:len(samples["label"])], samples["crop"])
    assert list(more["task"]) == list(range(len(more["task"])))
    assert set(more["pile_seed"].tolist()) == {2, 3}
    labelled, _, _ = load_checked_samples(log)  # what `train` reads
    assert len(labelled["label"]) == int((more["label"] >= 0).sum())
    assert any(r.outcome is Outcome.ONE for r in first)


def test_the_open_loop_cannot_log_and_another_part_is_refused(tmp_path):
    with pytest.raises(TangleDrakeError, match="leave out --open-loop"):
        run_demo(DemoOptions(picks=1, open_loop=True, log_picks=tmp_path / "a"))
    log = tmp_path / "log"
    run_demo(DemoOptions(picks=1, scenario=small_scenario(), seed=2, log_picks=log),
             lambda _: None)
    with pytest.raises(TangleDrakeError, match="other settings"):
        run_demo(DemoOptions(picks=1, scenario=small_scenario(), part="c_ring", seed=2,
                             log_picks=log), lambda _: None)
