#!/usr/bin/python3
"""PyTorch reference for lrf's LPIPS (tests/test_eval_lpips.cpp).

Builds LPIPS v0.1 with a VGG16 backbone in plain torch, written here from the definition of the `lpips`
package (ScalingLayer, vgg16 slices with torchvision's layer indices, normalize_tensor, NetLinLayer,
spatial_average), with random weights from a fixed seed, and writes to OUT_DIR:
  weights/<key>.npy   the state dict in the lpips layout (as LPIPS().state_dict() names it)
  img0.npy, img1.npy  two random RGB images [3, 64, 64] in [0, 1]
  expected.json       {"distance": d, "layers": [5 per-layer terms]}
Usage: lpips_reference.py OUT_DIR [SEED]
"""
import json
import os
import sys

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F

# torchvision's vgg16().features, as (index, in, out) for convs; ReLUs follow each conv, max pools sit at
# indices 4, 9, 16, 23. lpips slices features[0:4], [4:9], [9:16], [16:23], [23:30].
CONVS = [(0, 3, 64), (2, 64, 64), (5, 64, 128), (7, 128, 128), (10, 128, 256), (12, 256, 256),
         (14, 256, 256), (17, 256, 512), (19, 512, 512), (21, 512, 512), (24, 512, 512),
         (26, 512, 512), (28, 512, 512)]
POOLS = [4, 9, 16, 23]
SLICE_BOUNDS = [(0, 4), (4, 9), (9, 16), (16, 23), (23, 30)]
CHANNELS = [64, 128, 256, 512, 512]


class Lpips(nn.Module):
    def __init__(self):
        super().__init__()
        self.register_buffer("shift", torch.tensor([-.030, -.088, -.188])[None, :, None, None])
        self.register_buffer("scale", torch.tensor([.458, .448, .450])[None, :, None, None])
        self.slices = nn.ModuleList()
        conv_at = {i: (cin, cout) for i, cin, cout in CONVS}
        for lo, hi in SLICE_BOUNDS:
            s = nn.Sequential()
            for i in range(lo, hi):
                if i in conv_at:
                    s.add_module(str(i), nn.Conv2d(*conv_at[i], kernel_size=3, padding=1))
                elif i in POOLS:
                    s.add_module(str(i), nn.MaxPool2d(kernel_size=2, stride=2))
                else:
                    s.add_module(str(i), nn.ReLU(inplace=False))
            self.slices.append(s)
        # NetLinLayer: Sequential(Dropout, Conv2d 1x1 no bias); dropout is identity in eval mode.
        self.lins = nn.ModuleList(nn.Sequential(nn.Dropout(), nn.Conv2d(c, 1, 1, bias=False)) for c in CHANNELS)

    def forward(self, in0, in1):
        # normalize=True in lpips: inputs in [0, 1] → [-1, 1]; then the scaling layer.
        x0 = ((2 * in0 - 1) - self.shift) / self.scale
        x1 = ((2 * in1 - 1) - self.shift) / self.scale
        layers = []
        for s, lin in zip(self.slices, self.lins):
            x0, x1 = s(x0), s(x1)
            n0 = x0 / (torch.sqrt(torch.sum(x0 ** 2, dim=1, keepdim=True)) + 1e-10)
            n1 = x1 / (torch.sqrt(torch.sum(x1 ** 2, dim=1, keepdim=True)) + 1e-10)
            layers.append(lin((n0 - n1) ** 2).mean([2, 3], keepdim=True))
        val = layers[0]
        for l in layers[1:]:
            val = val + l
        return val, layers

    def lpips_state_dict(self):
        """The names LPIPS(net='vgg').state_dict() uses."""
        sd = {"scaling_layer.shift": self.shift, "scaling_layer.scale": self.scale}
        for k, s in enumerate(self.slices):
            for name, t in s.state_dict().items():
                sd["net.slice%d.%s" % (k + 1, name)] = t
        for k, lin in enumerate(self.lins):
            sd["lin%d.model.1.weight" % k] = lin[1].weight
        return sd


def main():
    out = sys.argv[1]
    seed = int(sys.argv[2]) if len(sys.argv) > 2 else 0
    torch.manual_seed(seed)
    torch.set_num_threads(1)
    net = Lpips().eval()
    with torch.no_grad():
        # He-normal weights keep activations of order 1 through all 13 layers (PyTorch's default init
        # shrinks them ~6× in variance per layer), so the test exercises real values, not the 1e-10 eps.
        for s in net.slices:
            for m in s:
                if isinstance(m, nn.Conv2d):
                    fan_in = m.in_channels * 9
                    m.weight.normal_(0.0, (2.0 / fan_in) ** 0.5)
                    m.bias.uniform_(-0.1, 0.1)
        for lin in net.lins:
            lin[1].weight.uniform_(0.0, 1.0)  # the trained lin weights are non-negative
        img0 = torch.rand(1, 3, 64, 64)
        img1 = (img0 + 0.3 * torch.rand(1, 3, 64, 64) - 0.15).clamp(0, 1)
        val, layers = net(img0, img1)
    os.makedirs(os.path.join(out, "weights"), exist_ok=True)
    for key, t in net.lpips_state_dict().items():
        np.save(os.path.join(out, "weights", key + ".npy"), t.detach().numpy().astype(np.float32))
    np.save(os.path.join(out, "img0.npy"), img0[0].numpy().astype(np.float32))
    np.save(os.path.join(out, "img1.npy"), img1[0].numpy().astype(np.float32))
    with open(os.path.join(out, "expected.json"), "w") as f:
        json.dump({"distance": float(val.item()), "layers": [float(l.item()) for l in layers]}, f)


if __name__ == "__main__":
    main()
