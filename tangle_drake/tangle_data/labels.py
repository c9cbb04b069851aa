"""The paper's labelling rules (section III-B) for one grasp candidate on a settled pile.

1. No part in the closing region: not a sample (the gripper would close on nothing).
2. Two or more parts in the closing region: *tangled* at once, nothing simulated (the
   gripper would grasp them together).
3. Exactly one: that part is the target; it alone is lifted by the force-based lift, and the
   pick is *tangled* if any other part rose more than the threshold during the lift, or if
   the target itself could not be pulled out of the pile (it stalled); else *not tangled*.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from tangle_drake.tangle_data.lift import LiftResult


@dataclass(frozen=True)
class PickLabel:
    """The outcome of the rules for one candidate."""

    in_region: tuple[int, ...]
    """Pile indices of the parts in the closing region."""
    lift: LiftResult | None
    """The lift's outcome; ``None`` when no lift ran (rules 1 and 2)."""

    @property
    def is_sample(self) -> bool:
        return len(self.in_region) > 0

    @property
    def tangled(self) -> bool:
        if not self.is_sample:
            raise ValueError("a candidate with an empty closing region has no label")
        if self.lift is None:
            return True
        return bool(self.lift.lifted) or self.lift.stalled

    @property
    def target(self) -> int:
        """Pile index of the lifted part, -1 when nothing was lifted."""
        return -1 if self.lift is None else self.lift.target


def label_pick(in_region: list[int], lift: Callable[[int], LiftResult]) -> PickLabel:
    """Apply the rules: ``lift(target)`` is called only when exactly one part is in the region."""
    region = tuple(in_region)
    if len(region) != 1:
        return PickLabel(region, None)
    return PickLabel(region, lift(region[0]))
