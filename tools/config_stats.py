"""What a dataset holds, as the row of docs/datasets.md's statistics table.

    python tools/config_stats.py DATASET_DIR [DATASET_DIR ...]

Reads a ``--format middlebury`` dataset (``MiddEval3/trainingF/NNNNNN``): per sample the objects
of ``scene.json``, the fractions of ``sample.json``'s stats and ``disp0GT.pfm``, and prints one
markdown row per dataset:

- objects per image: mean and range of ``scene.json``'s objects;
- occluded, no GT, sky: the mean of each sample's ``occluded_fraction``, ``invalid_fraction`` and
  ``sky_fraction`` (0 where the config has no sky);
- constant objects: the share of objects whose texture is ``constant`` or has no contrast;
- discontinuity density: the share of pixels whose right or lower neighbour's disparity differs
  by more than 1 px (both finite);
- disparity: the smallest finite value over the samples, the median of each sample's largest,
  the largest;
- redraws: the sum of each sample's ``redraws`` (frames that taught nothing, drawn again).

Nothing here is part of the package.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from matcher.io import read_pfm


def _constant(obj: dict) -> bool:
    texture = obj.get("texture", {})
    return texture.get("kind") == "constant" or texture.get("contrast", 1.0) == 0


def stats(root: Path) -> dict:
    folders = sorted((root / "MiddEval3" / "trainingF").iterdir())
    objects, constant, occluded, invalid, sky, edges, lows, highs, redraws = ([] for _ in range(9))
    for folder in folders:
        scene = json.loads((folder / "scene.json").read_text())["scene"]
        record = json.loads((folder / "sample.json").read_text())["stats"]
        objs = scene.get("objects", [])
        objects.append(len(objs))
        constant += [_constant(o) for o in objs]
        occluded.append(record["occluded_fraction"])
        invalid.append(record["invalid_fraction"])
        sky.append(record.get("sky_fraction", 0.0))
        redraws.append(record.get("redraws", 0))
        d = read_pfm(folder / "disp0GT.pfm").astype(np.float64)
        with np.errstate(invalid="ignore"):
            jump = np.zeros(d.shape, bool)
            jump[:, :-1] |= np.abs(d[:, 1:] - d[:, :-1]) > 1.0
            jump[:-1, :] |= np.abs(d[1:, :] - d[:-1, :]) > 1.0
        edges.append(float(jump.mean()))
        finite = d[np.isfinite(d)]
        lows.append(float(finite.min()))
        highs.append(float(finite.max()))
    return {"name": root.name, "samples": len(folders), "objects": objects,
            "constant": float(np.mean(constant)), "occluded": float(np.mean(occluded)),
            "invalid": float(np.mean(invalid)), "sky": float(np.mean(sky)),
            "edges": float(np.mean(edges)), "low": min(lows), "median_high": float(np.median(highs)),
            "high": max(highs), "redraws": int(sum(redraws))}


def row(s: dict) -> str:
    o = s["objects"]
    return (f"| `{s['name']}` | {s['samples']} | {np.mean(o):.1f} ({min(o)}-{max(o)}) | "
            f"{100 * s['occluded']:.1f} % | {100 * s['invalid']:.1f} % | {100 * s['sky']:.1f} % | "
            f"{100 * s['constant']:.0f} % | {100 * s['edges']:.1f} % | "
            f"{s['low']:.1f} / {s['median_high']:.0f} / {s['high']:.0f} | {s['redraws']} |")


def main(argv: list[str]) -> int:
    if not argv:
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    print("| config | samples | objects per image (mean, range) | occluded | no GT | sky | "
          "constant objects | discontinuity density | disparity min / median max / max (px) | "
          "redraws |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for path in argv:
        print(row(stats(Path(path))))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
