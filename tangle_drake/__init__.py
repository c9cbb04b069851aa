"""tangle_drake: pick one and only one part from a bin of tangle-prone parts, with Drake."""

__version__ = "0.1.0"
