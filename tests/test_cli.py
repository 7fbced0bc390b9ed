import json
import subprocess
import sys

import pytest

from icil_paper import cli
from icil_paper.system_deps import debian_backports_entry


def test_help_lists_every_subcommand(capsys):
    assert cli.main(["--help"]) == 0
    out = capsys.readouterr().out
    for command in ["env", "demos", "train", "eval", "tables", "reproduce"]:
        assert command in out


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
    from icil_paper.envcheck import check_simulators

    checks = {c.name: c for c in check_simulators()}
    assert checks["robosuite"].ok, checks["robosuite"].detail
    assert checks["offscreen rendering"].ok, checks["offscreen rendering"].detail
    from icil_paper.system_deps import vulkan_problem

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
