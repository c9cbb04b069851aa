"""The hardware station on an in-process LCM bus: the simulated station's ports, no command
before status, malformed messages refused without stopping the diagram, both depth formats."""

import numpy as np
import pytest
from drake import (
    lcmt_force_torque,
    lcmt_iiwa_command,
    lcmt_iiwa_status,
    lcmt_image,
    lcmt_image_array,
    lcmt_schunk_wsg_command,
    lcmt_schunk_wsg_status,
)
from pydrake.lcm import DrakeLcm
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import PortDataType
from pydrake.systems.lcm import LcmBuses

from tangle_drake.common.errors import TangleDrakeError
from tangle_drake.common.paths import diagrams_dir
from tangle_drake.robot_model.nextage import HOME
from tangle_drake.scenario import load_scenario, parse_scenario
from tangle_drake.station import SIM_ONLY_PREFIX, build_station
from tangle_drake.station.safety import Mode

WIDTH, HEIGHT = 8, 6


def _scenario():
    scenario = load_scenario(diagrams_dir() / "pick_demo.yaml")
    scenario.camera.width, scenario.camera.height = WIDTH, HEIGHT
    scenario.hardware.startup_timeout = 0.0  # nothing publishes before Initialize here
    return scenario


def _port_types(system, ports) -> dict[str, tuple]:
    types = {}
    for port in ports:
        if port.get_data_type() == PortDataType.kVectorValued:
            types[port.get_name()] = ("vector", port.size())
        else:
            types[port.get_name()] = ("abstract", type(port.Allocate().get_value()))
    return types


def _inputs(system):
    return [system.get_input_port(i) for i in range(system.num_input_ports())]


def _outputs(system):
    return [system.get_output_port(i) for i in range(system.num_output_ports())]


@pytest.mark.parametrize(("name", "carrier"), [("pick_demo.yaml", "nextage"),
                                              ("floating_gripper.yaml", "gantry")])
def test_hardware_station_has_every_port_of_the_simulated_one_with_the_same_type(name, carrier):
    scenario = load_scenario(diagrams_dir() / name)
    simulated = build_station(scenario)
    hardware = build_station(scenario, hardware=True)
    names = set()
    for ports in (_inputs, _outputs):
        wanted = {name: kind for name, kind in _port_types(simulated, ports(simulated)).items()
                  if not name.startswith(SIM_ONLY_PREFIX)}
        have = _port_types(hardware, ports(hardware))
        for name, kind in wanted.items():
            assert have.get(name) == kind, name
        assert not any(name.startswith(SIM_ONLY_PREFIX) for name in have)
        names |= set(have)
    assert {"camera.rgb_image", "camera.depth_image", f"{carrier}.position",
            f"{carrier}.state_measured", "gripper.position", "gripper.state_measured"} <= names
    assert {"safety.fault", "safety.ready", "safety.report"} <= names


class Bus:
    """A hardware station on a fresh memq:// bus, with the robot's side played by hand."""

    def __init__(self) -> None:
        self.scenario = _scenario()
        self.lcm = DrakeLcm("memq://")
        buses = LcmBuses()
        buses.Add("default", self.lcm)
        self.station = build_station(self.scenario, hardware=True, lcm_buses=buses)
        self.simulator = Simulator(self.station)
        self.simulator.Initialize()
        self.commands: dict[str, list[bytes]] = {"NEXTAGE_COMMAND": [], "WSG_COMMAND": []}
        for channel, messages in self.commands.items():
            self.lcm.Subscribe(channel, messages.append)

    def publish_status(self, q=HOME, width=0.03, wrist: bool = True) -> None:
        status = _status(self, self.time)
        status.joint_position_measured = list(q)
        self.lcm.Publish("NEXTAGE_STATUS", status.encode())
        self.publish_gripper_and_wrist(width, wrist)

    def publish_gripper_and_wrist(self, width: float = 0.03, wrist: bool = True) -> None:
        wsg = lcmt_schunk_wsg_status()
        wsg.utime = int(self.time * 1e6)
        wsg.actual_position_mm = width * 1e3
        self.lcm.Publish("WSG_STATUS", wsg.encode())
        if wrist:
            wrench = lcmt_force_torque()
            wrench.timestamp, wrench.fz = int(self.time * 1e6), 4.2
            self.lcm.Publish("WRIST_FORCE_TORQUE", wrench.encode())

    @property
    def time(self) -> float:
        return self.simulator.get_context().get_time()

    def advance(self, duration: float, status: bool = True) -> None:
        end = self.time + duration
        while self.time < end - 1e-9:
            if status:
                self.publish_status()
            self.simulator.AdvanceTo(self.time + 0.005)
            self.lcm.HandleSubscriptions(0)

    def out(self, name: str):
        return self.station.GetOutputPort(name).Eval(self.simulator.get_context())


