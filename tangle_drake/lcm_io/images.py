"""Camera images over LCM, in the two depth formats the channel may carry (``depth_format``).

``32F``: metres, +inf where nothing was seen, as the station's ``camera.depth_image``.
``16U``: millimetres as most depth-camera drivers send them: 0 too close, 65535 too far or
nothing seen; the station turns them into metres and 65535 into +inf, so both mean the same.

The station unpacks ``lcmt_image_array`` itself rather than with Drake's
``LcmImageArrayToImages``: in drake 1.51 that system copies ``Image::size()`` *elements* as
bytes from an uncompressed image, i.e. only the first quarter (32F) or half (16U) of a depth
image, and it aborts the process on BGR/BGRA images.
"""

from __future__ import annotations

import numpy as np
from drake import lcmt_image, lcmt_image_array
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, LeafSystem
from pydrake.systems.sensors import (
    ConvertDepth32FTo16U,
    ImageDepth16U,
    ImageDepth32F,
    ImageRgba8U,
)

from tangle_drake.lcm_io.messages import COLOR_CHANNELS, DEPTH_DTYPES, Received, image_bytes

_TOO_FAR_16U = 65535


def color_pixels(message: lcmt_image_array) -> np.ndarray | None:
    """The first RGB/RGBA image as an (H, W, 4) uint8 array, or None if there is none."""
    image = next((i for i in message.images if i.pixel_format in COLOR_CHANNELS), None)
    if image is None:
        return None
    channels = COLOR_CHANNELS[image.pixel_format]
    pixels = np.frombuffer(image_bytes(image), np.uint8).reshape(image.height, image.width,
                                                                 channels)
    if channels == 4:
        return pixels
    alpha = np.full((image.height, image.width, 1), 255, np.uint8)
    return np.concatenate([pixels, alpha], axis=2)


def depth_metres(message: lcmt_image_array) -> np.ndarray | None:
    """The first depth image as (H, W) float32 metres, +inf where nothing was seen."""
    image = next((i for i in message.images
                  if i.pixel_format == lcmt_image.PIXEL_FORMAT_DEPTH), None)
    if image is None:
        return None
    raw = np.frombuffer(image_bytes(image), DEPTH_DTYPES[image.channel_type])
    raw = raw.reshape(image.height, image.width)
    if image.channel_type == lcmt_image.CHANNEL_TYPE_FLOAT32:
        return raw.astype(np.float32)
    metres = raw.astype(np.float32) / 1e3
    metres[raw == _TOO_FAR_16U] = np.inf
    return metres


class ImageArrayToImages(LeafSystem):
    """The last accepted ``lcmt_image_array`` as the station's ``camera.*`` images.

    Input ``received`` (a checked :class:`Received` record); outputs ``color_image``
    (ImageRgba8U) and ``depth_image`` (ImageDepth32F, metres), empty before the first image.
    """

    def __init__(self) -> None:
        super().__init__()
        received = self.DeclareAbstractInputPort("received", AbstractValue.Make(Received()))
        self.DeclareAbstractOutputPort(
            "color_image", lambda: AbstractValue.Make(ImageRgba8U()),
            lambda c, v: self._calc(c, v, ImageRgba8U, color_pixels),
            prerequisites_of_calc={received.ticket()})
        self.DeclareAbstractOutputPort(
            "depth_image", lambda: AbstractValue.Make(ImageDepth32F()),
            lambda c, v: self._calc(c, v, ImageDepth32F, depth_metres),
            prerequisites_of_calc={received.ticket()})

    def _calc(self, context: Context, value: AbstractValue, image_type: type,
              unpack) -> None:
        data = self.get_input_port().Eval(context).data
        pixels = unpack(lcmt_image_array.decode(data)) if data else None
        if pixels is None:
            value.set_value(image_type())
            return
        image = image_type(pixels.shape[1], pixels.shape[0])
        image.mutable_data[:] = pixels.reshape(image.mutable_data.shape)
        value.set_value(image)


class ImageArrival(LeafSystem):
    """When (station time) the last image with a new stamp arrived: ``camera.image_time``.

    Input ``received`` (the camera's checked :class:`Received` record); output ``image_time``
    (1-vector, s; -inf before the first image). A driver that re-sends a frozen image keeps
    its stamp (counted as a repeat, not taken), so the time stops advancing and the planner,
    which looks only at an image that arrived after the arm's last motion, waits instead of
    picking from the pile as it was. Checked every ``period`` s, and at initialization.
    """

    def __init__(self, period: float) -> None:
        super().__init__()
        self.DeclareAbstractInputPort("received", AbstractValue.Make(Received()))
        self._state = self.DeclareDiscreteState(np.array([np.nan, -np.inf]))  # stamp, time
        self.DeclareVectorOutputPort(
            "image_time", 1,
            lambda c, out: out.SetAtIndex(0, c.get_discrete_state(self._state).GetAtIndex(1)),
            {self.discrete_state_ticket(self._state)})
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        self.DeclareInitializationDiscreteUpdateEvent(self._update)

    def _update(self, context: Context, state) -> None:
        stamp = self.get_input_port().Eval(context).stamp
        seen = context.get_discrete_state(self._state).GetAtIndex(0)
        if stamp is not None and stamp != seen:
            state.get_mutable_vector(self._state).SetFromVector([stamp, context.get_time()])


class SimulatedImageTime(LeafSystem):
    """``camera.image_time`` of the simulated camera: it renders on demand, so always now."""

    def __init__(self) -> None:
        super().__init__()
        self.DeclareVectorOutputPort("image_time", 1,
                                     lambda c, out: out.SetAtIndex(0, c.get_time()),
                                     {self.time_ticket()})


class DepthToMillimetres(LeafSystem):
    """32F metres in, 16U millimetres out (the hardware simulator's ``depth_format: 16U``)."""

    def __init__(self) -> None:
        super().__init__()
        self.DeclareAbstractInputPort("depth_32f", AbstractValue.Make(ImageDepth32F()))
        self.DeclareAbstractOutputPort("depth_16u", lambda: AbstractValue.Make(ImageDepth16U()),
                                       self._calc)

    def _calc(self, context: Context, value: AbstractValue) -> None:
        metres: ImageDepth32F = self.get_input_port().Eval(context)
        millimetres = ImageDepth16U(metres.width(), metres.height())
        ConvertDepth32FTo16U(metres, millimetres)
        value.set_value(millimetres)
