"""The robot: the gripper's dimensions (:mod:`.gripper`), the Nextage's joints and poses
(:mod:`.nextage`), and the generator of the shipped Nextage + parallel-jaw gripper model files.

The kinematic table of the Nextage (``shared/reference/nextage.md``) is written down in
:mod:`.kinematics` and nowhere else; the URDF (:mod:`.urdf`, with :mod:`.links`' primitives),
the gripper SDF (:mod:`.gripper_sdf`, from :class:`.gripper.GripperSpec`), the
model directives and ``package.xml`` under ``models/nextage/`` are generated from it so that
the numbers cannot drift apart. Inertias come from the primitives' geometry, scaled to the
table's masses.

``python -m tangle_drake.robot_model`` rewrites the files; ``--check`` only compares them.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from tangle_drake.robot_model.gripper import DEFAULT_GRIPPER, GripperSpec
from tangle_drake.robot_model.gripper_sdf import gripper_sdf
from tangle_drake.robot_model.kinematics import (
    FLANGE_OFFSET,
    JOINTS,
    WAIST_HEIGHT,
    JointSpec,
    init_rtm,
    joint_gains,
)
from tangle_drake.robot_model.urdf import nextage_urdf
from tangle_drake.robot_model.writers import GENERATED, num

__all__ = ["JOINTS", "JointSpec", "generated_files", "init_rtm", "joint_gains", "main"]


def model_directives(spec: GripperSpec = DEFAULT_GRIPPER) -> str:
    """Nextage on its stand plus the gripper on the left flange, as Drake model directives.

    Default positions are ``init_rtm`` and an open gripper, so a default context starts in a
    collision-free pose (all-zero joints would sink the hanging arms into the waist).
    """
    arm_defaults = "".join(f"\n      {name}: [{num(q)}]" for name, q in init_rtm().items())
    return f"""# {GENERATED}
# WAIST stands {WAIST_HEIGHT} m above the floor (world z = 0). The gripper frame G (gripper_base)
# sits on the left flange, {FLANGE_OFFSET * 1000:g} mm along -x of LARM_JOINT5_Link, rotated so that
# G's +z (approach) is the link's -x (the tool axis) and G's y (closing) is the link's y.
directives:
- add_model:
    name: nextage
    file: package://nextage/urdf/nextage.urdf
    default_joint_positions:{arm_defaults}
- add_weld:
    parent: world
    child: nextage::WAIST
    X_PC:
      translation: [0, 0, {num(WAIST_HEIGHT)}]
- add_model:
    name: gripper
    file: package://nextage/sdf/parallel_jaw_gripper.sdf
    default_joint_positions:
      left_finger_sliding_joint: [{num(-spec.finger_stroke)}]
      right_finger_sliding_joint: [{num(spec.finger_stroke)}]
- add_weld:
    parent: nextage::LARM_JOINT5_Link
    child: gripper::gripper_base
    X_PC:
      translation: [{num(-FLANGE_OFFSET)}, 0, 0]
      rotation: !Rpy {{ deg: [0, -90, 0] }}
"""


def package_xml() -> str:
    """``package.xml`` that lets Drake's PackageMap resolve ``package://nextage/...``."""
    return f"""<?xml version="1.0"?>
<!-- {GENERATED} -->
<package format="2">
  <name>nextage</name>
  <version>0.1.0</version>
  <description>
    Kawada NEXTAGE OPEN (primitive geometry, Drake PD servos) with a parallel-jaw gripper,
    for tangle_drake. Kinematics from the public nextage_description package; no meshes.
  </description>
  <maintainer email="tangle-drake@example.invalid">tangle_drake</maintainer>
  <license>BSD-3-Clause</license>
</package>
"""


def generated_files() -> dict[str, str]:
    """Shipped model files, keyed by path relative to ``models/nextage``."""
    return {
        "urdf/nextage.urdf": nextage_urdf(),
        "sdf/parallel_jaw_gripper.sdf": gripper_sdf(),
        "nextage_with_gripper.dmd.yaml": model_directives(),
        "package.xml": package_xml(),
    }


def _package_dir() -> Path:
    return Path(__file__).resolve().parents[2] / "models" / "nextage"


def main(argv: list[str] | None = None) -> int:
    """Write the model files, or with ``--check`` report those that differ from the code."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true",
                        help="exit 1 if a shipped file differs from the generated one")
    parser.add_argument("--out", type=Path, default=_package_dir(),
                        help="package directory (default: models/nextage of this checkout)")
    args = parser.parse_args(argv)
    stale = []
    for relative, text in generated_files().items():
        path = args.out / relative
        current = path.read_text() if path.is_file() else None
        if current == text:
            continue
        stale.append(relative)
        if not args.check:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
    if args.check and stale:
        print("stale model files (run python -m tangle_drake.robot_model):", *stale,
              sep="\n  ", file=sys.stderr)
        return 1
    return 0
