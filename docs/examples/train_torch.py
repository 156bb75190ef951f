"""Train your own PyTorch stereo network on a stereoforge dataset (docs/learning.md).

A tiny network: shared convolutional features, a correlation cost volume over d = 0 .. D - 1,
soft-argmin disparity, an L1 loss on the pixels with ground truth. Runs on the GPU if torch sees
one, else on the CPU:

    stereoforge dataset flying --out out/flying --count 200 --workers 2
    python docs/examples/train_torch.py out/flying --steps 500
"""

from __future__ import annotations

import argparse

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F
from torch.utils.data import DataLoader, Dataset

from synth import StereoDataset

MAX_DISP, CROP = 48, (64, 128)


class Crops(Dataset):
    """Random crops of a StereoDataset's pairs as float tensors (grey, 0..1)."""

    def __init__(self, root: str, split: str, seed: int = 0) -> None:
        self.data, self.seed = StereoDataset(root, split=split), seed

    def __len__(self) -> int:
        return len(self.data)

    def __getitem__(self, i: int):
        s = self.data[i]  # a dict of numpy arrays: left, right, disp (inf = none), valid, ...
        rng = np.random.default_rng([self.seed, i])
        h, w = s["disp"].shape
        y = rng.integers(0, h - CROP[0] + 1)
        x = rng.integers(0, w - CROP[1] + 1)
        cut = (slice(y, y + CROP[0]), slice(x, x + CROP[1]))
        grey = lambda rgb: torch.from_numpy(rgb[cut].mean(axis=2, dtype=np.float32) / 255)[None]  # noqa: E731
        disp = np.where(s["valid"], s["disp"], 0).astype(np.float32)[cut]
        return grey(s["left"]), grey(s["right"]), torch.from_numpy(disp), torch.from_numpy(
            s["valid"][cut] & (disp < MAX_DISP))


class TinyStereo(nn.Module):
    def __init__(self, maps: int = 16) -> None:
        super().__init__()
        self.features = nn.Sequential(nn.Conv2d(1, maps, 3, padding=1), nn.ReLU(),
                                      nn.Conv2d(maps, maps, 3, padding=1))

    def forward(self, left: torch.Tensor, right: torch.Tensor) -> torch.Tensor:
        fl, fr = self.features(left), self.features(right)
        cost = [(fl * fr).mean(1)]  # d = 0; left pixel x matches right pixel x - d
        for d in range(1, MAX_DISP):
            cost.append(F.pad((fl[..., d:] * fr[..., :-d]).mean(1), (d, 0), value=-1e4))
        prob = torch.softmax(torch.stack(cost, 1), dim=1)
        return (prob * torch.arange(MAX_DISP, device=left.device)[None, :, None, None]).sum(1)


def main(argv: list[str] | None = None) -> float:
    p = argparse.ArgumentParser()
    p.add_argument("dataset")
    p.add_argument("--steps", type=int, default=500)
    p.add_argument("--workers", type=int, default=2)
    args = p.parse_args(argv)
    device = torch.device("cuda" if torch.cuda.is_available() else "cpu")
    torch.manual_seed(0)
    net = TinyStereo().to(device)
    opt = torch.optim.Adam(net.parameters(), lr=1e-3)
    loader = DataLoader(Crops(args.dataset, "train"), batch_size=4, shuffle=True,
                        num_workers=args.workers, drop_last=True,
                        multiprocessing_context="spawn" if args.workers else None)
    step, loss = 0, torch.tensor(0.0)
    while step < args.steps:
        for left, right, disp, valid in loader:
            left, right, disp, valid = (t.to(device) for t in (left, right, disp, valid))
            loss = F.smooth_l1_loss(net(left, right)[valid], disp[valid])
            opt.zero_grad()
            loss.backward()
            opt.step()
            step += 1
            if step % 100 == 0 or step == args.steps:
                print(f"step {step}: loss {loss.item():.3f} px")
            if step == args.steps:
                break
    return float(loss)


if __name__ == "__main__":
    main()
