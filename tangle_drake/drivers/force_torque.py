"""The wrist force/torque sensor: every branch of it (:class:`~.config.ForceTorqueSensor`).

Simulation: the plant's reaction force at the weld above the sensed body (Drake gives it on
the child body, at the joint's child frame, in that frame; here it is turned into world
coordinates), sampled every ``period``, low-pass filtered as a sensor's firmware does, with
noise, a random-walk bias and the stream's resolution. (Working at the sensor's rate rather
than at every plant step keeps it cheap: a small share of a pick's computation.)
The noise is drawn from the seed and the sample's index, so a restored context replays it
exactly. Hardware station:
``lcmt_force_torque`` in, checked. Robot side: the simulated samples out as
``lcmt_force_torque`` every ``period``.
"""

from __future__ import annotations

import math

import numpy as np
from drake import lcmt_force_torque
from pydrake.common.value import AbstractValue
from pydrake.lcm import DrakeLcmInterface
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import Joint
from pydrake.systems.framework import (
    BasicVector,
    Context,
    Diagram,
    DiagramBuilder,
    DiscreteValues,
    LeafSystem,
)
from pydrake.systems.lcm import LcmPublisherSystem

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.lcm_io.lcm_systems import add_checked_subscriber
from tangle_drake.lcm_io.messages import Received, check_force_torque
from tangle_drake.scenario.drivers import ForceTorqueSensor

WRENCH_SIZE = 6
"""``[fx, fy, fz, tx, ty, tz]``: N and N·m."""


def sample_draws(seed: int, index: int) -> tuple[np.ndarray, np.ndarray]:
    """The standard-normal noise and bias-walk steps of sample ``index``: a function of the
    seed and the index alone. One Philox key per sample; a shared key with the index as the
    counter would hand a sample's draws on to its neighbour (correlation 0.97)."""
    draw = np.random.Generator(np.random.Philox(key=[index, seed]))
    return draw.standard_normal(WRENCH_SIZE), draw.standard_normal(WRENCH_SIZE)


def weld_above(plant: MultibodyPlant, config: ForceTorqueSensor) -> Joint:
    """The weld joint whose child is the sensed body (where the sensor sits)."""
    if not plant.HasModelInstanceNamed(config.model) or not plant.HasBodyNamed(
            config.body, plant.GetModelInstanceByName(config.model)):
        raise TangleDrakeError(f"the force/torque sensor's body {config.model}::{config.body} "
                               "is in no model the directives add")
    body = plant.GetBodyByName(config.body, plant.GetModelInstanceByName(config.model))
    joints = [plant.get_joint(i) for i in plant.GetJointIndices()]
    welds = [j for j in joints if j.child_body().index() == body.index()
             and j.num_velocities() == 0]
    if not welds:
        raise TangleDrakeError(f"{config.model}::{config.body} hangs from no weld: a "
                               "force/torque sensor sits in the weld between it and its carrier")
    return welds[0]


