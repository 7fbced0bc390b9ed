"""Observation backbones: what turns one observation into one token.

    proprio (P,) ┐
    object  (O,) ┴─ concat ─ normalize ─ MLP ──────────────────┐
    rgb (n_cams, H, W, 3) [+ depth (n_cams, H, W)]              ├─ concat ─ Linear ─(+ text)─> token (D,)
                 └─ per camera: ResNet-18 ─ avgpool ─ concat ───┘
    instruction ─ hashed bag of words ─ EmbeddingBag ──────────────────────────────┘ (optional)

- Low-dimensional state is normalized with statistics fitted on the training
  demonstrations (`ObservationEncoder.set_stats`, saved with the weights).
- Images go through the library's own ResNet-18, laid out as torchvision's `resnet18`, with
  GroupNorm by default (as diffusion_policy), trained from scratch.
- The paper embeds language with CLIP; offline, `HashedTextEmbedding` stands in: a learned
  bag of words, each lower-cased word hashed (CRC-32) into one of `n_buckets` vectors.
"""

from __future__ import annotations

import re
import zlib
from collections.abc import Mapping, Sequence

import numpy as np
import torch
from torch import Tensor, nn

from icil_paper.layers import mlp
from icil_paper.policies.batching import ObsSpec


# --------------------------------------------------------------------------- ResNet-18
def _norm2d(kind: str, channels: int) -> nn.Module:
    if kind == "batch":
        return nn.BatchNorm2d(channels)
    if kind == "group":
        return nn.GroupNorm(max(1, channels // 16), channels)
    raise ValueError(f"norm must be 'batch' or 'group', got {kind!r}")


class BasicBlock(nn.Module):
    """torchvision's BasicBlock: two 3x3 convolutions and a residual connection."""

    def __init__(self, inplanes: int, planes: int, stride: int = 1, norm: str = "group"):
        super().__init__()
        self.conv1 = nn.Conv2d(inplanes, planes, 3, stride=stride, padding=1, bias=False)
        self.bn1 = _norm2d(norm, planes)
        self.relu = nn.ReLU(inplace=True)
        self.conv2 = nn.Conv2d(planes, planes, 3, padding=1, bias=False)
        self.bn2 = _norm2d(norm, planes)
        self.downsample = None
        if stride != 1 or inplanes != planes:
            self.downsample = nn.Sequential(
                nn.Conv2d(inplanes, planes, 1, stride=stride, bias=False), _norm2d(norm, planes))

    def forward(self, x: Tensor) -> Tensor:
        identity = x if self.downsample is None else self.downsample(x)
        out = self.relu(self.bn1(self.conv1(x)))
        out = self.bn2(self.conv2(out))
        return self.relu(out + identity)


class ResNet18(nn.Module):
    """ResNet-18 with torchvision's layout; returns pooled features (N, 8 * width).

    in_channels: 3 for RGB, 4 for RGB-D; width: first-stage channels (torchvision: 64);
    norm: "group" or "batch" (torchvision's); num_classes: size of `fc` (None: features).
    """

    def __init__(self, in_channels: int = 3, width: int = 64, norm: str = "group",
                 num_classes: int | None = None):
        super().__init__()
        self.inplanes = width
        self.conv1 = nn.Conv2d(in_channels, width, 7, stride=2, padding=3, bias=False)
        self.bn1 = _norm2d(norm, width)
        self.relu = nn.ReLU(inplace=True)
        self.maxpool = nn.MaxPool2d(kernel_size=3, stride=2, padding=1)
        self.layer1 = self._layer(width, 1, norm)
        self.layer2 = self._layer(width * 2, 2, norm)
        self.layer3 = self._layer(width * 4, 2, norm)
        self.layer4 = self._layer(width * 8, 2, norm)
        self.avgpool = nn.AdaptiveAvgPool2d((1, 1))
        self.out_dim = width * 8
        self.fc = nn.Linear(self.out_dim, num_classes) if num_classes else nn.Identity()
        for m in self.modules():
            if isinstance(m, nn.Conv2d):
                nn.init.kaiming_normal_(m.weight, mode="fan_out", nonlinearity="relu")

    def _layer(self, planes: int, stride: int, norm: str) -> nn.Sequential:
        blocks = [BasicBlock(self.inplanes, planes, stride, norm), BasicBlock(planes, planes, 1, norm)]
        self.inplanes = planes
        return nn.Sequential(*blocks)

    def forward(self, x: Tensor) -> Tensor:
        """x (N, C, H, W) float -> (N, 8 * width) (or (N, num_classes) with a classifier)."""
        x = self.maxpool(self.relu(self.bn1(self.conv1(x))))
        x = self.layer4(self.layer3(self.layer2(self.layer1(x))))
        return self.fc(torch.flatten(self.avgpool(x), 1))


# --------------------------------------------------------------------------- language
_WORD = re.compile(r"[a-z0-9]+")


def hash_words(text: str, n_buckets: int) -> list[int]:
    """Bucket ids of the lower-cased words of `text` (CRC-32, stable across runs)."""
    words = _WORD.findall(text.lower()) or ["<empty>"]
    return [zlib.crc32(w.encode()) % n_buckets for w in words]


class HashedTextEmbedding(nn.Module):
    """A learned bag-of-words embedding of an instruction (stands in for CLIP)."""

    def __init__(self, dim: int, n_buckets: int = 4096):
        super().__init__()
        self.n_buckets = n_buckets
        self.bag = nn.EmbeddingBag(n_buckets, dim, mode="mean")
        nn.init.normal_(self.bag.weight, std=0.02)

    def forward(self, texts: Sequence[str]) -> Tensor:
        """texts: B strings -> (B, dim)."""
        ids = [hash_words(t or "", self.n_buckets) for t in texts]
        offsets = torch.tensor([0] + [len(i) for i in ids[:-1]]).cumsum(0)
        flat = torch.tensor([i for row in ids for i in row], dtype=torch.long)
        return self.bag(flat.to(self.bag.weight.device), offsets.to(self.bag.weight.device))


# --------------------------------------------------------------------------- the encoder
class ObservationEncoder(nn.Module):
    """Observation dict (B, T, ...) -> one token per step (B, T, D).

    hidden: width of the low-dimensional MLP; language: add the instruction embedding;
    separate: one token per part instead, (B, T, n_parts, D) with parts [state, camera 1,
    ..., instruction] (ACT's encoder reads its observation this way).
    """

    def __init__(self, spec: ObsSpec, d_model: int, hidden: int = 256, resnet_width: int = 64,
                 language: bool = False, separate: bool = False):
        super().__init__()
        self.spec, self.d_model, self.language, self.separate = spec, d_model, language, separate
        parts = 0
        if spec.lowdim_dim:
            self.lowdim_mlp = mlp([spec.lowdim_dim, hidden, d_model], nn.GELU, final_activation=True)
            self.register_buffer("lowdim_mean", torch.zeros(spec.lowdim_dim))
            self.register_buffer("lowdim_std", torch.ones(spec.lowdim_dim))
            parts += d_model
        if spec.image is not None:
            self.resnet = ResNet18(in_channels=4 if spec.depth else 3, width=resnet_width)
            if separate:
                self.image_proj = nn.Linear(self.resnet.out_dim, d_model)  # per camera
            else:
                self.image_proj = nn.Linear(spec.image[0] * self.resnet.out_dim, d_model)
            self.register_buffer("depth_mean", torch.zeros(()))
            self.register_buffer("depth_std", torch.ones(()))
            parts += d_model
        if parts == 0:
            raise ValueError("an observation encoder needs low-dimensional keys or images")
        self.fuse = None if separate else nn.Linear(parts, d_model)
        self.text = HashedTextEmbedding(d_model) if language else None

    @property
    def n_parts(self) -> int:
        """Tokens per step in `separate` mode."""
        n_cams = self.spec.image[0] if self.spec.image is not None else 0
        return int(bool(self.spec.lowdim_dim)) + n_cams + int(self.language)

    # -- statistics ---------------------------------------------------------------
    def set_stats(self, obs: Mapping[str, np.ndarray]) -> None:
        """Fit normalization to training observations (arrays with a leading step axis)."""
        if self.spec.lowdim_dim and all(k in obs for k in self.spec.lowdim_keys):
            x = np.concatenate([np.asarray(obs[k], np.float64).reshape(len(obs[k]), -1)
                                for k in self.spec.lowdim_keys], axis=-1)
            self.lowdim_mean.copy_(torch.as_tensor(x.mean(0), dtype=torch.float32))
            # a constant dimension (e.g. zero padding) keeps std 1 instead of exploding
            std = x.std(0)
            self.lowdim_std.copy_(torch.as_tensor(np.where(std < 1e-6, 1.0, std), dtype=torch.float32))
        if self.spec.depth and "depth" in obs:
            d = np.asarray(obs["depth"], np.float64)
            self.depth_mean.fill_(float(d.mean()))
            self.depth_std.fill_(float(max(d.std(), 1e-6)))

    # -- parts ---------------------------------------------------------------------
    def lowdim(self, obs: Mapping[str, Tensor]) -> Tensor:
        """Normalized low-dimensional state (B, T, lowdim_dim)."""
        x = torch.cat([obs[k].float().flatten(2) for k in self.spec.lowdim_keys], dim=-1)
        if x.shape[-1] != self.spec.lowdim_dim:
            raise ValueError(f"observation keys {self.spec.lowdim_keys} have {x.shape[-1]} "
                             f"values in all, the policy expects {self.spec.lowdim_dim}")
        return (x - self.lowdim_mean) / self.lowdim_std

    def image_features(self, obs: Mapping[str, Tensor]) -> Tensor:
        """Per-camera ResNet features (B, T, n_cams, F)."""
        rgb = obs["rgb"]  # (B, T, n, H, W, 3) uint8
        B, T, n, H, W, _ = rgb.shape
        x = rgb.reshape(B * T * n, H, W, 3).permute(0, 3, 1, 2).float() / 127.5 - 1.0
        if self.spec.depth:
            d = obs["depth"].reshape(B * T * n, 1, H, W).float()
            x = torch.cat([x, (d - self.depth_mean) / self.depth_std], dim=1)
        return self.resnet(x).view(B, T, n, -1)

    def forward(self, obs: Mapping[str, Tensor], instructions: Sequence[str] | None = None) -> Tensor:
        """obs: key -> (B, T, ...) tensors; instructions: B strings (if language) -> (B, T, D)
        (or (B, T, n_parts, D) in `separate` mode)."""
        parts = []
        if self.spec.lowdim_dim:
            parts.append(self.lowdim_mlp(self.lowdim(obs)))  # (B, T, D)
        if self.spec.image is not None:
            feats = self.image_features(obs)  # (B, T, n_cams, F)
            if self.separate:
                parts.extend(self.image_proj(feats).unbind(dim=2))
            else:
                parts.append(self.image_proj(feats.flatten(2)))
        text = None
        if self.text is not None:
            B = parts[0].shape[0]
            texts = list(instructions) if instructions is not None else [""] * B
            text = self.text(texts)[:, None, :]  # (B, 1, D)
        if self.separate:
            if text is not None:
                parts.append(text.expand_as(parts[0]))
            return torch.stack(parts, dim=2)  # (B, T, n_parts, D)
        token = self.fuse(torch.cat(parts, dim=-1))  # (B, T, D)
        return token if text is None else token + text
