"""The systems between LCM and the station's ports: checked subscribers and a gated publisher.

Drake's (en|de)coder systems (``IiwaStatusReceiver``, ``SchunkWsgCommandSender``,
``LcmImageArrayToImages``, ...) read and write C++ message values; these systems move checked
bytes in and out of such values with Drake's C++ serializer, the one that
``LcmPublisherSystem.Make(..., use_cpp_serializer=True)`` uses.
"""

from __future__ import annotations

from pydrake.common.value import AbstractValue
from pydrake.lcm import DrakeLcmInterface
from pydrake.systems.framework import Context, DiagramBuilder, LeafSystem, OutputPort
from pydrake.systems.lcm import (
    LcmPublisherSystem,
    LcmSubscriberSystem,
    SerializerInterface,
    _Serializer_,
)

from tangle_drake.lcm_io.messages import Check, Received, ValidatingSerializer


def cpp_serializer(lcm_type: type) -> SerializerInterface:
    """Drake's C++ serializer for ``lcm_type`` (a Python class from the ``drake`` package)."""
    return _Serializer_[lcm_type]()


class ToDrakeMessage(LeafSystem):
    """The last accepted message of a :class:`Received` record, as the C++ value Drake reads.

    Before the first accepted message it is the default (empty) message, which Drake's
    receivers treat as "nothing received yet".
    """

    def __init__(self, lcm_type: type) -> None:
        super().__init__()
        self._serializer = cpp_serializer(lcm_type)
        received = self.DeclareAbstractInputPort("received", AbstractValue.Make(Received()))
        self.DeclareAbstractOutputPort(
            "message", self._serializer.CreateDefaultValue, self._calc,
            prerequisites_of_calc={received.ticket()})

    def _calc(self, context: Context, value: AbstractValue) -> None:
        data = self.get_input_port().Eval(context).data
        if data:
            self._serializer.Deserialize(data, value)
        else:
            value.SetFrom(self._serializer.CreateDefaultValue())


class GatedPublisher(LeafSystem):
    """Publishes its C++ message input every ``period`` seconds while ``enabled`` is 1.

    ``LcmPublisherSystem`` publishes unconditionally; the rule "no command before a fresh
    status" needs the gate.
    """

    def __init__(self, channel: str, lcm_type: type, lcm: DrakeLcmInterface,
                 period: float) -> None:
        super().__init__()
        self._channel = channel
        self._lcm = lcm
        self._serializer = cpp_serializer(lcm_type)
        self.DeclareAbstractInputPort("message", self._serializer.CreateDefaultValue())
        self.DeclareVectorInputPort("enabled", 1)
        self.DeclarePeriodicPublishEvent(period, 0.0, self._publish)

    def _publish(self, context: Context) -> None:
        if self.get_input_port(1).Eval(context)[0] > 0.5:
            message = self.get_input_port(0).EvalAbstract(context)
            self._lcm.Publish(self._channel, self._serializer.Serialize(message),
                              context.get_time())


def add_checked_subscriber(builder: DiagramBuilder, name: str, channel: str, lcm_type: type,
                           check: Check, lcm: DrakeLcmInterface) -> LcmSubscriberSystem:
    """Subscribe to ``channel`` through a :class:`ValidatingSerializer`; the subscriber's
    output is the :class:`Received` record."""
    return builder.AddNamedSystem(
        f"{name}.subscriber",
        LcmSubscriberSystem(channel, ValidatingSerializer(lcm_type, check, channel), lcm))


def add_drake_message(builder: DiagramBuilder, name: str, subscriber: LcmSubscriberSystem,
                      lcm_type: type) -> ToDrakeMessage:
    """A :class:`ToDrakeMessage` behind ``subscriber``, for Drake's C++ receivers."""
    converter = builder.AddNamedSystem(f"{name}.message", ToDrakeMessage(lcm_type))
    builder.Connect(subscriber.get_output_port(), converter.get_input_port())
    return converter


def add_publisher(builder: DiagramBuilder, name: str, channel: str, lcm_type: type,
                  lcm: DrakeLcmInterface, period: float, message: OutputPort) -> None:
    """Publish the C++ message ``message`` on ``channel`` every ``period`` seconds."""
    publisher = builder.AddNamedSystem(name, LcmPublisherSystem.Make(
        channel, lcm_type, lcm, publish_period=period, use_cpp_serializer=True))
    builder.Connect(message, publisher.get_input_port())
