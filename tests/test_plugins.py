"""Plugins: a tokenizer defined outside the package, as a file, a module or an installed
package's entry point, trains, exports, runs in `icil-paper compare` on the local pool and
on Ray (loaded in every worker), and is named in every record it makes; a bad plugin stops
every command with one line and exit 2 before anything is written."""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from icil_paper import cli, plugins
from icil_paper.book.own_tokenizer import EXAMPLE_NAME, EXAMPLE_SOURCE
from icil_paper.tables.claims import VERDICTS

TASK = "kitchen/open_drawer"

GOOD = EXAMPLE_SOURCE  # the chapter's tokenizer `chunkbins`, one file

HEADER = '''
from dataclasses import dataclass, field

import torch.nn.functional as F
from torch import nn

from icil_paper.tokenizers import ActionTokenizer, TokenizerConfig, TokenizerOutput
from icil_paper.tokenizers import register_tokenizer
'''

LINEAR = '''

class Linear(ActionTokenizer):
    name = "linear"

    def __init__(self, config, action_dim):
        super().__init__(config, action_dim)
        self.encoder = nn.Linear(action_dim, config.latent_dim)
        self.decoder = nn.Linear(config.latent_dim, action_dim)

    def _forward(self, actions):
        z = self.encoder(actions){reduce}
        recon = self.decoder(z.detach())
        if recon.ndim == 2:
            recon = recon[:, None].expand_as(actions)
        return TokenizerOutput(embeddings=z, reconstruction=recon, codes=None,
                               losses={{"reconstruction": F.mse_loss(recon, actions)}})
'''


def _config(name: str, body: str = "    scale: float = 1.0\n    \"\"\"A factor.\"\"\"\n",
            decorator: str = "@dataclass(frozen=True)") -> str:
    return (f'\n\n@register_tokenizer("{name}", "Linear")\n{decorator}\n'
            f"class Config(TokenizerConfig):\n    \"\"\"`{name}`.\"\"\"\n\n{body}")


BAD = {
    "missing file": (None, "no such file"),
    "missing module": ("no_such_plugin_module_41", "no module named 'no_such_plugin_module_41'"),
    "registers nothing": ("x = 1\n", "registers nothing"),
    "built-in name": (HEADER + _config("vq") + LINEAR.format(reduce=""),
                      "registers the tokenizer 'vq', a name a built-in already has"),
    "field without default": (
        HEADER + _config("nodefault", "    scale: float\n    \"\"\"A factor.\"\"\"\n",
                         "@dataclass(frozen=True, kw_only=True)") + LINEAR.format(reduce=""),
        "fields without a default (scale)"),
    "no validation": (
        HEADER + _config("novalid", "    scale: float = 1.0\n\n    def __post_init__(self):\n"
                                    "        pass\n") + LINEAR.format(reduce=""),
        "does not check its values"),
    "wrong shape": (HEADER + _config("flat") + LINEAR.format(reduce=".mean(1)  # (B, D)"),
                    "returns embeddings of shape (2, 64), expected (B, T, latent_dim)"),
    "import error": ("raise RuntimeError('broken on purpose')\n", "importing it failed"),
}


@pytest.fixture
def clean_plugins():
    """Leave the registries, the loaded plugins and the imported modules as they were."""
    regs = {kind: plugins.REGISTRIES[kind] for kind in plugins.REGISTRIES}
    saved = {kind: (dict(r.configs), dict(r.models)) for kind, r in regs.items()}
    discovered = set(plugins._DISCOVERED)
    loaded, modules = dict(plugins._LOADED), set(sys.modules)
    yield
    for kind, r in regs.items():
        for mapping, old in zip((r.configs, r.models), saved[kind], strict=True):
            mapping.clear()
            mapping.update(old)
    plugins._DISCOVERED.clear()
    plugins._DISCOVERED.update(discovered)
    plugins._LOADED.clear()
    plugins._LOADED.update(loaded)
    for name in set(sys.modules) - modules:
        if name.startswith("icil_plugin_") or name.startswith("toks41"):
            sys.modules.pop(name, None)


def _forget_plugins() -> None:
    """This process as one that never loaded a plugin (`clean_plugins` restores it)."""
    for kind in plugins.REGISTRIES:
        reg = plugins.REGISTRIES[kind]
        reg.forget([n for n in list(reg.configs) if plugins.owner(kind, n)])
    plugins._LOADED.clear()


