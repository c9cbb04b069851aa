"""One station builder, for simulation and hardware: ``build_station(scenario, hardware=...)``.

As Drake's ``MakeHardwareStation``: the scenario says which models to load (``directives``) and
which driver runs each (``model_drivers``); every driver has a simulated branch and an LCM
branch (:mod:`tangle_drake.drivers`) with the same ``{model}.{port}`` names, so a controller
wired to one station is wired to the other. For the shipped scenarios:

=============================== ====== ====================================================
port                            dir    meaning
=============================== ====== ====================================================
``nextage.position``            in     the arm's joint positions, ``robot.NEXTAGE_JOINTS``
                                       order (``pick_demo.yaml``)
``gantry.position``             in     the gantry's x, y, z (m) and yaw (rad)
                                       (``floating_gripper.yaml``)
``{carrier}.position_measured`` out    measured joint positions
``{carrier}.state_measured``    out    measured [positions, velocities]
``gripper.position``            in     commanded opening width between the finger pads, m
``gripper.state_measured``      out    measured [width, width rate]
``camera.rgb_image``            out    top camera colour image
``camera.depth_image``          out    top camera depth, metres along the optical axis (32F)
``camera.image_time``           out    when the last image was taken (simulation: now) or
                                       arrived with a new stamp (hardware), station time, s
=============================== ====== ====================================================

Simulation-only ports, which no real robot has, start with ``sim.``: ``sim.plant_state``,
``sim.body_poses``, ``sim.query_object``, ``sim.contact_results``, ``sim.camera.label_image``,
and ``sim.{name}.rgb_image`` for each of the scenario's view cameras. Controllers must not read
them; benchmarks and tests may. The hardware station adds ``safety.*``
(:mod:`tangle_drake.station.interface`).
"""

from __future__ import annotations

from pydrake.geometry import Meshcat
from pydrake.systems.lcm import LcmBuses

from tangle_drake.drivers.camera import camera_body_pose, camera_model
from tangle_drake.scenario import Scenario
from tangle_drake.station.interface import HardwareStation, build_hardware_station
from tangle_drake.station.simulated import (
    PLANT_NAME,
    SIM_ONLY_PREFIX,
    SimulatedStation,
    add_pile_parts,
    build_simulated_station,
    part_bodies,
    pile_instances,
    pile_model_name,
)

Station = SimulatedStation | HardwareStation

__all__ = ["PLANT_NAME", "SIM_ONLY_PREFIX", "HardwareStation", "SimulatedStation", "Station",
           "add_pile_parts", "build_station", "camera_body_pose", "camera_model", "part_bodies",
           "pile_instances", "pile_model_name"]


def build_station(scenario: Scenario, meshcat: Meshcat | None = None, hardware: bool = False,
                  lcm_buses: LcmBuses | None = None) -> Station:
    """The station diagram for ``scenario`` (see the module docstring for its ports).

    ``hardware=False``: the simulated station, drawn in ``meshcat`` if given.
    ``hardware=True``: the same ports over the robot drivers' LCM; ``lcm_buses`` overrides the
    scenario's buses (``meshcat`` is not used).
    """
    if hardware:
        return build_hardware_station(scenario, lcm_buses)
    return build_simulated_station(scenario, meshcat)