def test_no_command_goes_out_before_fresh_status_and_the_first_holds_the_measured_pose():
    bus = Bus()
    bus.advance(0.3, status=False)
    assert bus.commands == {"NEXTAGE_COMMAND": [], "WSG_COMMAND": []}
    assert bus.out("safety.ready")[0] == 0
    bus.advance(0.05)
    assert bus.out("safety.ready")[0] == 1
    first = lcmt_iiwa_command.decode(bus.commands["NEXTAGE_COMMAND"][0])
    np.testing.assert_allclose(first.joint_position, HOME)
    gripper = lcmt_schunk_wsg_command.decode(bus.commands["WSG_COMMAND"][0])
    assert gripper.target_position_mm == pytest.approx(30.0)
    assert gripper.force == bus.scenario.model_drivers["gripper"].force_limit


def test_malformed_status_is_refused_and_reported_while_the_station_runs_on(caplog):
    bus = Bus()
    bus.advance(0.05)
    q = HOME + 0.1
    bus.publish_status(q)
    bus.simulator.AdvanceTo(bus.time + 0.005)
    bad_status = [b"\x00garbage", lcmt_schunk_wsg_status().encode()]
    short = lcmt_iiwa_status()
    short.num_joints = 7
    for name in lcmt_iiwa_status.__slots__[2:]:
        setattr(short, name, [0.0] * 7)
    bad_status.append(short.encode())
    nan = lcmt_iiwa_status.decode(short.encode())
    nan.num_joints = 15
    for name in lcmt_iiwa_status.__slots__[2:]:
        setattr(nan, name, [float("nan")] * 15)
    bad_status.append(nan.encode())
    for data in bad_status:
        bus.lcm.Publish("NEXTAGE_STATUS", data)
        bus.simulator.AdvanceTo(bus.time + 0.005)
    bus.lcm.Publish("DRAKE_RGBD_CAMERA_IMAGES_camera", b"not an image array")
    bus.lcm.Publish("WSG_STATUS", b"\xff" * 40)
    bus.simulator.AdvanceTo(bus.time + 0.010)  # the report counts at the next command tick

    np.testing.assert_allclose(bus.out("nextage.position_measured"), q)
    assert bus.out("safety.report").rejected == (4, 1, 0)
    for reason in ("does not decode as lcmt_iiwa_status", "num_joints is 7, expected 15",
                   "joint_position_measured has non-finite values",
                   "rejected message 1 on DRAKE_RGBD_CAMERA_IMAGES_camera",
                   "rejected message 1 on WSG_STATUS"):
        assert reason in caplog.text
    assert bus.out("camera.depth_image").width() == 0  # nothing valid arrived
    # Bad messages are not status: if only they come, the status goes stale and the robot stops.
    for _ in range(25):
        bus.lcm.Publish("NEXTAGE_STATUS", b"\x00garbage")
        bus.simulator.AdvanceTo(bus.time + 0.005)
    assert "no valid NEXTAGE_STATUS" in bus.out("safety.report").message


def _image(pixels: np.ndarray, pixel_format: int, channel_type: int) -> lcmt_image:
    image = lcmt_image()
    image.height, image.width = pixels.shape[:2]
    image.row_stride = pixels[0].nbytes
    image.data = pixels.astype(pixels.dtype.newbyteorder("<")).tobytes()
    image.size = len(image.data)
    image.pixel_format, image.channel_type = pixel_format, channel_type
    image.compression_method = lcmt_image.COMPRESSION_METHOD_NOT_COMPRESSED
    return image


@pytest.mark.parametrize(("depth", "channel_type", "metres"), [
    (np.array([0.0, 0.5, np.inf], np.float32), lcmt_image.CHANNEL_TYPE_FLOAT32,
     [0.0, 0.5, np.inf]),
    (np.array([0, 500, 65535], np.uint16), lcmt_image.CHANNEL_TYPE_UINT16, [0.0, 0.5, np.inf]),
])
def test_depth_arrives_in_metres_from_32f_and_16u(depth, channel_type, metres):
    bus = Bus()
    pixels = np.resize(depth, (HEIGHT, WIDTH))
    array = lcmt_image_array()
    rgba = np.full((HEIGHT, WIDTH, 4), 200, np.uint8)
    array.images = [_image(rgba, lcmt_image.PIXEL_FORMAT_RGBA, lcmt_image.CHANNEL_TYPE_UINT8),
                    _image(pixels, lcmt_image.PIXEL_FORMAT_DEPTH, channel_type)]
    array.num_images = 2
    bus.lcm.Publish("DRAKE_RGBD_CAMERA_IMAGES_camera", array.encode())
    bus.advance(0.01)
    image = np.array(bus.out("camera.depth_image").data)[:, :, 0]
    np.testing.assert_allclose(image, np.resize(np.array(metres, np.float32), (HEIGHT, WIDTH)))
    assert (np.array(bus.out("camera.rgb_image").data) == 200).all()


