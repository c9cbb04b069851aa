"""One module per ``tangle-drake`` subcommand; each defines ``register(subparsers)``."""

COMMAND_MODULES: tuple[str, ...] = ("demo", "scene", "diagram", "graspability", "collect",
                                     "train", "evaluate", "export_onnx", "hardware_sim", "bench",
                                     "teach", "pick_ceiling")
