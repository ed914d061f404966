"""Executors: a grid sweep (2 rows x 2 points, coarse grid) gives identical tables and files whether run
serially, in local processes or on a Dask LocalCluster started here."""
import pytest

from birdocp.engine.executors import DaskExecutor, ProcessExecutor, SerialExecutor, get_executor
from birdocp.studies.sweep import grid_sweep

GRID = dict(key="amplitude", values=[42.0, 43.0], row_key="root_ahead_m", row_values=[0.05, 0.048])


def _square(x):
    return x * x


def test_get_executor_choices():
    assert isinstance(get_executor(), SerialExecutor)
    assert isinstance(get_executor(jobs=1), SerialExecutor)
    assert isinstance(get_executor(jobs=2), ProcessExecutor)
    with pytest.raises(ValueError):
        get_executor(jobs=0)


def _files(d):
    return (d / "grid.json").read_text(), (d / "grid.csv").read_text()


@pytest.fixture(scope="module")
def serial(tmp_path_factory, coarse):
    d = tmp_path_factory.mktemp("serial")
    table = grid_sweep(None, **GRID, executor=SerialExecutor(), out_dir=d, **coarse)
    return table, d


def test_serial_grid(serial):
    table, d = serial
    assert [(r["row_value"], r["value"]) for r in table] == [(0.05, 42.0), (0.05, 43.0), (0.048, 42.0), (0.048, 43.0)]
    assert all(r["success"] for r in table)
    assert table[1]["warm_from"] == 0 and table[0]["warm_from"] is None


@pytest.mark.slow
def test_processes_match_serial(serial, tmp_path, coarse):
    table, d = serial
    with ProcessExecutor(2) as ex:
        assert ex.map(_square, [1, 2, 3]) == [1, 4, 9]
        t2 = grid_sweep(None, **GRID, executor=ex, out_dir=tmp_path, **coarse)
    assert t2 == table
    assert _files(tmp_path) == _files(d)


@pytest.mark.slow
def test_dask_local_cluster_matches_serial(serial, tmp_path, coarse):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cl, \
            distributed.Client(cl) as client:
        ex = DaskExecutor(client=client)
        assert ex.map(_square, [3, 4]) == [9, 16]
        t3 = grid_sweep(None, **GRID, executor=ex, out_dir=tmp_path, **coarse)
        ex.close()
    assert t3 == serial[0]
    assert _files(tmp_path) == _files(serial[1])


def test_cli_grid_bad_input(capsys):
    from birdocp.cli.main import main

    base = ["sweep", "amplitude", "--from", "42", "--to", "43", "--by", "1"]
    assert main(base + ["--jobs", "2"]) == 2
    assert "--rows" in capsys.readouterr().err
    assert main(base + ["--rows", "root_ahead_m=0.05"]) == 2
    assert main(base + ["--rows", "amplitude=40:41:1", "--jobs", "2"]) == 2


def test_process_workers_started_in_main_thread_serve_a_helper_thread():
    """Workers started by ``start()`` in this thread serve a map from a helper thread and keep serving
    after that thread has ended."""
    import threading

    with ProcessExecutor(1).start() as ex:
        out: list = []
        th = threading.Thread(target=lambda: out.extend(ex.map(_square, [2, 3])))
        th.start()
        th.join(timeout=120)
        assert out == [4, 9]
        assert ex.map(_square, [5]) == [25]


def test_process_workers_first_used_by_an_ended_thread_keep_serving():
    """A pool first used by a helper thread outlives it (its workers belong to the executor's own thread,
    not to the thread that first mapped: before, they died with it and the next map waited for ever)."""
    import threading

    ex = ProcessExecutor(1)
    try:
        out: list = []
        th = threading.Thread(target=lambda: out.extend(ex.map(_square, [2, 3])))
        th.start()
        th.join(timeout=120)
        assert out == [4, 9]
        done: list = []
        again = threading.Thread(target=lambda: done.extend(ex.map(_square, [5])), daemon=True)
        again.start()
        again.join(timeout=120)
        assert done == [25], "the map after the first thread ended did not finish in 120 s"
    finally:
        # terminate, not close: a pool that lost its workers would make close() wait for ever
        threading.Thread(target=ex.terminate, daemon=True).start()


def test_process_pool_start_failure_and_concurrent_first_maps():
    """A pool that cannot start raises in the caller (and leaves no thread waiting); two threads mapping
    first at once share one pool."""
    import threading

    from birdocp.engine import executors

    before = {t.name for t in threading.enumerate()}
    bad = ProcessExecutor(1)
    bad.jobs = 0  # multiprocessing refuses a pool of 0 processes
    with pytest.raises(ValueError):
        bad.map(_square, [1])
    assert sum(t.name == "birdocp-pool-owner" for t in threading.enumerate()) == \
        sum(n == "birdocp-pool-owner" for n in before)
    made: list = []
    real = executors._pool_in_own_thread
    with ProcessExecutor(1) as ex:
        executors._pool_in_own_thread = lambda jobs: made.append(jobs) or real(jobs)
        try:
            outs: list = [[], []]
            ths = [threading.Thread(target=lambda i=i: outs[i].extend(ex.map(_square, [i + 2]))) for i in range(2)]
            for t in ths:
                t.start()
            for t in ths:
                t.join(timeout=120)
        finally:
            executors._pool_in_own_thread = real
        assert outs == [[4], [9]] and made == [1]
