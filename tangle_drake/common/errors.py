"""The project's error type for bad user input (files, images, scenarios, checkpoints)."""


class TangleDrakeError(Exception):
    """A problem with what the user gave us, with a message that says what to fix.

    The command line prints these as one line (``error: ...``) instead of a traceback.
    """


class SafetyStop(TangleDrakeError):
    """The station's safety supervisor stopped the robot: the run cannot go on by itself."""


SEED_LIMIT = 2**63
"""Seeds are non-negative 63-bit integers: what numpy's generators and torch both accept."""


def check_seed(seed: int, name: str) -> int:
    """``seed``, or a :class:`TangleDrakeError` naming ``name`` (an option or a scenario
    field) when it is no seed."""
    if not 0 <= seed < SEED_LIMIT:
        raise TangleDrakeError(f"{name} must be a non-negative 63-bit integer, got {seed}")
    return seed
