#!/usr/bin/env python3
"""PyTorch references for lrf's C++ autoencoders and weight readers (run by the C++ tests).

Writes fixtures into the folder given on the command line, never into the repository:
  taef2   --weights DIR --input IN.safetensors --out DIR
          TAESD-family network (taesd.py's architecture, with TAEF2's GroupNorm "pool" branch) on the
          real weights: DIR/ref.safetensors {"latent", "decoded"} for the input {"image"}.
  kl      --out DIR [--ch 32] [--size 64] [--seed 0]
          KL-f8 AutoencoderKL (ldm's architecture) with random weights, saved as ldm and diffusers key
          layouts in .safetensors and .ckpt, plus reference.safetensors {"image", "moments", "decoded"}.
  vaelight --weights DIR --input IN.safetensors --out DIR
          VAElight (the README of its weights, written with nn.ConvTranspose2d and F.interpolate) on the
          real checkpoints: DIR/ref.safetensors {"latent", "decoded"} for the input {"image"} in [0, 1].
  zipcases --out DIR
          torch.save checkpoints with views / dtypes ({"views.pth", "views_expected.safetensors"}) and
          hostile archives built as bytes (nothing is executed): evil_*.pth, huge_storage.pth,
          view_overflow.pth.
"""
import argparse
import collections
import json
import os
import struct
import sys
import zipfile

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F

# ---------- minimal safetensors IO (the safetensors package is not a Debian dependency) ----------
_DT = {"F32": np.float32, "F16": np.float16, "I64": np.int64}


def save_safetensors(path, tensors):
    header, blobs, offset = {}, [], 0
    for name, t in tensors.items():
        t = t.detach().contiguous()
        if t.dtype == torch.bfloat16:
            raw, dt = t.view(torch.int16).numpy().tobytes(), "BF16"
        else:
            dt = {torch.float32: "F32", torch.float16: "F16", torch.int64: "I64"}[t.dtype]
            raw = t.numpy().tobytes()
        header[name] = {"dtype": dt, "shape": list(t.shape), "data_offsets": [offset, offset + len(raw)]}
        offset += len(raw)
        blobs.append(raw)
    text = json.dumps(header).encode()
    text += b" " * ((8 - (8 + len(text)) % 8) % 8)
    with open(path, "wb") as f:
        f.write(struct.pack("<Q", len(text)) + text + b"".join(blobs))


def load_safetensors(path):
    data = open(path, "rb").read()
    n = struct.unpack("<Q", data[:8])[0]
    header = json.loads(data[8:8 + n])
    out = {}
    for name, e in header.items():
        if name == "__metadata__":
            continue
        b, end = e["data_offsets"]
        arr = np.frombuffer(data[8 + n + b:8 + n + end], dtype=_DT[e["dtype"]]).reshape(e["shape"])
        out[name] = torch.from_numpy(arr.copy())
    return out


# ---------- tiny autoencoder (TAESD family; TAEF2 adds the pool branch) ----------
def conv(n_in, n_out, **kw):
    return nn.Conv2d(n_in, n_out, 3, padding=1, **kw)


class Clamp(nn.Module):
    def forward(self, x):
        return torch.tanh(x / 3) * 3


class Block(nn.Module):
    def __init__(self, n, pool):
        super().__init__()
        self.conv = nn.Sequential(conv(n, n), nn.ReLU(), conv(n, n), nn.ReLU(), conv(n, n))
        self.pool = None
        if pool:
            self.pool = nn.Sequential(nn.Conv2d(n, 4 * n, 1, bias=False), nn.GroupNorm(4, 4 * n), nn.ReLU(),
                                      nn.Conv2d(4 * n, n, 1, bias=False))

    def forward(self, x):
        if self.pool is not None:
            x = x + self.pool(x)
        return F.relu(self.conv(x) + x)


def tiny_encoder(c, pools):
    layers = [conv(3, 64), Block(64, 1 in pools)]
    for level in range(3):
        layers.append(conv(64, 64, stride=2, bias=False))
        layers += [Block(64, (3 + 4 * level + i) in pools) for i in range(3)]
    layers.append(conv(64, c))
    return nn.Sequential(*layers)