@pytest.mark.parametrize("case", list(BAD))
def test_a_bad_plugin_stops_every_command_with_one_line_before_writing(
        case, tmp_path, folders, clean_plugins, capsys):
    source, message = BAD[case]
    if source is None:
        spec = str(tmp_path / "absent.py")
    elif "\n" not in source:
        spec = source
    else:
        spec = str(tmp_path / "plugin.py")
        Path(spec).write_text(textwrap.dedent(source))
    before = {kind: list(plugins.REGISTRIES[kind].configs) for kind in plugins.REGISTRIES}
    for command in (["train", "--preset", "smoke", "--tasks", TASK, "--set", "train.steps=1"],
                    ["compare", "--preset", "smoke", "--tokenizer", "vq"]):
        code = cli.main([command[0], "--plugin", spec, *command[1:]])
        err = capsys.readouterr().err
        assert code == 2, err
        assert len(err.strip().splitlines()) == 1 and message in err, err
        assert "Traceback" not in err
    assert not any(p.exists() for p in folders.values())  # nothing written
    after = {kind: list(plugins.REGISTRIES[kind].configs) for kind in plugins.REGISTRIES}
    assert after == before  # a refused plugin leaves nothing registered


def test_the_example_plugin_trains_exports_and_is_named_in_its_records(
        tmp_path, folders, clean_plugins, capsys):
    from icil_paper.tokenizers import load_tokenizer
    from icil_paper.tokenizers.portable import TokenizerFolderError

    path = tmp_path / "chunk_bins.py"
    path.write_text(GOOD)
    digest = hashlib.sha256(GOOD.encode()).hexdigest()
    run_dir = tmp_path / "run"
    assert cli.main(["train", "--plugin", str(path), "--preset", "smoke", "--tokenizer",
                     EXAMPLE_NAME, "--tasks", TASK, "--set", "train.steps=2",
                     "--set", f"tokenizers.{EXAMPLE_NAME}.n_bins=8",
                     "--run-dir", str(run_dir), "--quiet"]) == 0
    assert f"icrt+{EXAMPLE_NAME} trained for 2 steps" in capsys.readouterr().out
    record = json.loads(next((folders["results"] / "smoke" / "train").glob("*.json"))
                        .read_text())
    assert record["config"]["tokenizer"]["n_bins"] == 8
    (named,) = record["plugins"]
    assert named["sha256"] == digest and named["source"] == "file"
    assert named["names"] == {"tokenizer": [EXAMPLE_NAME]}

    out = tmp_path / "exported"
    assert cli.main(["export-tokenizer", "--plugin", str(path), str(run_dir), str(out)]) == 0
    assert "plugins=" in capsys.readouterr().out
    tok = load_tokenizer(out)  # the plugin is loaded in this process
    assert tok.name == EXAMPLE_NAME and tok.config.n_bins == 8
    _forget_plugins()  # a process without the plugin: the folder and the policy file name it
    with pytest.raises(TokenizerFolderError, match=f"plugin {path} \\(sha256 {digest[:12]}\\)"):
        load_tokenizer(out)
    assert cli.main(["export-tokenizer", str(run_dir), str(tmp_path / "again")]) == 2
    err = capsys.readouterr().err
    assert f"needs the plugin {path}" in err and f"--plugin {path}" in err
    assert load_tokenizer(out, plugins=[str(path)]).config.n_bins == 8


def test_a_plugin_loaded_first_in_a_fresh_process_names_only_its_own_components(tmp_path):
    """A grid worker loads the plugin before anything imports the tokenizer registry: the
    built-ins its import brings in are not the plugin's."""
    path = tmp_path / "chunk_bins.py"
    path.write_text(GOOD)
    code = ("import json; from icil_paper import plugins; "
            f"p = plugins.load_plugin({str(path)!r}); print(json.dumps(p.record()['names']))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    assert json.loads(out.stdout.strip().splitlines()[-1]) == {"tokenizer": [EXAMPLE_NAME]}


def _install(site: Path, monkeypatch) -> None:
    """A package `toks41` 0.3 with an entry point `pcatok` in `icil_paper.tokenizers`,
    installed as pip would lay it out (its .dist-info beside it) on sys.path."""
    (site / "toks41").mkdir(parents=True)
    (site / "toks41" / "__init__.py").write_text("")
    source = GOOD.replace('"chunkbins"', '"pcatok"').replace("`chunkbins`", "`pcatok`")
    (site / "toks41" / "pca.py").write_text(source)
    info = site / "toks41-0.3.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: toks41\nVersion: 0.3\n")
    (info / "entry_points.txt").write_text("[icil_paper.tokenizers]\npcatok = toks41.pca\n")
    monkeypatch.syspath_prepend(str(site))
    plugins._DISCOVERED.clear()  # as a fresh process: discovery on first use


