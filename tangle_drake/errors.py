"""The project's error type for bad user input (files, images, scenarios, checkpoints)."""


class TangleDrakeError(Exception):
    """A problem with what the user gave us, with a message that says what to fix.

    The command line prints these as one line (``error: ...``) instead of a traceback.
    """
