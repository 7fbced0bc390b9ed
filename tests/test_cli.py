import json
import subprocess
import sys

import pytest

from cli_helpers import run_cli
from icil_paper import cli
from icil_paper.config import PRESET_NAMES
from tools.system_deps import debian_backports_entry


def test_help_lists_every_subcommand(capsys):
    assert cli.main(["--help"]) == 0
    out = capsys.readouterr().out
    for command in ["env", "demos", "train", "eval", "tables", "reproduce", "compare", "plan",
                    "export-tokenizer"]:
        assert command in out
    for preset in PRESET_NAMES:
        assert f" {preset} (" in out


def test_unknown_command_is_an_error_listing_commands(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["fly"])
    assert exc.value.code == 2
    assert "valid commands: env, demos" in capsys.readouterr().err


def test_env_reports_packages_and_preset_without_simulators(capsys):
    assert cli.main(["env", "--no-sim", "--json", "--preset", "full"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["preset"] == "full"
    assert report["packages"]["torch"].startswith("2.")
    assert report["host"]["cpu_count"] >= 1


def test_env_rejects_unknown_preset(capsys):
    with pytest.raises(SystemExit):
        cli.main(["env", "--preset", "huge"])
    assert "invalid choice" in capsys.readouterr().err


def test_console_script_runs():
    out = subprocess.run([sys.executable, "-m", "icil_paper.cli", "--help"],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and "icil-paper" in out.stdout


@pytest.mark.sim
def test_env_checks_simulators():
    from icil_paper.setup.envcheck import check_simulators

    checks = {c.name: c for c in check_simulators()}
    assert checks["metaworld"].ok, checks["metaworld"].detail
    assert checks["robosuite"].ok, checks["robosuite"].detail
    assert checks["offscreen rendering"].ok, checks["offscreen rendering"].detail
    from icil_paper.setup.envcheck import vulkan_problem

    problem = vulkan_problem()
    if problem:
        pytest.skip(problem)
    assert checks["maniskill"].ok, checks["maniskill"].detail


def test_backports_entry_derived_from_deb822_source(tmp_path):
    (tmp_path / "sources.list.d").mkdir()
    (tmp_path / "sources.list.d" / "debian.sources").write_text(
        "Types: deb\nURIs: http://mirror.example/debian\nSuites: bookworm bookworm-updates\n"
        "Components: main\nSigned-By: /k.gpg\n\n"
        "Types: deb\nURIs: http://mirror.example/debian-security\n"
        "Suites: bookworm-security\nComponents: main\n")
    entry = debian_backports_entry(tmp_path)
    assert "URIs: http://mirror.example/debian\n" in entry
    assert "Suites: bookworm-backports" in entry and "Signed-By: /k.gpg" in entry


def test_backports_entry_from_one_line_sources_and_none_elsewhere(tmp_path):
    (tmp_path / "sources.list").write_text("deb http://m.example/debian bookworm main\n")
    assert "URIs: http://m.example/debian" in debian_backports_entry(tmp_path)
    (tmp_path / "sources.list").write_text("deb http://m.example/ubuntu noble main\n")
    assert debian_backports_entry(tmp_path) is None


def test_apt_get_install_updates_first_and_names_the_command_that_failed(monkeypatch):
    from tools import system_deps

    ran = []

    def fake_run(cmd, env):
        ran.append(cmd)
        assert env["DEBIAN_FRONTEND"] == "noninteractive"
        return subprocess.CompletedProcess(cmd, 100 if "install" in cmd else 0)

    monkeypatch.setattr(system_deps.subprocess, "run", fake_run)
    why = system_deps.apt_get_install("chromium")
    assert ran == [["apt-get", "update", "-qq"], ["apt-get", "install", "-y", "-qq", "chromium"]]
    assert why == "`apt-get install -y -qq chromium` failed"
    monkeypatch.setattr(system_deps.subprocess, "run",
                        lambda cmd, env: subprocess.CompletedProcess(cmd, 0))
    assert system_deps.apt_get_install("chromium") is None


# --------------------------------------------------------------------------- user errors
@pytest.mark.parametrize("argv,message", [
    (["train", "--tokenizer", "lipvqq"], "unknown tokenizer 'lipvqq'. Did you mean 'lipvq'"),
    (["train", "--policy", "bc_transformer", "--tokenizer", "vq"], "does not take the 'vq'"),
    (["train", "--tasks", "kitchen/open_drawr"], "Did you mean 'kitchen/open_drawer'"),
    (["train", "--steps", "0"], "--steps must be at least 1"),
    (["train", "--set", "train.stepz=3"], "Did you mean 'steps'"),
    (["train", "--set", "train.steps=many"], "train.steps: expected an integer"),
    (["train", "--seed", "-1"], "non-negative"),
    (["eval", "--episodes", "0"], "--episodes must be at least 1"),
    (["eval", "--max-steps", "-5"], "--max-steps must be at least 1"),
    (["eval", "--workers", "0"], "--workers must be at least 1"),
    (["reproduce", "--stages", "tabel-I"], "Did you mean 'table-I'"),
    (["tables", "--table", "VIII"], "unknown table"),
    (["demos", "--task", "kitchen/open_drawer", "--n", "0"], "--n must be at least 1"),
    (["train", "--set", "train.batch_size=0"], "train.batch_size counts something"),
    (["reproduce", "--set", "train.lr=-1"], "train.lr must be a finite number >= 0"),
    (["reproduce", "--gpus-per-cell", "-1"], "--gpus-per-cell must be between 0 and 64"),
    (["reproduce", "--executor", "ray", "--ray-address", "127.0.0.1:1"],
     "nothing answers at 127.0.0.1:1"),
])
def test_user_errors_are_one_line_and_exit_2_before_any_work(argv, message, tmp_path, monkeypatch):
    monkeypatch.setenv("ICIL_DATA", str(tmp_path / "data"))
    code, err = run_cli(*argv)
    assert code == 2, err
    assert message in err, err
    assert "Traceback" not in err and len(err.strip().splitlines()) <= 2
    assert not (tmp_path / "data").exists(), "no data may be generated before the check"


def test_damaged_run_folders_are_named_not_tracebacks(tmp_path):
    code, err = run_cli("eval", "--run-dir", str(tmp_path / "missing"))
    assert code == 2 and "not a training run folder" in err
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "config.json").write_text("{torn")
    code, err = run_cli("eval", "--run-dir", str(tmp_path / "run"))
    assert code == 2 and "Traceback" not in err


def test_debug_shows_the_traceback():
    with pytest.raises(ValueError, match="unknown tokenizer"):
        cli.main(["train", "--tokenizer", "lipvqq", "--debug"])


@pytest.mark.parametrize("var", ["ICIL_RESULTS", "ICIL_RUNS", "ICIL_DATA"])
def test_a_folder_variable_naming_a_file_is_a_one_line_error(var, tmp_path, monkeypatch):
    """$ICIL_RESULTS (RUNS, DATA) set to a file: the variable is named, nothing is written."""
    from icil_paper.data.generate import data_root
    from icil_paper.results import results_root
    from icil_paper.train.rundir import runs_root

    target = tmp_path / "a_file"
    target.write_text("not a folder")
    monkeypatch.setenv(var, str(target))
    root = {"ICIL_RESULTS": results_root, "ICIL_RUNS": runs_root, "ICIL_DATA": data_root}[var]
    named = "data\\.root=" if var == "ICIL_DATA" else f"\\${var}="  # $ICIL_DATA fills data.root
    with pytest.raises(NotADirectoryError, match=f"{named}.*is a file, not a folder"):
        root()
    code, err = run_cli("tables", "--preset", "smoke") if var == "ICIL_RESULTS" else \
        run_cli("train", "--preset", "smoke", "--tasks", "kitchen/open_drawer")
    assert code == 2 and f"${var}" in err and "Traceback" not in err, err
    assert target.read_text() == "not a folder"


@pytest.mark.slow
def test_eval_refuses_a_policy_of_another_action_width_before_any_work(tmp_path, monkeypatch):
    """A policy trained on a file with 3-D actions, evaluated on a 7-D kitchen task: one line
    naming both widths, and no prompt data set generated for it."""
    import h5py
    import numpy as np

    monkeypatch.setenv("ICIL_DATA", str(tmp_path / "data"))
    path = tmp_path / "three_d.hdf5"
    with h5py.File(path, "w") as f:
        for i in range(2):
            demo = f.create_group(f"data/demo_{i}")
            demo["actions"] = np.zeros((12, 3), np.float32)
            demo["obs/proprio"] = np.zeros((12, 9), np.float32)
            demo["obs/object"] = np.zeros((12, 18), np.float32)
            demo.attrs["num_samples"] = 12
    run_dir = tmp_path / "run"
    code, err = run_cli("train", "--preset", "smoke", "--dataset", str(path),
                        "--run-dir", str(run_dir))
    assert code == 0, err
    code, err = run_cli("eval", "--preset", "smoke", "--run-dir", str(run_dir),
                        "--tasks", "kitchen/open_drawer", "--episodes", "1")
    assert code == 2 and "acts in 3 dimensions" in err and "7-dimensional" in err, err
    assert not (tmp_path / "data").exists()
