"""One local Dask cluster for the scan tests (two worker processes, one thread each, as
``thinfilm scan`` starts by default on this machine), and the case scans run on it once."""

import pytest

from thinfilm.scan.execute import execute, local_cluster
from thinfilm.scan.plan import load_plan
from thinfilm.scan.table import read_table
from tests.helpers import CASES


@pytest.fixture(scope="session")
def client():
    from distributed import Client

    cluster = local_cluster(workers=2)
    with Client(cluster) as c:
        yield c
    cluster.close()


def _scan(client, tmp_path_factory, name):
    plan = load_plan(CASES / "scans" / f"{name}.toml")
    out = tmp_path_factory.mktemp(name)
    table, figure, counts = execute(plan, out, client=client)
    return plan, out, read_table(table), counts


@pytest.fixture(scope="session")
def exact1d_scan(client, tmp_path_factory):
    """``cases/scans/exact1d_lam.toml``: (plan, directory, table rows, status counts)."""
    return _scan(client, tmp_path_factory, "exact1d_lam")


@pytest.fixture(scope="session")
def spacing_scan(client, tmp_path_factory):
    """``cases/scans/cantilever_spacing.toml``, uninterrupted: the fault tests' reference."""
    return _scan(client, tmp_path_factory, "cantilever_spacing")
