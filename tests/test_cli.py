"""The timpm command: records, JSON, plots and clear errors."""
import json

import pytest

from timpm.cli.main import main

REQUIRED = {"problem", "elements", "ppc", "basis", "mass", "dt", "t_end", "steps", "rms_error",
            "wall_seconds", "grid_crossings"}


def test_convergence_json_and_plot(tmp_path, capsys):
    out, png = tmp_path / "out.json", tmp_path / "conv.png"
    assert main(["convergence", "vibrating-string", "--elements", "4", "8", "16",
                 "--json", str(out), "--plot", str(png)]) == 0
    doc = json.loads(out.read_text())
    assert len(doc["runs"]) == 3 and REQUIRED <= set(doc["runs"][0])
    assert [r["from"] for r in doc["rates"]] == [4, 8]
    assert 1.9 < doc["rates"][-1]["rate"] < 2.1
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    table = capsys.readouterr().out
    assert "e_RMS" in table and "8.3003e-04" in table


def test_run_json_and_time_series_plot(tmp_path):
    out, png = tmp_path / "run.json", tmp_path / "series.png"
    assert main(["run", "soil-column", "--elements", "10", "--ppc", "2", "--dt", "1e-3",
                 "--t-end", "0.2", "--json", str(out), "--plot", str(png), "--quiet"]) == 0
    rec = json.loads(out.read_text())["runs"][0]
    assert REQUIRED <= set(rec)
    assert rec["steps"] == 200 and rec["elements"] == 10 and rec["rms_error"] > 0
    assert png.stat().st_size > 10_000


def test_param_override_and_list(capsys):
    assert main(["run", "oedometer", "--stress-update", "small", "--param", "p0=100",
                 "--elements", "4", "--ppc", "4", "--t-end", "2"]) == 0
    assert "exact_strain = -0.001" in capsys.readouterr().out
    assert main(["list"]) == 0
    assert "vibrating-bar" in capsys.readouterr().out


@pytest.mark.parametrize("argv,message", [
    (["run", "nope"], "unknown problem 'nope'"),
    (["run", "vibrating-string", "--dt", "1"], "exceeds the critical time step"),
    (["run", "vibrating-string", "--param", "E=-1"], "parameter E must be positive"),
    (["run", "vibrating-string", "--param", "Q=1"], "no parameter Q"),
])
def test_bad_input_exits_with_a_message(argv, message, capsys):
    assert main(argv) == 2
    assert message in capsys.readouterr().err


@pytest.mark.parametrize("argv, message", [
    (["run", "vibrating-string", "--elements", "0"], "argument --elements: must be a positive integer, got 0"),
    (["run", "vibrating-string", "--ppc", "-1"], "argument --ppc: must be a positive integer, got -1"),
])
def test_a_count_is_refused_by_the_parser(argv, message, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    assert message in capsys.readouterr().err


@pytest.mark.parametrize("argv, option", [
    (["run", "vibrating-string", "--basis", "cubic"], "--basis"),
    (["compare-ulfem", "--basis", "cubic"], "--basis"),
    (["study", "speed-error", "vibrating-string", "--bases", "linear", "cubic"], "--bases"),
])
def test_a_wrong_basis_is_refused_by_the_parser(argv, option, capsys):
    # where the command line is read, before Taichi starts: argparse's usage error, the
    # option named, the known bases listed
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {option}: unknown basis 'cubic'" in err and "bsplineN" in err