def test_image_time_is_when_a_new_image_arrived_and_a_frozen_one_does_not_advance_it():
    bus = Bus()
    assert bus.out("camera.image_time")[0] == -np.inf  # no image yet
    rgba = np.full((HEIGHT, WIDTH, 4), 200, np.uint8)
    depth = np.full((HEIGHT, WIDTH), 0.5, np.float32)

    def send(stamp_us: int) -> None:
        array = lcmt_image_array()
        array.header.utime = stamp_us
        array.images = [
            _image(rgba, lcmt_image.PIXEL_FORMAT_RGBA, lcmt_image.CHANNEL_TYPE_UINT8),
            _image(depth, lcmt_image.PIXEL_FORMAT_DEPTH, lcmt_image.CHANNEL_TYPE_FLOAT32)]
        array.num_images = 2
        bus.lcm.Publish("DRAKE_RGBD_CAMERA_IMAGES_camera", array.encode())

    bus.advance(0.1)
    send(1000)
    bus.advance(0.02)
    arrived = bus.out("camera.image_time")[0]
    assert 0.1 <= arrived <= 0.12
    for _ in range(3):  # a driver re-sending its last frame: the same stamp
        bus.advance(0.1)
        send(1000)
    bus.advance(0.02)
    assert bus.out("camera.image_time")[0] == arrived
    send(2000)
    bus.advance(0.02)
    assert bus.time - 0.025 <= bus.out("camera.image_time")[0] <= bus.time


def test_scenario_defaults_keep_lcm_in_process_and_bad_hardware_fields_are_named():
    scenario = parse_scenario("{}")
    assert scenario.lcm_buses["default"].lcm_url == "memq://"
    robot = parse_scenario("""
lcm_buses: {robot: {lcm_url: "udpm://239.255.76.67:7667?ttl=0"}}
model_drivers: {nextage: !NextageDriver {lcm_bus: robot}}
hardware: {depth_format: 16U, status_timeout: 0.05}
""")
    assert robot.model_drivers["nextage"].lcm_bus == "robot"
    assert robot.model_drivers["nextage"].status_channel == "NEXTAGE_STATUS"
    assert robot.hardware.depth_format == "16U"
    for text, field in [("model_drivers: {nextage: !NextageDriver {lcm_bus: robot}}",
                         "model_drivers.nextage.lcm_bus"),
                        ("model_drivers: {nextage: {lcm_bus: default}}", "model_drivers.nextage"),
                        ("model_drivers: {nextage: !NextageDriver {}, gantry: !GantryDriver "
                         "{status_channel: NEXTAGE_STATUS}}", "model_drivers"),
                        ("model_drivers: {gripper: !ParallelJawDriver {force_limit: 0}}",
                         "model_drivers.gripper.force_limit"),
                        ("camera: {name: camera, lcm_bus: elsewhere}", "camera.lcm_bus"),
                        ("hardware: {depth_format: 8U}", "hardware.depth_format"),
                        ("hardware: {status_timeout: 0.001}", "hardware.status_timeout"),
                        ("hardware: {status_timeot: 0.2}", "hardware.status_timeot")]:
        with pytest.raises(TangleDrakeError, match=f"'{field}'"):
            parse_scenario(text)


def test_freshness_is_by_timestamp_a_frozen_or_late_status_is_not_fresh(caplog):
    bus = Bus()
    bus.advance(0.05)
    assert bus.out("safety.ready")[0] == 1
    # A few lost messages in a row are tolerated...
    bus.advance(0.04, status=False)
    bus.advance(0.02)
    assert bus.out("safety.report").mode is Mode.RUNNING
    # ...an out-of-order status is refused, a repeated one dropped...
    frozen = bus.time
    late = lcmt_iiwa_status.decode(_status(bus, frozen - 0.02).encode())
    bus.lcm.Publish("NEXTAGE_STATUS", late.encode())
    bus.simulator.AdvanceTo(bus.time + 0.005)
    assert "out of order" in caplog.text
    # ...and a driver that re-sends a frozen status stops the robot as a silent one does.
    while bus.out("safety.report").mode is Mode.RUNNING:
        bus.lcm.Publish("NEXTAGE_STATUS", _status(bus, frozen).encode())
        bus.publish_gripper_and_wrist()
        bus.simulator.AdvanceTo(bus.time + 0.005)
        assert bus.time - frozen < 0.2
    assert "no valid NEXTAGE_STATUS" in bus.out("safety.report").message


def test_a_silent_wrist_sensor_stops_the_robot():
    bus = Bus()
    bus.advance(0.05)
    start = bus.time
    while bus.out("safety.report").mode is Mode.RUNNING:
        bus.publish_status(wrist=False)
        bus.simulator.AdvanceTo(bus.time + 0.005)
        assert bus.time - start < 0.2
    assert "no valid WRIST_FORCE_TORQUE" in bus.out("safety.report").message
    assert bus.out("safety.fault")[0] == 1


def _status(bus, at: float) -> lcmt_iiwa_status:
    status = lcmt_iiwa_status()
    status.utime = int(at * 1e6)
    status.num_joints = 15
    status.joint_position_measured = list(HOME)
    for name in ("joint_velocity_estimated", "joint_position_commanded", "joint_position_ipo",
                 "joint_torque_measured", "joint_torque_commanded", "joint_torque_external"):
        setattr(status, name, [0.0] * 15)
    return status