def tiny_decoder(c, pools):
    layers = [Clamp(), conv(c, 64), nn.ReLU()]
    for level in range(3):
        layers += [Block(64, (3 + 5 * level + i) in pools) for i in range(3)]
        layers += [nn.Upsample(scale_factor=2), conv(64, 64, bias=False)]
    layers += [Block(64, 18 in pools), conv(64, 3)]
    return nn.Sequential(*layers)


def pool_indices(sd):
    return {int(k.split(".")[0]) for k in sd if ".pool." in k}


def cmd_taef2(a):
    enc_sd = torch.load(os.path.join(a.weights, "taef2_encoder.pth"), map_location="cpu")
    dec_sd = torch.load(os.path.join(a.weights, "taef2_decoder.pth"), map_location="cpu")
    c = enc_sd["14.weight"].shape[0]
    enc, dec = tiny_encoder(c, pool_indices(enc_sd)), tiny_decoder(c, pool_indices(dec_sd))
    enc.load_state_dict(enc_sd)
    dec.load_state_dict(dec_sd)
    image = load_safetensors(a.input)["image"].float()
    with torch.no_grad():
        latent = enc.float()(image)
        decoded = dec.float()(latent).clamp(0, 1)
    os.makedirs(a.out, exist_ok=True)
    save_safetensors(os.path.join(a.out, "ref.safetensors"), {"latent": latent, "decoded": decoded})


# ---------- VAElight (4 channels, SD's latent space) ----------
class VaeLightEncoder(nn.Module):
    def __init__(self):
        super().__init__()
        down = lambda i, o: nn.Conv2d(i, o, 2, stride=2)
        self.cv1, self.cv2, self.cv3 = down(3, 16), conv(16, 32), down(32, 32)
        self.cv4, self.cv5, self.cv6 = conv(32, 64), down(64, 64), conv(64, 4)
        self.cv14, self.cv15, self.cv16 = conv(3, 64), conv(64, 64), conv(64, 64)
        self.cv17, self.cv18 = conv(64, 128), conv(128, 4)
        self.norm1, self.norm2, self.norm3 = nn.LayerNorm(32), nn.LayerNorm(64), nn.LayerNorm(4)  # unused

    def forward(self, x):
        a = x
        for layer in (self.cv1, self.cv2, self.cv3, self.cv4, self.cv5):
            a = F.leaky_relu(layer(a), 0.01)
        a = self.cv6(a)
        b = F.avg_pool2d(x, 8)
        for layer in (self.cv14, self.cv15, self.cv16, self.cv17):
            b = F.leaky_relu(layer(b), 0.01)
        return a + self.cv18(b)


class VaeLightDecoder(nn.Module):
    # Each branch: names with "T" for a transposed convolution (kernel 2, stride 2).
    BRANCHES = [
        [("cv1", 4, 8), ("cv2", 8, 16), ("cv3", 16, 16, "T"), ("cv4", 16, 32), ("cv5", 32, 64),
         ("cv6", 64, 64, "T"), ("cv7", 64, 64), ("cv8", 64, 64), ("cv9", 64, 64, "T"), ("cv10", 64, 64),
         ("cv11", 64, 3)],
        [("c4v1", 4, 8), ("c4v2", 8, 16), ("c4v3", 16, 16, "T"), ("c4v4", 16, 32), ("c4v5", 32, 64),
         ("c4v6", 64, 64, "T"), ("c4v7", 64, 64), ("c4v8", 64, 3)],
        [("c3v1", 4, 8), ("c3v2", 8, 16), ("c3v3", 16, 16, "T"), ("c3v4", 16, 32), ("c3v5", 32, 3)],
        [("c2v1", 4, 8), ("c2v2", 8, 16), ("c2v3", 16, 32), ("c2v4", 32, 3)],
    ]

    def __init__(self):
        super().__init__()
        for branch in self.BRANCHES:
            for spec in branch:
                name, i, o = spec[:3]
                layer = nn.ConvTranspose2d(i, o, 2, stride=2) if len(spec) == 4 else conv(i, o)
                setattr(self, name, layer)

    def forward(self, z):
        out = 0
        for branch, scale in zip(self.BRANCHES, (1, 2, 4, 8)):
            y = z
            for n, spec in enumerate(branch):
                y = getattr(self, spec[0])(y)
                if n + 1 < len(branch):
                    y = F.leaky_relu(y, 0.01)
            if scale > 1:
                y = F.interpolate(y, scale_factor=scale, mode="bilinear", align_corners=False)
            out = out + y
        return out


