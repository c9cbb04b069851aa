"""The pick diagram's wiring: the same builder serves the simulated and the hardware station."""

from tangle_drake.graspability import GraspabilityParams
from tangle_drake.pick.diagram import build_pick_diagram, default_graspability_params
from tangle_drake.planning.arm_motion import ArmMotion
from tangle_drake.scenario.files import resolve_scenario
from tangle_drake.selection.choice import TangleChoice
from tangle_drake.station import build_station


def test_the_pick_diagram_wires_to_the_hardware_station_without_the_monitor():
    scenario = resolve_scenario(None)
    station = build_station(scenario, hardware=True)  # in-process LCM (memq://)
    pick = build_pick_diagram(scenario, TangleChoice(None, "graspability"),
                              ArmMotion(scenario.bin), station=station)
    assert pick.monitor is None
    assert not pick.planner.GetInputPort("lifted_count").HasValue(
        pick.planner.GetMyContextFromRoot(pick.diagram.CreateDefaultContext()))


def test_default_graspability_params_fit_the_wire_and_the_palm():
    scenario = resolve_scenario(None)
    params = default_graspability_params(scenario)
    defaults = GraspabilityParams()
    # One depth level less than the U-hook's 6 mm wire; the palm's 14.5 mm overhang in pixels
    # at the floor (0.5 m below a 579 px focal length: 0.86 mm a pixel).
    assert params.insertion_depth_m == 0.006 - defaults.level_step_m
    assert params.roi_margin_px == 17
    assert params.top_k == 2 * defaults.top_k
