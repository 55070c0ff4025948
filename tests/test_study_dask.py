"""``proleg.study`` on Dask and local processes: killing a Dask worker mid-study, or the
driver process itself, loses nothing already written and duplicates nothing; the rerun
completes the study with every variant exactly once.

Slow (each worker process imports JAX and compiles the batch: ~20–60 s on the 2-core VM);
run with ``pytest -m slow tests/test_study_dask.py``.
"""

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

import proleg as pl

from test_study import make_study, pendulum

pytestmark = pytest.mark.slow
HERE = Path(__file__).parent


def test_killing_a_dask_worker_mid_study_loses_and_duplicates_nothing(tmp_path):
    from distributed import Client, LocalCluster

    st = make_study(pendulum())
    killed = []
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, Client(cluster) as client:
        pids = client.run(os.getpid)

        def kill_a_busy_worker(rows):
            if killed:
                return
            busy = [w for w, tasks in client.processing().items() if tasks]
            if busy:
                os.kill(pids[busy[0]], signal.SIGKILL)  # a worker process this test's cluster started
                killed.append(busy[0])

        tab = st.run(design="lhs", n=12, seed=5, executor="dask", scheduler=client, store=tmp_path / "s", batch_size=2,
                     progress=False, on_batch=kill_a_busy_worker)
    assert killed, "no worker was busy when the first batch came back"
    rows = pl.study.Store(tmp_path / "s").read()
    assert len(rows) == 12 and rows["key"].is_unique and set(rows["key"]) == set(tab["key"])
    assert (rows["status"] == "success").all()
    assert pl.study.Store(tmp_path / "s").status()["pending"] == 0


DRIVER = textwrap.dedent(
    """
    import sys
    sys.path.insert(0, {tests!r})
    from test_study import make_study, pendulum
    if __name__ == "__main__":
        make_study(pendulum()).run(design="lhs", n=12, seed=7, executor="dask", store={store!r}, batch_size=2, workers=2, progress=False)
    """
)


def test_killing_the_driver_loses_and_duplicates_nothing(tmp_path):
    store = tmp_path / "s"
    script = tmp_path / "driver.py"
    script.write_text(DRIVER.format(tests=str(HERE), store=str(store)))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE.parent / "src"), os.environ.get("PYTHONPATH", "")]))
    # its own session: the driver, its LocalCluster's nannies and workers form one process group
    proc = subprocess.Popen([sys.executable, str(script)], env=env, start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    t0 = time.time()
    try:
        while time.time() - t0 < 400:
            if proc.poll() is not None:
                pytest.fail(f"the driver ended before it was killed: {proc.stderr.read().decode()[-2000:]}")
            if len(list((store / "rows").glob("part-*.parquet"))) >= 1 if (store / "rows").exists() else False:
                break
            time.sleep(0.2)
        else:
            pytest.fail("no batch was written in 400 s")
    finally:
        os.killpg(proc.pid, signal.SIGKILL)  # the driver and the processes it started
        proc.wait()
    before = pl.study.Store(store).read()
    assert 1 <= len(before) < 12 and before["key"].is_unique
    ran = []
    tab = make_study(pendulum()).run(design="lhs", n=12, seed=7, executor="vmap", store=store, batch_size=2, workers=1,
                                     progress=False, on_batch=lambda r: ran.extend(x["key"] for x in r))
    after = pl.study.Store(store).read()
    assert len(after) == 12 and after["key"].is_unique and len(tab) == 12
    assert len(ran) == 12 - len(before) and not set(ran) & set(before["key"])  # nothing recomputed
    kept = after.set_index("key").loc[before["key"], "batch"]
    assert list(kept) == list(before["batch"])  # rows written before the kill are untouched


def test_processes_executor_equals_vmap_and_survives_a_killed_worker(tmp_path):
    """The "processes" executor (spawned worker processes) gives the same rows as the in-process
    vmap executor, and a worker process killed mid-study is replaced: the batches it had not
    returned run again, every variant exactly once."""
    import multiprocessing as mp

    st = make_study(pendulum())
    ref = st.run(design="lhs", n=8, seed=11, executor="vmap", workers=1, progress=False)
    killed = []

    def kill_a_worker(rows):
        kids = [p for p in mp.active_children() if p.is_alive()]
        if kids and not killed:
            os.kill(kids[0].pid, signal.SIGKILL)  # a worker process of this study's pool
            killed.append(kids[0].pid)

    tab = st.run(design="lhs", n=8, seed=11, executor="processes", workers=2, batch_size=2, store=tmp_path / "p",
                 progress=False, on_batch=kill_a_worker)
    assert killed, "no worker process was alive when the first batch came back"
    rows = pl.study.Store(tmp_path / "p").read()
    assert len(rows) == 8 and rows["key"].is_unique and (rows["status"] == "success").all()
    got = tab.set_index("key")["x_end"]
    exp = ref.set_index("key")["x_end"]
    assert set(got.index) == set(exp.index)
    assert max(abs(got[k] - exp[k]) for k in exp.index) < 1e-10


def _same_cache_dir(expected):
    import jax

    return {"same": float(jax.config.jax_compilation_cache_dir == expected)}


def test_workers_take_the_drivers_compilation_cache_folder(tmp_path):
    """Dask workers (a WorkerPlugin) and the processes pool (its initializer) use the driver's
    persistent compilation cache folder, so that a shape compiled once is read, not compiled,
    by every other worker and by later batches."""
    import jax
    from distributed import Client, LocalCluster

    from proleg.study.executors import shutdown_pools

    cache = tmp_path / "cache"
    cache.mkdir()
    old = jax.config.jax_compilation_cache_dir
    jax.config.update("jax_compilation_cache_dir", str(cache))
    try:
        st = pl.study.Study.function(lambda x: _same_cache_dir(str(cache)), {"x": [1.0, 2.0]}, ["same"])
        with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, Client(cluster) as client:
            assert list(client.run(lambda: jax.config.jax_compilation_cache_dir).values()) != [str(cache)]  # not before
            tab = st.run(design="grid", executor="dask", scheduler=client, progress=False)
            assert list(client.run(lambda: jax.config.jax_compilation_cache_dir).values()) == [str(cache)]
        assert (tab["same"] == 1.0).all()
        shutdown_pools()  # a fresh pool: its initializer reads the folder now set
        tab = st.run(design="grid", executor="processes", workers=1, progress=False)
        assert (tab["same"] == 1.0).all()
    finally:
        jax.config.update("jax_compilation_cache_dir", old)
        shutdown_pools()
