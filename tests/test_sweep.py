"""Sweeps on worker processes and Dask: the serial records to the last digit, in the serial
order, and clear errors (each pool or cluster spawns processes that import Taichi and
compile: the meshes are tiny and few)."""
import json
import os
import sys

import pytest

from timpm.cli.main import main
from timpm.simulation.solver import SimulationError
from timpm.studies.study import convergence
from timpm.studies.sweep import SweepError, map_runs

#: what differs between two runs of one mesh: the times
TIMES = {"wall_seconds", "compile_seconds", "build_seconds"}


def _without_times(records):
    return [{k: v for k, v in r.items() if k not in TIMES} for r in records]


def _die(code):
    """A task whose worker process exits without a result."""
    os._exit(code)


_STARTED = []


def _numbered(name):
    """``name`` and how many tasks this worker process started before it."""
    _STARTED.append(name)
    return name, len(_STARTED) - 1


def _fail(message):
    raise SimulationError(message, code=5, step=7)


@pytest.fixture(scope="module")
def serial():
    return convergence("soil-column", elements=(4, 8, 16))


# ---- the serial results ---------------------------------------------------------------------

def test_local_dask_cluster_gives_the_serial_records(serial):
    pytest.importorskip("distributed")
    local = convergence("soil-column", elements=(4, 8, 16), dask="local")
    assert [r["rms_error"] for r in local["runs"]] == [r["rms_error"] for r in serial["runs"]]
    assert _without_times(local["runs"]) == _without_times(serial["runs"])
    assert local["rates"] == serial["rates"]


def test_cli_workers_give_the_serial_errors_to_the_last_digit(tmp_path, capsys):
    argv = ["convergence", "soil-column", "--elements", "4", "8"]
    assert main(argv + ["--json", str(tmp_path / "serial.json")]) == 0
    serial_table = capsys.readouterr().out
    assert main(argv + ["--workers", "2", "--json", str(tmp_path / "workers.json")]) == 0
    workers_table = capsys.readouterr().out
    docs = [json.loads((tmp_path / f"{name}.json").read_text()) for name in ("serial", "workers")]
    assert [r["elements"] for r in docs[1]["runs"]] == [4, 8]
    assert [r["rms_error"] for r in docs[1]["runs"]] == [r["rms_error"] for r in docs[0]["runs"]]
    assert _without_times(docs[1]["runs"]) == _without_times(docs[0]["runs"])

    def errors(table):  # e_RMS, ratio and log2 of each row
        return [line.split()[2:5] for line in table.splitlines() if line.split()[0].isdigit()]

    assert errors(workers_table) == errors(serial_table) and len(errors(serial_table)) == 2


def test_a_runs_error_in_a_worker_reads_as_in_the_serial_run(capsys):
    # dt = 0.02 s is stable on 4 elements, not on 8: the worker of the second mesh raises
    argv = ["convergence", "soil-column", "--elements", "4", "8", "--dt", "0.02"]
    assert main(argv) == 2
    serial = capsys.readouterr().err
    assert main(argv + ["--workers", "2"]) == 2
    err = capsys.readouterr().err
    assert err == serial
    assert err.startswith("timpm: error: time step dt = 0.02 s exceeds the critical time step")
    assert "Traceback" not in err


def test_costliest_runs_start_first_and_results_keep_their_order():
    # one worker: it starts the calls one by one, costliest first
    results = map_runs(_numbered, [("a",), ("b",), ("c",)], workers=1, cost=[1, 3, 2])
    assert results == [("a", 2), ("b", 0), ("c", 1)]


def test_a_worker_that_dies_and_a_simulation_error_there():
    with pytest.raises(SimulationError, match="^blew up$") as info:
        map_runs(_fail, [("blew up",)], workers=1)
    assert (info.value.code, info.value.step) == (5, 7)
    with pytest.raises(SweepError, match=r"a worker process died before its run finished"):
        map_runs(_die, [(3,)], workers=1)


def test_workers_start_taichi_with_this_processes_settings():
    from taichi.lang import impl

    from timpm.platform import runtime

    # the thread count resolved: a worker on a machine with other cores runs as many
    assert runtime.settings() == dict(threads=runtime.cpu_threads(),
                                      precision=runtime.precision(), arch=runtime.arch(),
                                      debug=False, pin=True,
                                      optimize=bool(impl.current_cfg().cfg_optimization),
                                      fast_math=bool(impl.current_cfg().fast_math))