class SimulatedForceTorque(LeafSystem):
    """The simulated sensor; inputs ``reaction_forces`` and ``body_poses`` (the plant's),
    output ``force_torque``."""

    def __init__(self, plant: MultibodyPlant, joint: Joint, config: ForceTorqueSensor) -> None:
        super().__init__()
        self._config = config
        self._joint = int(joint.index())
        self._child = int(joint.child_body().index())
        self._R_CJ = joint.frame_on_child().GetFixedPoseInBodyFrame().rotation().matrix()
        self._period = config.period
        self._alpha = 1.0 - math.exp(-2 * math.pi * config.cutoff_frequency * config.period) \
            if config.cutoff_frequency > 0 else 1.0
        self._noise = np.array([config.force_noise] * 3 + [config.torque_noise] * 3)
        self._drift = np.array([config.force_drift] * 3 + [config.torque_drift] * 3) * math.sqrt(
            config.period)
        self._resolution = np.array([config.force_resolution] * 3
                                    + [config.torque_resolution] * 3)
        self.DeclareAbstractInputPort("reaction_forces",
                                      plant.get_reaction_forces_output_port().Allocate())
        self.DeclareAbstractInputPort("body_poses", plant.get_body_poses_output_port().Allocate())
        # [filtered true wrench (6), bias (6), sample (6), started flag]
        self._state = self.DeclareDiscreteState(3 * WRENCH_SIZE + 1)
        self.DeclarePeriodicDiscreteUpdateEvent(config.period, 0.0, self._update)
        self.DeclareVectorOutputPort("force_torque", WRENCH_SIZE, self._calc_sample,
                                     {self.discrete_state_ticket(self._state)})

    def true_wrench(self, context: Context) -> np.ndarray:
        """The reaction at the weld, world coordinates, ``[f; t]`` (no sensor effects)."""
        F = self.get_input_port(0).Eval(context)[self._joint]
        R_WC = self.get_input_port(1).Eval(context)[self._child].rotation().matrix()
        R_WJ = R_WC @ self._R_CJ
        return np.concatenate([R_WJ @ F.translational(), R_WJ @ F.rotational()])

    def _update(self, context: Context, values: DiscreteValues) -> None:
        x = context.get_discrete_state(self._state).get_value()
        filtered, bias, sample = x[:6], x[6:12], x[12:18]
        wrench = self.true_wrench(context)
        filtered = wrench if x[18] == 0 else filtered + self._alpha * (wrench - filtered)
        noise, walk = sample_draws(self._config.seed, round(context.get_time() / self._period))
        bias = bias + self._drift * walk
        sample = filtered + bias + self._noise * noise
        steps = self._resolution > 0
        sample[steps] = np.round(sample[steps] / self._resolution[steps]) * self._resolution[steps]
        values.set_value(self._state, np.concatenate([filtered, bias, sample, [1.0]]))

    def _calc_sample(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(context.get_discrete_state(self._state).get_value()[12:18])


def add_simulated(builder: DiagramBuilder, plant: MultibodyPlant, name: str,
                  config: ForceTorqueSensor) -> SimulatedForceTorque:
    """``{name}.force_torque`` from the plant's reaction at the sensor's weld."""
    sensor = builder.AddNamedSystem(f"{name}.sensor",
                                    SimulatedForceTorque(plant, weld_above(plant, config), config))
    builder.Connect(plant.get_reaction_forces_output_port(),
                    sensor.GetInputPort("reaction_forces"))
    builder.Connect(plant.get_body_poses_output_port(), sensor.GetInputPort("body_poses"))
    builder.ExportOutput(sensor.GetOutputPort("force_torque"), f"{name}.force_torque")
    return sensor


# --- the hardware station's side ------------------------------------------------------------

class ReceivedForceTorque(LeafSystem):
    """The last accepted ``lcmt_force_torque`` as a 6-vector (zeros before the first)."""

    def __init__(self) -> None:
        super().__init__()
        received = self.DeclareAbstractInputPort("received", AbstractValue.Make(Received()))
        self.DeclareVectorOutputPort("force_torque", WRENCH_SIZE, self._calc,
                                     {received.ticket()})

    def _calc(self, context: Context, output: BasicVector) -> None:
        data = self.get_input_port().Eval(context).data
        if not data:
            output.SetFromVector(np.zeros(WRENCH_SIZE))
            return
        m = lcmt_force_torque.decode(data)
        output.SetFromVector([m.fx, m.fy, m.fz, m.tx, m.ty, m.tz])


def add_interface(builder: DiagramBuilder, lcm: DrakeLcmInterface, name: str,
                  config: ForceTorqueSensor):
    """``{name}.force_torque`` from the sensor's messages; returns the subscriber."""
    subscriber = add_checked_subscriber(builder, name, config.channel, lcmt_force_torque,
                                        check_force_torque, lcm)
    wrench = builder.AddNamedSystem(f"{name}.receiver", ReceivedForceTorque())
    builder.Connect(subscriber.get_output_port(), wrench.get_input_port())
    builder.ExportOutput(wrench.get_output_port(), f"{name}.force_torque")
    return subscriber


# --- the robot's side, played by the hardware simulator -------------------------------------

class ForceTorqueToMessage(LeafSystem):
    """The simulated ``force_torque`` as an ``lcmt_force_torque`` stamped with the time."""

    def __init__(self) -> None:
        super().__init__()
        self.DeclareVectorInputPort("force_torque", WRENCH_SIZE)
        self.DeclareAbstractOutputPort("message", lambda: AbstractValue.Make(lcmt_force_torque()),
                                       self._calc)

    def _calc(self, context: Context, value: AbstractValue) -> None:
        wrench = self.get_input_port().Eval(context)
        message = lcmt_force_torque()
        message.timestamp = round(context.get_time() * 1e6)
        message.fx, message.fy, message.fz, message.tx, message.ty, message.tz = (
            float(v) for v in wrench)
        value.set_value(message)


def add_robot_side(builder: DiagramBuilder, station: Diagram, lcm: DrakeLcmInterface,
                   name: str, config: ForceTorqueSensor) -> None:
    """Publish ``station``'s ``{name}.force_torque`` every ``period``."""
    message = builder.AddNamedSystem(f"{name}.to_message", ForceTorqueToMessage())
    builder.Connect(station.GetOutputPort(f"{name}.force_torque"), message.get_input_port())
    publisher = builder.AddNamedSystem(f"{name}.publisher", LcmPublisherSystem.Make(
        config.channel, lcmt_force_torque, lcm, publish_period=config.period))
    builder.Connect(message.get_output_port(), publisher.get_input_port())
