"""A picture per pick: the chosen grasp is marked where its record says, with the side view
at the top of the lift, and the crop the CNN saw."""

import cv2
import numpy as np

from tangle_drake.episode.demo import DemoOptions, run_demo
from tangle_drake.pick.pictures import CHOSEN, TILE
from tangle_drake.scenario.files import resolve_scenario
from tangle_drake.station import camera_model


def test_each_pick_gets_a_picture_with_the_chosen_grasp_marked_at_its_pixel(tmp_path):
    scenario = resolve_scenario("floating_gripper.yaml")
    scenario.pile.parts[0].count = 4
    records = run_demo(DemoOptions(picks=1, scenario=scenario, seed=2,
                                   pictures=tmp_path / "pictures"), lambda _: None)
    tried = [r for r in records if r.view is not None]
    assert tried and sorted(p.name for p in (tmp_path / "pictures").iterdir()) == [
        f"pick_{r.index:03d}.png" for r in tried]
    intrinsics = camera_model(scenario).intrinsics
    width, height = intrinsics.width, intrinsics.height
    for record in tried:
        picture = cv2.imread(str(tmp_path / "pictures" / f"pick_{record.index:03d}.png"))
        u, v = int(np.rint(record.candidate.u)), int(np.rint(record.candidate.v))
        assert tuple(picture[v, u]) == CHOSEN  # the marker sits on the chosen grasp
        assert 1 <= len(record.view.ranked) <= 5 and record.view.depth.shape == (height, width)
        assert record.candidate in [s.candidate for s in record.view.ranked]
        side = picture[40:height, width:]
        assert side.std() > 10  # the side view of the lift, not an empty panel
        crop_tile = picture[height + 40:height + 20 + TILE, width + 8:width + 8 + TILE]
        assert crop_tile.std() > 5  # the crop the CNN saw
