"""``python -m tangle_drake.robot_model``: rewrite (or ``--check``) the shipped model files."""

import sys

from tangle_drake.robot_model import main

sys.exit(main())
