"""One module per ``tangle-drake`` subcommand; each defines ``register(subparsers)``."""

COMMAND_MODULES: tuple[str, ...] = ("scene", "diagram", "graspability", "train", "export_onnx",
                                     "hardware_sim")
