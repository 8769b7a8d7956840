import os

import pytest

# no banner or start-up notes from Taichi in the test processes: pytest-xdist's workers
# would print them after pytest's summary line
os.environ.setdefault("ENABLE_TAICHI_HEADER_PRINT", "false")
os.environ.setdefault("TI_LOG_LEVEL", "warn")

import timpm  # noqa: E402


def pytest_configure(config):
    # the process that runs tests starts Taichi (with pytest-xdist, each worker does; the
    # controller only distributes the test files); two threads at most: CI machines have
    # two cores
    controller = getattr(config.option, "numprocesses", None) and \
        "PYTEST_XDIST_WORKER" not in os.environ
    if not controller:
        timpm.init(threads=int(os.environ.get("TIMPM_THREADS", "2")))


@pytest.fixture(scope="session")
def study_table_3_2():
    """Runs of the vibrating string with the study's Table 3.2 settings (defaults)."""
    from timpm.studies.study import convergence

    return convergence("vibrating-string", elements=(4, 8, 16, 32, 64))
