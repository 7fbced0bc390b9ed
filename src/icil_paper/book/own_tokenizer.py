"""Chapter 14's worked example: a tokenizer of one file, loaded as a plugin and compared with
LipVQ-VAE on Table I's protocol (`icil-paper compare`): the `own-tokenizer` stage.

    path = write_example("my_plugins/")          # chunk_bins.py, the tokenizer `chunkbins`
    report = own_tokenizer_study(preset)         # loads it, runs (or loads) the comparison

The example: uniform bins over chunks of actions, summed learned embeddings, a linear decoder.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from icil_paper import plugins
from icil_paper.config import Preset
from icil_paper.results import ResultsStore
from icil_paper.stages import GRID
from icil_paper.tables import compare

EXAMPLE_NAME = "chunkbins"
EXAMPLE_FILE = "chunk_bins.py"
EXAMPLE_SOURCE = '''\
"""`chunkbins`: uniform bins over chunks of actions, a tokenizer of one file."""

from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import nn

from icil_paper.tokenizers import ActionTokenizer, TokenizerConfig, TokenizerOutput
from icil_paper.tokenizers import register_tokenizer


@register_tokenizer("chunkbins", "ChunkBinsTokenizer")
@dataclass(frozen=True)
class ChunkBinsConfig(TokenizerConfig):
    """`chunkbins`: each step embeds the uniform bins of its last `chunk` actions."""

    n_bins: int = 32
    """Uniform bins per action dimension over [-1, 1]."""
    chunk: int = 4
    """Actions per chunk: the step's own and the `chunk - 1` before it."""


class ChunkBinsTokenizer(ActionTokenizer):
    name = "chunkbins"
    discrete = True

    def __init__(self, config, action_dim):
        super().__init__(config, action_dim)
        self.n_bins, self.chunk = config.n_bins, config.chunk
        self.embed = nn.Embedding(config.chunk * action_dim * config.n_bins, config.latent_dim)
        self.decoder = nn.Linear(config.latent_dim, action_dim)

    @property
    def context_steps(self):
        return self.chunk

    def _forward(self, actions):  # (B, T, A)
        first = actions[:, :1].expand(-1, self.chunk - 1, -1)
        padded = torch.cat([first, actions], dim=1)  # (B, T + chunk - 1, A)
        windows = padded.unfold(1, self.chunk, 1).transpose(-1, -2)  # (B, T, chunk, A)
        codes = ((windows.clamp(-1, 1) + 1) / 2 * (self.n_bins - 1)).round().long()
        slots = torch.arange(self.chunk * self.action_dim, device=actions.device)
        ids = codes.flatten(2) + slots * self.n_bins  # (B, T, chunk * A)
        z = self.embed(ids).sum(2)  # (B, T, D)
        recon = self.decoder(z.detach())
        return TokenizerOutput(embeddings=z, reconstruction=recon, codes=codes[:, :, -1],
                               losses={"reconstruction": F.mse_loss(recon, actions)},
                               latents=z)
'''
"""The example plugin's source: what chapter 14 shows and writes to a file."""

CHAPTER_MAX_SEEDS = {"smoke": 2, "small": 2}
"""Seeds a row the chapter's comparison may plan up to, by preset (others: `compare.MAX_SEEDS`)."""


def example_folder(preset: Preset) -> Path:
    """Where the stage writes the example plugin and its comparison."""
    return ResultsStore(preset.name).dir / "compare" / EXAMPLE_NAME


def write_example(folder: str | Path) -> Path:
    """Write the example tokenizer to `folder`/chunk_bins.py (unchanged if it is there)."""
    path = Path(folder) / EXAMPLE_FILE
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.is_file() or path.read_text() != EXAMPLE_SOURCE:
        path.write_text(EXAMPLE_SOURCE)
    return path


def own_tokenizer_study(preset: Preset, store: ResultsStore | None = None,
                        force: bool = False) -> dict[str, Any]:
    """Write and load the example plugin, compare it with LipVQ-VAE; return the report."""
    folder = example_folder(preset)
    plugins.load_plugins([str(write_example(folder))])
    report = compare.compare(preset, EXAMPLE_NAME, ("lipvq",), effect=compare.DEFAULT_EFFECT,
                             max_seeds=CHAPTER_MAX_SEEDS.get(preset.name, compare.MAX_SEEDS),
                             executor=GRID["executor"], workers=GRID["workers"],
                             ray_address=GRID["ray_address"],
                             gpus_per_cell=GRID["gpus_per_cell"], progress=False)
    compare.write(report, folder)
    return report
