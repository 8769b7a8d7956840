import os

import pytest

import timpm


def pytest_configure(config):
    # two threads at most: CI machines have two cores
    timpm.init(threads=int(os.environ.get("TIMPM_THREADS", "2")))


@pytest.fixture(scope="session")
def study_table_3_2():
    """Runs of the vibrating string with the study's Table 3.2 settings (defaults)."""
    from timpm.studies.study import convergence

    return convergence("vibrating-string", elements=(4, 8, 16, 32, 64))