def cmd_vaelight(a):
    files = sorted(os.listdir(a.weights))
    enc_file = [f for f in files if "encoder" in f and f.endswith(".pt")][0]
    dec_file = [f for f in files if "decoder" in f and f.endswith(".pt")][0]
    enc, dec = VaeLightEncoder(), VaeLightDecoder()
    enc.load_state_dict(torch.load(os.path.join(a.weights, enc_file), map_location="cpu")["model"])
    dec.load_state_dict(torch.load(os.path.join(a.weights, dec_file), map_location="cpu")["model"])
    image = load_safetensors(a.input)["image"].float()
    with torch.no_grad():
        latent = enc(image * 2 - 1)
        decoded = (dec(latent).clamp(-1, 1) + 1) / 2
    os.makedirs(a.out, exist_ok=True)
    save_safetensors(os.path.join(a.out, "ref.safetensors"), {"latent": latent, "decoded": decoded})


# ---------- KL-f8 AutoencoderKL (ldm layout) ----------
def gn(c):
    return nn.GroupNorm(32, c, eps=1e-6)


class ResnetBlock(nn.Module):
    def __init__(self, cin, cout):
        super().__init__()
        self.norm1, self.conv1 = gn(cin), nn.Conv2d(cin, cout, 3, padding=1)
        self.norm2, self.conv2 = gn(cout), nn.Conv2d(cout, cout, 3, padding=1)
        if cin != cout:
            self.nin_shortcut = nn.Conv2d(cin, cout, 1)

    def forward(self, x):
        h = self.conv1(F.silu(self.norm1(x)))
        h = self.conv2(F.silu(self.norm2(h)))
        return (self.nin_shortcut(x) if hasattr(self, "nin_shortcut") else x) + h


class AttnBlock(nn.Module):
    def __init__(self, c):
        super().__init__()
        self.norm = gn(c)
        self.q, self.k, self.v, self.proj_out = (nn.Conv2d(c, c, 1) for _ in range(4))

    def forward(self, x):
        h = self.norm(x)
        b, c, hh, ww = x.shape
        q = self.q(h).reshape(b, c, -1).permute(0, 2, 1)
        k = self.k(h).reshape(b, c, -1)
        v = self.v(h).reshape(b, c, -1)
        w = torch.softmax(torch.bmm(q, k) * (c ** -0.5), dim=2)
        out = torch.bmm(v, w.permute(0, 2, 1)).reshape(b, c, hh, ww)
        return x + self.proj_out(out)


class Down(nn.Module):
    def __init__(self, c):
        super().__init__()
        self.conv = nn.Conv2d(c, c, 3, stride=2)

    def forward(self, x):
        return self.conv(F.pad(x, (0, 1, 0, 1)))


class Up(nn.Module):
    def __init__(self, c):
        super().__init__()
        self.conv = nn.Conv2d(c, c, 3, padding=1)

    def forward(self, x):
        return self.conv(F.interpolate(x, scale_factor=2.0, mode="nearest"))


class Mid(nn.Module):
    def __init__(self, c):
        super().__init__()
        self.block_1, self.attn_1, self.block_2 = ResnetBlock(c, c), AttnBlock(c), ResnetBlock(c, c)

    def forward(self, x):
        return self.block_2(self.attn_1(self.block_1(x)))


class KLEncoder(nn.Module):
    def __init__(self, ch, mult, nres, z):
        super().__init__()
        self.conv_in = nn.Conv2d(3, ch, 3, padding=1)
        self.down = nn.ModuleList()
        cin = ch
        for i, m in enumerate(mult):
            level = nn.Module()
            level.block = nn.ModuleList([ResnetBlock(cin if j == 0 else ch * m, ch * m) for j in range(nres)])
            if i != len(mult) - 1:
                level.downsample = Down(ch * m)
            self.down.append(level)
            cin = ch * m
        self.mid, self.norm_out, self.conv_out = Mid(cin), gn(cin), nn.Conv2d(cin, 2 * z, 3, padding=1)

    def forward(self, x):
        x = self.conv_in(x)
        for level in self.down:
            for b in level.block:
                x = b(x)
            if hasattr(level, "downsample"):
                x = level.downsample(x)
        return self.conv_out(F.silu(self.norm_out(self.mid(x))))


