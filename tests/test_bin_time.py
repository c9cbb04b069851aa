"""The bin's busy time per pick (``pick.bin_time.BinTime``): what bounds two arms sharing it."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from tangle_drake.pick.bin_time import BinTime
from tangle_drake.pick.modes import Mode
from tangle_drake.pick.outcome import PickRecord
from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER
from tangle_drake.scenario import BinConfig

BIN = BinConfig()  # floor 0.93 m, 10 cm walls unless set
RIM = BIN.floor_height + BIN.wall_height
TIPS = DEFAULT_GRIPPER.reach - DEFAULT_GRIPPER.tcp_offset  # fingertips below the tool centre


class HeightMotion:
    """A carrier whose measured state is the tool centre's height."""

    measured_port = "carrier.state_measured"
    measured_size = 1

    def tool_height(self, measured: np.ndarray) -> float:
        return float(measured[0])


def test_the_hand_in_the_bin_and_the_look_are_booked_to_their_pick():
    system = BinTime(HeightMotion(), BIN, 0.02)
    simulator = Simulator(system)
    context = simulator.get_mutable_context()

    def hold(seconds: float, height: float, mode: Mode, pick: int | None) -> None:
        system.GetInputPort(HeightMotion.measured_port).FixValue(context, [height])
        system.GetInputPort("mode").FixValue(context, mode)
        system.GetInputPort("current_pick").FixValue(
            context, None if pick is None else PickRecord(index=pick))
        simulator.AdvanceTo(context.get_time() + seconds)

    def times():
        return system.GetOutputPort("bin_times").Eval(context)

    above, below = RIM + TIPS + 0.05, RIM + TIPS - 0.01  # fingertips 5 cm over, 1 cm under
    hold(0.4, above, Mode.SETTLE, None)  # the look before pick 1: no pick yet
    assert times().pending[1] == pytest.approx(0.4, abs=0.021) and times().look == {}
    hold(0.3, above, Mode.APPROACH, 1)  # neither in the bin nor looking
    hold(0.8, below, Mode.DESCEND, 1)
    hold(0.2, above, Mode.TRANSFER, 1)
    assert times().in_bin[1] == pytest.approx(0.8, abs=0.021)
    assert times().look[1] == pytest.approx(0.4, abs=0.021)  # the look that chose it
    assert times().pending == (0.0, 0.0)
    hold(0.5, below, Mode.STIR, None)  # between picks: booked to the next one
    hold(0.2, below, Mode.DESCEND, 2)
    assert times().in_bin[2] == pytest.approx(0.7, abs=0.041)
    assert times().in_bin[1] == pytest.approx(0.8, abs=0.021)  # unchanged
