"""The pick diagram's wiring: the same builder serves the simulated and the hardware station."""

from tangle_drake.graspability import GraspabilityParams
from tangle_drake.pick.diagram import (
    build_pick_diagram,
    closed_loop_settings,
    default_graspability_params,
)
from tangle_drake.pick.load_path import LoadPathMonitor
from tangle_drake.pick.outcome import LiftMonitor, TrayMonitor
from tangle_drake.pick.truth import PickTruth
from tangle_drake.planning.arm_motion import ArmMotion
from tangle_drake.scenario.files import resolve_scenario
from tangle_drake.selection.choice import TangleChoice
from tangle_drake.selection.methods import fixed_selection
from tangle_drake.station import build_station


def test_the_pick_diagram_wires_to_the_hardware_station_without_the_monitor():
    scenario = resolve_scenario(None)
    station = build_station(scenario, hardware=True)  # in-process LCM (memq://)
    selection = fixed_selection(TangleChoice(None, "graspability"), scenario)
    pick = build_pick_diagram(scenario, ArmMotion(scenario.bin), selection,
                              station=station)
    assert pick.monitor is None and pick.truth is None
    assert not pick.diagram.HasOutputPort("truth")


TRUTH = (LiftMonitor, LoadPathMonitor, TrayMonitor, PickTruth)


def upstream(diagram, system) -> list[tuple[object, str]]:
    """Every (system, output port name) that feeds ``system``, directly or through others,
    stopping at the station (whose ports are what a real cell has, or ``sim.*``)."""
    sources = {}
    for (dest, _), (source, port) in diagram.connection_map().items():
        sources.setdefault(dest, []).append((source, source.get_output_port(port).get_name()))
    found, todo, seen = [], [system], set()
    while todo:
        current = todo.pop()
        for source, name in sources.get(current, []):
            found.append((source, name))
            if source.get_name() != "station" and id(source) not in seen:
                seen.add(id(source))
                todo.append(source)
    return found


def test_no_planner_input_is_fed_by_the_simulations_truth():
    """Controllers never see the simulation's truth: nothing upstream of the planner is a
    ``sim.*`` port or a truth monitor, while the monitors are there beside it."""
    scenario = resolve_scenario(None)
    selection = fixed_selection(TangleChoice(None, "graspability"), scenario)
    pick = build_pick_diagram(scenario, ArmMotion(scenario.bin), selection,
                              settings=closed_loop_settings(scenario))
    feeding = upstream(pick.diagram, pick.planner)
    assert any(name == "camera.depth_image" for _, name in feeding)  # it does see the camera
    assert not [name for source, name in feeding if isinstance(source, TRUTH)
                or name.startswith("sim.")]
    assert pick.truth is not None and pick.monitor is not None
    assert any(isinstance(source, TRUTH) for source, _ in upstream(pick.diagram, pick.truth))


def test_default_graspability_params_fit_the_wire_and_the_palm():
    scenario = resolve_scenario(None)
    params = default_graspability_params(scenario)
    defaults = GraspabilityParams()
    # One depth level less than the U-hook's 6 mm wire; the palm's 14.5 mm overhang in pixels
    # at the floor (0.5 m below a 579 px focal length: 0.86 mm a pixel).
    assert params.insertion_depth_m == 0.006 - defaults.level_step_m
    assert params.roi_margin_px == 17
    assert params.top_k == 2 * defaults.top_k