class KLDecoder(nn.Module):
    def __init__(self, ch, mult, nres, z):
        super().__init__()
        cin = ch * mult[-1]
        self.conv_in = nn.Conv2d(z, cin, 3, padding=1)
        self.mid = Mid(cin)
        levels = [None] * len(mult)
        for i in reversed(range(len(mult))):
            level = nn.Module()
            level.block = nn.ModuleList([ResnetBlock(cin if j == 0 else ch * mult[i], ch * mult[i])
                                         for j in range(nres + 1)])
            if i != 0:
                level.upsample = Up(ch * mult[i])
            levels[i] = level
            cin = ch * mult[i]
        self.up = nn.ModuleList(levels)
        self.norm_out, self.conv_out = gn(cin), nn.Conv2d(cin, 3, 3, padding=1)

    def forward(self, z):
        x = self.mid(self.conv_in(z))
        for level in reversed(self.up):
            for b in level.block:
                x = b(x)
            if hasattr(level, "upsample"):
                x = level.upsample(x)
        return self.conv_out(F.silu(self.norm_out(x)))


class KLVAE(nn.Module):
    def __init__(self, ch=128, mult=(1, 2, 4, 4), nres=2, z=4):
        super().__init__()
        self.encoder, self.decoder = KLEncoder(ch, mult, nres, z), KLDecoder(ch, mult, nres, z)
        self.quant_conv, self.post_quant_conv = nn.Conv2d(2 * z, 2 * z, 1), nn.Conv2d(z, z, 1)


def ldm_to_diffusers(sd, levels, old_attention_names):
    """ldm key names -> diffusers AutoencoderKL names (attention projections as Linear weights)."""
    import re
    attn = {"q": "query", "k": "key", "v": "value", "proj_out": "proj_attn"} if old_attention_names else \
        {"q": "to_q", "k": "to_k", "v": "to_v", "proj_out": "to_out.0"}
    out = collections.OrderedDict()
    for k, v in sd.items():
        n = k
        n = re.sub(r"^(encoder|decoder)\.norm_out\.", r"\1.conv_norm_out.", n)
        n = re.sub(r"^encoder\.down\.(\d+)\.block\.(\d+)\.", r"encoder.down_blocks.\1.resnets.\2.", n)
        n = re.sub(r"^encoder\.down\.(\d+)\.downsample\.", r"encoder.down_blocks.\1.downsamplers.0.", n)
        n = re.sub(r"^decoder\.up\.(\d+)\.block\.(\d+)\.",
                   lambda m: f"decoder.up_blocks.{levels - 1 - int(m[1])}.resnets.{m[2]}.", n)
        n = re.sub(r"^decoder\.up\.(\d+)\.upsample\.",
                   lambda m: f"decoder.up_blocks.{levels - 1 - int(m[1])}.upsamplers.0.", n)
        n = re.sub(r"\.mid\.block_1\.", ".mid_block.resnets.0.", n)
        n = re.sub(r"\.mid\.block_2\.", ".mid_block.resnets.1.", n)
        n = re.sub(r"\.mid\.attn_1\.norm\.", ".mid_block.attentions.0.group_norm.", n)
        m = re.match(r"^(.*)\.mid\.attn_1\.(q|k|v|proj_out)\.(weight|bias)$", n)
        if m:
            n = f"{m[1]}.mid_block.attentions.0.{attn[m[2]]}.{m[3]}"
            if m[3] == "weight":
                v = v.reshape(v.shape[0], v.shape[1])
        n = n.replace(".nin_shortcut.", ".conv_shortcut.")
        out[n] = v
    return out