# ---- checked before any work ----------------------------------------------------------------

@pytest.mark.parametrize("kwargs, message", [
    (dict(workers=0), "workers must be a positive integer (worker processes), got 0"),
    (dict(workers=2.5), "workers must be a positive integer (worker processes), got 2.5"),
    (dict(workers=True), "workers must be a positive integer (worker processes), got True"),
    (dict(workers=2, dask="local"), "give workers or dask, not both (workers=2, "
                                    "dask='local'): worker processes on this machine or a "
                                    "Dask cluster"),
    (dict(dask=""), "dask must be a scheduler address such as tcp://host:8786 or 'local', "
                    "got ''"),
    (dict(workers=2, batch=True), "batch runs the meshes side by side in this process: give "
                                  "batch or workers / dask, not both"),
])
def test_bad_executors_are_refused(kwargs, message):
    with pytest.raises(ValueError) as info:
        convergence("soil-column", elements=(4,), **kwargs)
    assert str(info.value) == message


def test_cli_refuses_bad_workers_and_both(capsys):
    for argv, message in [(["--workers", "0"], "argument --workers: must be a positive "
                                               "integer, got 0"),
                          (["--workers", "2.5"], "argument --workers: '2.5' is not an integer"),
                          (["--workers", "2", "--dask", "local"],
                           "argument --dask: not allowed with argument --workers")]:
        with pytest.raises(SystemExit) as info:
            main(["convergence", "soil-column", *argv])
        assert info.value.code == 2 and message in capsys.readouterr().err


def test_scheduler_errors_name_the_address():
    distributed = pytest.importorskip("distributed")
    with pytest.raises(SweepError, match=r"^cannot reach the Dask scheduler at "
                                         r"tcp://127\.0\.0\.1:9 within 0\.5 s"):
        map_runs(_die, [(3,)], dask="tcp://127.0.0.1:9", connect_timeout=0.5)
    with pytest.raises(SweepError) as info:
        map_runs(_die, [(3,)], dask="scheduler", connect_timeout=0.5)
    assert str(info.value) == ("dask='scheduler' is not a scheduler address such as "
                               "tcp://host:8786 (or 'local'): missing port number in address "
                               "'scheduler'")
    with distributed.LocalCluster(n_workers=0, dashboard_address=None) as idle:
        address = idle.scheduler_address
        with pytest.raises(SweepError) as info:
            map_runs(_die, [(3,)], dask=address, connect_timeout=0.5)
    assert str(info.value) == (f"the Dask scheduler at {address} has no workers (waited "
                               f"0.5 s): start some with: dask worker {address} --nthreads 1")


def test_missing_dask_says_how_to_install(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed fails
    with pytest.raises(SweepError) as info:
        map_runs(_die, [(3,)], dask="local")
    assert str(info.value) == ("dask='local' needs dask.distributed, which is not installed: "
                               "pip install 'timpm[dask]'")
    assert main(["convergence", "soil-column", "--elements", "4", "--dask", "local"]) == 2
    assert capsys.readouterr().err == ("timpm: error: dask='local' needs dask.distributed, "
                                       "which is not installed: pip install 'timpm[dask]'\n")


def test_speed_error_study_on_workers_gives_the_serial_records(tmp_path):
    # linear elements lumped on 4 and 8, and a configuration that is skipped (too few
    # particles per element for cubic B-splines)
    argv = ["study", "speed-error", "vibrating-string", "--bases", "linear", "bspline3",
            "--masses", "lumped", "--elements", "4", "8", "--ppc", "1", "--t-end", "0.01",
            "--repeats", "1", "--quiet"]
    assert main(argv + ["--json", str(tmp_path / "serial.json")]) == 0
    assert main(argv + ["--workers", "2", "--json", str(tmp_path / "workers.json")]) == 0
    serial, workers = (json.loads((tmp_path / f"{name}.json").read_text())
                       for name in ("serial", "workers"))
    times = {"wall_seconds", "wall_samples", "first_run_seconds", "compile_seconds", "pareto"}
    assert [{k: v for k, v in r.items() if k not in times} for r in workers["runs"]] == \
        [{k: v for k, v in r.items() if k not in times} for r in serial["runs"]]
    assert [(r["basis"], r["elements"]) for r in workers["runs"]] == [("linear", 4), ("linear", 8)]
    assert workers["skipped"] == serial["skipped"] and len(serial["skipped"]) == 2
