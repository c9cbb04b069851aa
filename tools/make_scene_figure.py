"""Make the README's scene picture: the overview camera, the top camera's colour and depth.

    python tools/make_scene_figure.py [--scenario diagrams/pick_demo.yaml] [--out docs/scene.png]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

from tangle_drake.scenario.files import resolve_scenario
from tangle_drake.station.scene import make_scene


def depth_to_colour(depth: np.ndarray, floor: float) -> np.ndarray:
    """Height above the floor as a colour map (BGR); missing pixels black."""
    height = np.nan_to_num(floor - depth, nan=0.0)
    scaled = np.clip(height / 0.05, 0, 1) * 255
    image = cv2.applyColorMap(scaled.astype(np.uint8), cv2.COLORMAP_VIRIDIS)
    image[~np.isfinite(depth)] = 0
    return image


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="diagrams/pick_demo.yaml")
    parser.add_argument("--out", type=Path, default=Path("docs/scene.png"))
    args = parser.parse_args()
    scene = make_scene(resolve_scenario(args.scenario))
    height = 300
    panels = [cv2.cvtColor(image, cv2.COLOR_RGB2BGR) for image in scene.views.values()]
    panels += [cv2.cvtColor(scene.rgb, cv2.COLOR_RGB2BGR),
               depth_to_colour(scene.depth, scene.floor_depth)]
    resized = [cv2.resize(p, (round(p.shape[1] * height / p.shape[0]), height)) for p in panels]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(args.out), np.hstack(resized))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