def cmd_kl(a):
    torch.manual_seed(a.seed)
    mult = (1, 2, 4, 4)
    vae = KLVAE(ch=a.ch, mult=mult).float()
    with torch.no_grad():
        # Every parameter random (norm scales too), so that any mis-mapped key changes the output.
        for name, p in vae.named_parameters():
            if "norm" in name and name.endswith("weight"):
                p.copy_(1 + 0.2 * torch.randn_like(p))
            elif name.endswith("bias"):
                p.copy_(0.05 * torch.randn_like(p))
    sd = collections.OrderedDict((k, v.detach().clone()) for k, v in vae.state_dict().items())
    os.makedirs(a.out, exist_ok=True)
    save_safetensors(os.path.join(a.out, "kl_ldm.safetensors"), sd)
    torch.save({"state_dict": collections.OrderedDict(("first_stage_model." + k, v) for k, v in sd.items()),
                "global_step": 7}, os.path.join(a.out, "kl_ldm.ckpt"))
    save_safetensors(os.path.join(a.out, "kl_diffusers.safetensors"), ldm_to_diffusers(sd, len(mult), False))
    torch.save(ldm_to_diffusers(sd, len(mult), True), os.path.join(a.out, "kl_diffusers.ckpt"))

    g = torch.Generator().manual_seed(a.seed + 1)
    yy, xx = torch.meshgrid(torch.linspace(0, 1, a.size), torch.linspace(0, 1, a.size), indexing="ij")
    image = torch.stack([xx, yy, 0.5 + 0.5 * torch.sin(6 * xx * yy)])[None]
    image = (image + 0.05 * torch.rand(image.shape, generator=g)).clamp(0, 1)
    with torch.no_grad():
        moments = vae.quant_conv(vae.encoder(image * 2 - 1))
        mean, logvar = moments.chunk(2, dim=1)
        moments = torch.cat([mean, logvar.clamp(-30, 20)], 1)
        decoded = ((vae.decoder(vae.post_quant_conv(mean)) + 1) / 2).clamp(0, 1)
    save_safetensors(os.path.join(a.out, "reference.safetensors"),
                     {"image": image, "moments": moments, "decoded": decoded})


# ---------- checkpoints for the zip / pickle readers ----------
def raw_zip(path, pickle_bytes, storages):
    """A torch-style archive written by hand: <root>/data.pkl + <root>/data/<key>, stored."""
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_STORED) as z:
        z.writestr("archive/data.pkl", pickle_bytes)
        z.writestr("archive/byteorder", "little")
        z.writestr("archive/version", "3\n")
        for key, data in storages.items():
            z.writestr("archive/data/" + key, data)


def tensor_pickle(storage_type, key, numel, offset, size, stride):
    """Pickle (protocol 2) of OrderedDict{'w': _rebuild_tensor_v2(persistent storage, ...)}."""
    def tup(vals):
        return b"(" + b"".join(b"J" + struct.pack("<i", v) for v in vals) + b"t"
    return (b"\x80\x02ccollections\nOrderedDict\n)R(X\x01\x00\x00\x00w"
            b"ctorch._utils\n_rebuild_tensor_v2\n("
            b"(X\x07\x00\x00\x00storagectorch\n" + storage_type.encode() + b"\nX" + struct.pack("<I", len(key)) +
            key.encode() + b"X\x03\x00\x00\x00cpuJ" + struct.pack("<i", numel) + b"tQ" +
            b"J" + struct.pack("<i", offset) + tup(size) + tup(stride) +
            b"\x89ccollections\nOrderedDict\n)RtRu.")