def test_an_installed_entry_point_is_found_by_the_registry_and_trains(
        tmp_path, folders, clean_plugins, monkeypatch, capsys):
    from icil_paper.config import get_preset
    from icil_paper.tokenizers import REGISTRY, make_tokenizer

    _install(tmp_path / "site", monkeypatch)
    assert make_tokenizer("pcatok", 7).name == "pcatok"  # found on first use, no --plugin
    assert "pcatok" in list(REGISTRY) and "pcatok" in get_preset("smoke").tokenizers
    assert cli.main(["train", "--preset", "smoke", "--tokenizer", "pcatok", "--tasks", TASK,
                     "--set", "train.steps=1", "--run-dir", str(tmp_path / "run"),
                     "--quiet"]) == 0, capsys.readouterr().err
    record = json.loads(next((folders["results"] / "smoke" / "train").glob("*.json"))
                        .read_text())
    (named,) = record["plugins"]
    assert (named["source"], named["distribution"], named["version"]) == (
        "entry point", "toks41", "0.3")
    # the chapter's comparison, through the installed package
    assert cli.main(["compare", "--preset", "smoke", "--tokenizer", "pcatok", "--seeds", "2",
                     "--set", f"data.robocasa_tasks={TASK}", "--executor", "serial", "--quiet",
                     "--out", str(tmp_path / "out")]) == 0, capsys.readouterr().err
    report = json.loads((tmp_path / "out" / "compare.json").read_text())
    assert report["comparisons"][0]["verdict"] in VERDICTS
    assert report["plugins"][0]["version"] == "0.3"
    # an entry point that clashes with a built-in stops the command in one line
    (tmp_path / "site" / "toks41-0.3.dist-info" / "entry_points.txt").write_text(
        "[icil_paper.tokenizers]\nvq = toks41.clash\n")
    (tmp_path / "site" / "toks41" / "clash.py").write_text(
        GOOD.replace('"chunkbins"', '"vq"'))
    plugins._DISCOVERED.clear()
    plugins._LOADED.clear()
    assert cli.main(["train", "--preset", "smoke", "--tasks", TASK]) == 2
    err = capsys.readouterr().err
    assert "entry point 'vq'" in err and "a name a built-in already has" in err


def _compare(tmp_path, executor: str, *extra: str, source: str = GOOD) -> int:
    path = tmp_path / "chunk_bins.py"
    path.write_text(source)
    return cli.main(["compare", "--plugin", str(path), "--preset", "smoke", "--tokenizer",
                     EXAMPLE_NAME, "--seeds", "2", "--set", f"data.robocasa_tasks={TASK}",
                     "--executor", executor, "--workers", "2", "--quiet",
                     "--out", str(tmp_path / f"out-{executor}"), *extra])


def _check_report(folder: Path, n_bins: int) -> dict:
    report = json.loads((folder / "compare.json").read_text())
    assert (folder / "compare.png").stat().st_size > 1000
    (entry,) = report["comparisons"]
    assert entry["verdict"] in VERDICTS and entry["verdict"] != "not run"
    assert entry["ci"][0] <= entry["ours"] <= entry["ci"][1]
    assert entry["seeds"] == {f"icrt+{EXAMPLE_NAME}": 2, "icrt+lipvq": 2}
    assert report["plugins"][0]["names"] == {"tokenizer": [EXAMPLE_NAME]}
    return report


def _plugin_records(results: Path, n_bins: int) -> list[dict]:
    records = [json.loads(p.read_text()) for p in (results / "smoke" / "eval").glob(
        f"icrt_{EXAMPLE_NAME}__*.json")]
    return [r for r in records if r["config"]["run"]["tokenizer"]["n_bins"] == n_bins]


@pytest.mark.ray
@pytest.mark.slow
def test_compare_runs_a_plugin_file_on_the_local_pool_and_on_ray(
        tmp_path, folders, clean_plugins, capsys):
    assert _compare(tmp_path, "local") == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    assert f"icrt+{EXAMPLE_NAME} minus icrt+lipvq" in out and "seeds: fixed at 2" in out
    assert "the paper's" not in out  # sized against --effect
    _check_report(tmp_path / "out-local", 32)
    made = _plugin_records(folders["results"], 32)
    assert len(made) == 2 and all(r["plugins"][0]["sha256"] for r in made)  # in the workers

    # the file edited (as a fresh process sees it): its stored cells are reused, and said so
    _forget_plugins()
    assert _compare(tmp_path, "local", source=GOOD + "# edited\n") == 0
    assert "warning: 2 stored icrt+chunkbins cell(s) were made by another version" in \
        capsys.readouterr().out

    ray = pytest.importorskip("ray", reason="Ray is not installed")
    if ray.is_initialized():
        pytest.skip("a Ray session is already open in this process")
    # another config of the plugin: its two cells run on Ray, LipVQ-VAE's are reused
    code = _compare(tmp_path, "ray", "--set", f"tokenizers.{EXAMPLE_NAME}.n_bins=16")
    err = capsys.readouterr().err
    if code == 2 and "Ray" in err:
        pytest.skip(f"Ray cannot start here: {err.strip()}")
    assert code == 0, err
    _check_report(tmp_path / "out-ray", 16)
    assert len(_plugin_records(folders["results"], 16)) == 2