def cmd_zipcases(a):
    os.makedirs(a.out, exist_ok=True)
    torch.manual_seed(0)
    base = torch.randn(6, 8)
    tensors = collections.OrderedDict([
        ("narrow", base[2:5, 1:7]),            # storage offset + non-contiguous strides
        ("transposed", base.t()),              # permuted strides
        ("half", torch.randn(3, 5).half()),
        ("bfloat16", torch.randn(4, 2).bfloat16()),
        ("long", torch.arange(-3, 9, dtype=torch.int64).reshape(3, 4)),
        ("scalar", torch.tensor(2.5)),
        ("empty", torch.zeros(0, 3)),
        ("shared_again", base[0]),             # shares base's storage
    ])
    torch.save({"state_dict": tensors, "epoch": 3, "note": "hello"}, os.path.join(a.out, "views.pth"))
    # A training checkpoint (torch.save of model, optimizer, loss, step), and one that holds no weights.
    model = collections.OrderedDict([("conv.weight", torch.randn(2, 3, 1, 1)), ("conv.bias", torch.randn(2))])
    optimizer = {"state": {0: {"step": torch.tensor(7.0), "exp_avg": torch.randn(2, 3, 1, 1)}},
                 "param_groups": [{"lr": 1e-3, "params": [0, 1]}]}
    torch.save({"model": model, "optimizer": optimizer, "loss": torch.tensor(0.25), "iterations": 7},
               os.path.join(a.out, "training.pth"))
    save_safetensors(os.path.join(a.out, "training_expected.safetensors"), model)
    torch.save({"loss": torch.tensor(0.25), "iterations": 7}, os.path.join(a.out, "scalars_only.pth"))
    save_safetensors(os.path.join(a.out, "views_expected.safetensors"),
                     collections.OrderedDict((k, v.contiguous()) for k, v in tensors.items() if k != "empty"))
    # Hostile pickles: globals outside the allow-list, as GLOBAL and as STACK_GLOBAL (protocol 4).
    raw_zip(os.path.join(a.out, "evil_os_system.pth"),
            b"\x80\x02cos\nsystem\nX\x0a\x00\x00\x00touch pwnd\x85R.", {})
    raw_zip(os.path.join(a.out, "evil_eval.pth"),
            b"\x80\x04\x8c\x08builtins\x8c\x04eval\x93X\x04\x00\x00\x001+1\x85R.", {})
    raw_zip(os.path.join(a.out, "evil_popen.pth"),
            b"\x80\x02csubprocess\nPopen\nX\x02\x00\x00\x00ls\x85R.", {})
    # A storage that claims 10^9 elements but holds 16 bytes.
    raw_zip(os.path.join(a.out, "huge_storage.pth"),
            tensor_pickle("FloatStorage", "0", 1_000_000_000, 0, [4], [1]), {"0": b"\0" * 16})
    # A view reaching past the end of its 4-element storage.
    raw_zip(os.path.join(a.out, "view_overflow.pth"),
            tensor_pickle("FloatStorage", "0", 4, 2, [3], [1]), {"0": b"\0" * 16})
    # A storage entry whose central-directory size claims 4 GB in a file of a few hundred bytes.
    path = os.path.join(a.out, "entry_past_end.pth")
    raw_zip(path, tensor_pickle("FloatStorage", "0", 4, 0, [4], [1]), {"0": b"\0" * 16})
    data = bytearray(open(path, "rb").read())
    at = data.find(b"PK\x01\x02")
    while at >= 0:
        n = struct.unpack("<H", data[at + 28:at + 30])[0]
        if data[at + 46:at + 46 + n] == b"archive/data/0":
            data[at + 20:at + 28] = struct.pack("<II", 0xF0000000, 0xF0000000)
        at = data.find(b"PK\x01\x02", at + 4)
    open(path, "wb").write(bytes(data))
    # A re-zipped checkpoint with deflate-compressed entries (torch.save never compresses).
    with zipfile.ZipFile(os.path.join(a.out, "compressed.pth"), "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.writestr("archive/data.pkl", tensor_pickle("FloatStorage", "0", 4, 0, [4], [1]))
        z.writestr("archive/data/0", b"\0" * 16)
    # A well-formed hand-built one (checks the helper itself).
    raw_zip(os.path.join(a.out, "handmade_ok.pth"),
            tensor_pickle("FloatStorage", "0", 4, 1, [2], [2]), {"0": struct.pack("<4f", 1, 2, 3, 4)})


def main():
    p = argparse.ArgumentParser()
    sub = p.add_subparsers(dest="cmd", required=True)
    t = sub.add_parser("taef2")
    t.add_argument("--weights", required=True)
    t.add_argument("--input", required=True)
    t.add_argument("--out", required=True)
    k = sub.add_parser("kl")
    k.add_argument("--out", required=True)
    k.add_argument("--ch", type=int, default=32)
    k.add_argument("--size", type=int, default=64)
    k.add_argument("--seed", type=int, default=0)
    v = sub.add_parser("vaelight")
    v.add_argument("--weights", required=True)
    v.add_argument("--input", required=True)
    v.add_argument("--out", required=True)
    z = sub.add_parser("zipcases")
    z.add_argument("--out", required=True)
    a = p.parse_args()
    torch.set_num_threads(2)
    {"taef2": cmd_taef2, "kl": cmd_kl, "vaelight": cmd_vaelight, "zipcases": cmd_zipcases}[a.cmd](a)


if __name__ == "__main__":
    sys.exit(main())
