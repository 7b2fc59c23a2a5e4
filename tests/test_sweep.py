"""vrelab.sweep: the engine, its checkpoint, its backends and the sweep file.

The point functions the tests run live in a small module written to a temporary folder (put on
sys.path and PYTHONPATH, so spawned pool workers, dask workers and `vrelab sweep` subprocesses
import it by name, as they would a user's module).
"""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from concurrent.futures import Future
from pathlib import Path

import numpy as np
import pytest

from test_hardening_folders import _alive, _children
from vrelab.cli import main
from vrelab.sweep import (
    Backend,
    Checkpoint,
    DaskBackend,
    ProcessBackend,
    SerialBackend,
    SerialExecutor,
    SweepAborted,
    load_spec,
    parse_spec,
    run_points,
    run_sweep,
)

pytestmark = pytest.mark.timeout(120)  # a hang in the engine must fail, not stall the suite

POINTS_MODULE = '''
import os, time
from pathlib import Path
import numpy as np

def noisy(params, seed):
    """Random numbers from the point's seed: any seed mix-up between backends shows up."""
    rng = np.random.default_rng(seed)
    x = rng.normal(size=64)
    return {"a": float(params["x"]) * 2.0 + float(x.mean()), "b": float(x.std())}

def slow(params, seed):
    time.sleep(float(params.get("sleep_s", 0.05)))
    return noisy(params, seed)

def gated(params, seed):
    """x < 5 returns at once; x >= 5 waits for the file ``params["gate"]`` (60 s at most), so a
    run killed before the gate opens has finished some points and certainly not all, however fast
    or loaded the machine is."""
    if params["x"] >= 5:
        deadline = time.monotonic() + 60
        while not Path(params["gate"]).exists():
            if time.monotonic() > deadline:
                raise RuntimeError("the gate never opened")
            time.sleep(0.01)
    return noisy(params, seed)

def bad(params, seed):
    """Raises at x == 3; counts its calls in a file per point (to see the retries)."""
    log = params.get("log_dir")
    if log:
        with open(Path(log) / f"calls-{params['x']}-{params['y']}", "a") as fh:
            fh.write("x")
    if params["x"] == 3:
        raise RuntimeError("boom at x=3")
    return noisy(params, seed)

def invalid(params, seed):
    log = params.get("log_dir")
    with open(Path(log) / f"calls-{params['x']}-{params['y']}", "a") as fh:
        fh.write("x")
    if params["x"] == 3:
        raise ValueError("x must not be 3")
    return noisy(params, seed)

def die(params, seed):
    """Kills its worker process at x == 3, as a segfault or an OOM kill would."""
    if params["x"] == 3:
        os._exit(7)
    return noisy(params, seed)
'''


@pytest.fixture(scope="module")
def points_module(tmp_path_factory):
    d = tmp_path_factory.mktemp("sweep_points")
    (d / "sweep_test_points.py").write_text(POINTS_MODULE)
    mp = pytest.MonkeyPatch()
    mp.syspath_prepend(str(d))
    mp.setenv("PYTHONPATH", os.pathsep.join([str(d), os.environ.get("PYTHONPATH", "")]))
    yield d
    mp.undo()


@pytest.fixture(scope="module")
def cluster(points_module):
    """One LocalCluster for the module: it takes about a second to start. A task that kills its
    worker fails at once (dask's default reruns it on 3 more workers, a second or so each)."""
    import dask
    import distributed

    with dask.config.set({"distributed.scheduler.allowed-failures": 0}), distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
    ) as lc, distributed.Client(lc) as client:
        yield client


def _doc(fn="noisy", **over):
    doc = {
        "kind": "python",
        "function": f"sweep_test_points:{fn}",
        "seed": 20161121,
        "grid": {"x": "0:5:1", "y": ["p", "q"]},
    }
    doc.update(over)
    return doc


def _bits(ds):
    return {k: np.ascontiguousarray(v.values).tobytes() for k, v in ds.data_vars.items()}


# --- reproducibility --------------------------------------------------------------------------


def test_same_sweep_is_bitwise_identical_serial_process_pool_and_dask(points_module, cluster, tmp_path):
    import xarray as xr

    spec = parse_spec(_doc(montecarlo={"units": 3, "k": {"dist": "normal", "mean": 0.0, "sd": 1.0}}))
    serial = run_sweep(spec, tmp_path / "serial")
    with ProcessBackend(2) as pool:
        procs = run_sweep(spec, tmp_path / "procs", backend=pool, chunk=5)
    dask = run_sweep(spec, tmp_path / "dask", backend=DaskBackend(client=cluster), chunk=2)
    assert serial.summary["n_ok"] == 36 and serial.dataset.sizes == {"unit": 3, "x": 6, "y": 2}
    for other in (procs, dask):
        xr.testing.assert_identical(serial.dataset, other.dataset)
        assert _bits(serial.dataset) == _bits(other.dataset)
    # and the files say the same thing as the in-memory Dataset
    back = xr.load_dataset(tmp_path / "dask" / "result.nc", engine="h5netcdf")
    assert _bits(back[["a", "b"]]) == _bits(serial.dataset[["a", "b"]])
    assert [s for s in back["status"].values.ravel()] == ["ok"] * 36


def test_analytic_model_lot_is_bitwise_identical_on_every_backend(cluster, tmp_path):
    """The built-in `model` kind over a lot whose fn, Q, k2 and offset are drawn per unit."""
    import xarray as xr

    spec = parse_spec(
        {
            "kind": "model",
            "seed": 3,
            "fixed": {"range_g": 2.0, "f_lo_hz": 50.0, "f_hi_hz": 2000.0},
            "grid": {"rms_g": "0.5:2:0.5", "static_g": [1.0, -1.0]},
            "montecarlo": {
                "units": 4,
                "fn_hz": {"dist": "normal", "mean": 2400.0, "sd": 100.0},
                "q": {"dist": "uniform", "low": 5.0, "high": 9.0},
                "k2_ug_per_g2": {"dist": "normal", "mean": 0.0, "sd": 50.0},
                "offset_g": {"dist": "normal", "mean": 0.0, "sd": 0.025},
            },
        }
    )
    serial = run_sweep(spec, tmp_path / "s").dataset
    with ProcessBackend(2) as pool:
        procs = run_sweep(spec, tmp_path / "p", backend=pool, chunk=3).dataset
    dask = run_sweep(spec, tmp_path / "d", backend=DaskBackend(client=cluster), chunk=7).dataset
    assert (serial["status"] == "ok").all() and dict(serial.sizes) == {"unit": 4, "rms_g": 4, "static_g": 2}
    for other in (procs, dask):
        xr.testing.assert_identical(serial, other)
        assert _bits(serial) == _bits(other)
    # each unit keeps its draws across the grid, and units differ
    assert len(set(serial["fn_hz"].values)) == 4 and serial["offset_g"].dims == ("unit",)


def test_point_seed_is_the_spawned_child_of_the_sweep_seed(points_module):
    """numpy documents SeedSequence(s).spawn(n)[i] == SeedSequence(s, spawn_key=(i,)); the
    sweep uses the first child's children for points and the second's for units."""
    spec = parse_spec(_doc())
    entropy, key = spec.point_seed(7)
    ours = np.random.SeedSequence(entropy, spawn_key=key).generate_state(4)
    spawned = np.random.SeedSequence(20161121).spawn(2)[0].spawn(8)[7].generate_state(4)
    assert np.array_equal(ours, spawned)
    # a unit's draws do not depend on the size of the lot
    mc = {"k": {"dist": "uniform", "low": 1.0, "high": 2.0}, "m": {"dist": "normal", "mean": 5.0, "sd": 0.5}}
    small = parse_spec(_doc(montecarlo={"units": 2, **mc}))
    big = parse_spec(_doc(montecarlo={"units": 50, **mc}))
    assert small.unit_params(1) == big.unit_params(1)
    rng = np.random.default_rng(np.random.SeedSequence(20161121).spawn(2)[1].spawn(2)[1])
    assert big.unit_params(1) == {"k": rng.uniform(1.0, 2.0), "m": rng.normal(5.0, 0.5)}


# --- failures ---------------------------------------------------------------------------------


def test_a_point_that_raises_is_retried_then_recorded_failed_and_the_others_finish(points_module, tmp_path):
    spec = parse_spec(_doc("bad", fixed={"log_dir": str(tmp_path)}))
    with ProcessBackend(2) as pool:
        res = run_sweep(spec, tmp_path / "out", backend=pool, retries=2)
    ds = res.dataset
    failed = ds["status"].values == "failed"
    assert failed.sum() == 2 and (ds["x"].values[np.nonzero(failed)[0]] == 3).all()
    assert (failed == (ds["x"] == 3).broadcast_like(ds["a"]).values).all()
    assert set(ds["error"].values[failed]) == {"RuntimeError: boom at x=3"}
    assert np.isnan(ds["a"].values[failed]).all() and not np.isnan(ds["a"].values[~failed]).any()
    assert (tmp_path / "calls-3.0-p").read_text() == "xxx"  # 1 try + 2 retries
    assert (tmp_path / "calls-2.0-p").read_text() == "x"
    assert [len(p.read_text()) for p in tmp_path.glob("calls-*")].count(1) == 10
    assert {r.attempts for r in res.records.values() if r.status == "failed"} == {3}
    # a rerun keeps the failures (they are finished), unless asked to try them again
    assert run_sweep(spec, tmp_path / "out").summary["n_computed"] == 0
    again = run_sweep(spec, tmp_path / "out", retry_failed=True)
    assert again.summary["n_computed"] == 2 and again.summary["n_resumed"] == 10
    assert (tmp_path / "calls-3.0-p").read_text() == "xxxxx" and (tmp_path / "calls-2.0-p").read_text() == "x"
    # default: one retry
    res1 = run_sweep(parse_spec(_doc("bad")), tmp_path / "out1")
    assert {r.attempts for r in res1.records.values() if r.status == "failed"} == {2}


def test_on_dask_a_raising_point_is_retried_and_recorded(points_module, cluster, tmp_path):
    spec = parse_spec(_doc("bad", fixed={"log_dir": str(tmp_path)}))
    res = run_sweep(spec, tmp_path / "out", backend=DaskBackend(client=cluster))
    failed = {i: r for i, r in res.records.items() if r.status == "failed"}
    assert sorted(failed) == [6, 7] and {r.attempts for r in failed.values()} == {2}
    assert (tmp_path / "calls-3.0-q").read_text() == "xx"  # dask did not hand back the old result


def test_on_dask_a_killed_worker_is_pinned_on_its_point_even_in_a_chunk(points_module, cluster, tmp_path):
    res = run_sweep(parse_spec(_doc("die")), tmp_path / "die", backend=DaskBackend(client=cluster), chunk=3)
    ref = run_sweep(parse_spec(_doc("noisy")), tmp_path / "ref").dataset
    ds = res.dataset
    dead = (ds["x"] == 3).broadcast_like(ds["a"]).values
    assert (ds["status"].values == np.where(dead, "failed", "ok")).all()
    assert all(e.startswith("KilledWorker") for e in ds["error"].values[dead])
    assert {r.attempts for r in res.records.values() if r.status == "failed"} == {2}
    # the chunk-mates of the dying points were rerun alone, not charged
    assert ds["a"].values[~dead].tobytes() == ref["a"].values[~dead].tobytes()


def test_a_worker_that_dies_is_pinned_on_its_point_and_loses_no_other(points_module, tmp_path):
    spec = parse_spec(_doc("die"))
    with ProcessBackend(2) as pool:
        res = run_sweep(spec, tmp_path / "die", backend=pool)
        resets = pool.resets
    ref = run_sweep(parse_spec(_doc("noisy")), tmp_path / "ref").dataset
    ds = res.dataset
    dead = (ds["x"] == 3).broadcast_like(ds["a"]).values
    assert (ds["status"].values[dead] == "failed").all() and (ds["status"].values[~dead] == "ok").all()
    assert all("worker process died" in e for e in ds["error"].values[dead])
    # the neighbours of the crash were rerun, not charged: same bits as a clean run
    assert ds["a"].values[~dead].tobytes() == ref["a"].values[~dead].tobytes()
    assert {r.attempts for r in res.records.values() if r.status == "failed"} == {2}
    assert resets >= 2  # at least one crash per attempt of the dying points


def test_engine_is_generic_over_any_executor_and_callable(points_module):
    """run_points takes a callable and a plain executor backend; records come back by index."""
    import sweep_test_points as P

    items = [(i, {"x": float(i)}, (3, (0, i))) for i in range(5)]
    seen = []
    recs = run_points(P.noisy, items, SerialBackend(), on_records=seen.extend)
    assert sorted(recs) == [0, 1, 2, 3, 4] and len(seen) == 5
    expect = P.noisy({"x": 4.0}, np.random.SeedSequence(3, spawn_key=(0, 4)))
    assert recs[4].values == expect


# --- checkpoint and resume --------------------------------------------------------------------


def _point_lines(path: Path) -> list[dict]:
    out = []
    for line in path.read_text().splitlines():
        obj = json.loads(line)
        if obj["type"] == "point":
            out.append(obj)
    return out


@pytest.mark.timeout(400)
@pytest.mark.parametrize("where", [[], ["--workers", "2"]], ids=["serial", "pool"])
def test_sigkill_midway_then_resume_recomputes_nothing_finished(points_module, tmp_path, where):
    sweep = tmp_path / "slow.toml"
    gate = tmp_path / "gate"
    sweep.write_text(
        textwrap.dedent(
            f"""
            kind = "python"
            function = "sweep_test_points:gated"
            seed = 11
            [fixed]
            gate = "{gate.as_posix()}"
            [grid]
            x = "0:9:1"
            y = ["p", "q"]
            """
        )
    )
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "vrelab", "sweep", str(sweep), "--out", str(out), "--no-progress", "--allow-python",
           *where]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    ck = out / "checkpoint.jsonl"
    # a generous wait, not a speed check: a loaded machine took over 30 s to start the pool
    deadline = time.monotonic() + 150
    while not (ck.exists() and len(_point_lines(ck)) >= 5):
        assert time.monotonic() < deadline, "the sweep finished no 5 points in 150 s"
        time.sleep(0.02)
    workers = _children(proc.pid)
    assert len(workers) >= (2 if where else 0)
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=10)
    proc.stderr.close()
    # pool workers notice their parent is gone and exit, instead of waiting for work forever
    deadline = time.monotonic() + 5
    while any(_alive(w) for w in workers) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(_alive(w) for w in workers)
    first = {p["i"] for p in _point_lines(ck)}
    # at least the 5 waited for, at most the 10 with x < 5: the others wait for the gate, still shut
    assert 5 <= len(first) <= 10
    assert not (out / "result.nc").exists()  # final outputs: complete or absent
    gate.touch()  # the resumed run (and the clean one below) may finish every point

    r = subprocess.run(cmd + ["--json"], capture_output=True, text=True, timeout=200)  # a hang guard, not a speed check
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    assert summary["n_resumed"] == len(first) and summary["n_computed"] == 20 - len(first)
    lines = _point_lines(ck)
    assert len(lines) == 20  # each point evaluated once over both runs
    assert {p["i"] for p in lines if p["run"] == 2}.isdisjoint(first)
    assert {p["i"] for p in lines} == set(range(20))

    import xarray as xr

    clean = run_sweep(load_spec(sweep), tmp_path / "clean").dataset
    resumed = xr.load_dataset(out / "result.nc", engine="h5netcdf")
    xr.testing.assert_identical(clean, resumed)
    assert _bits(clean) == _bits(resumed)


def test_a_torn_last_line_is_dropped_and_a_finished_sweep_reruns_nothing(points_module, tmp_path):
    spec = parse_spec(_doc())
    first = run_sweep(spec, tmp_path)
    ck = tmp_path / "checkpoint.jsonl"
    lines = ck.read_text().splitlines(keepends=True)
    # lose the last two points, and leave half a line, as a kill mid-write would
    ck.write_text("".join(lines[:-2]) + lines[-2][:25])
    again = run_sweep(spec, tmp_path)
    assert again.summary["n_computed"] == 2 and again.summary["n_resumed"] == 10
    assert _bits(again.dataset) == _bits(first.dataset)
    third = run_sweep(spec, tmp_path)
    assert third.summary["n_computed"] == 0


def test_resume_refuses_a_changed_sweep_file_unless_fresh(points_module, tmp_path):
    run_sweep(parse_spec(_doc()), tmp_path)
    changed = parse_spec(_doc(seed=1))
    with pytest.raises(ValueError, match="different sweep"):
        run_sweep(changed, tmp_path)
    assert run_sweep(changed, tmp_path, fresh=True).summary["n_computed"] == 12
    # retries/chunk/outputs do not change the results, so they do not block a resume
    assert run_sweep(parse_spec(_doc(seed=1, chunk=4)), tmp_path).summary["n_computed"] == 0


# --- outputs ----------------------------------------------------------------------------------


def test_cli_writes_netcdf_csv_and_json_that_agree(points_module, tmp_path, capsys):
    import xarray as xr

    f = tmp_path / "s.toml"
    f.write_text(
        'kind = "python"\nfunction = "sweep_test_points:noisy"\nseed = 3\n'
        '[grid]\nx = [1, 2]\n[montecarlo]\nunits = 3\nk = {dist = "lognormal", mean = 0.0, sigma = 0.1}\n'
    )
    assert main(["sweep", str(f), "--out", str(tmp_path / "o"), "--json", "--allow-python"]) == 0
    captured = capsys.readouterr()
    doc = json.loads(captured.out)  # stdout: one JSON object and nothing else
    assert "sweep" in captured.err and "6/6" in captured.err  # the progress bar, on stderr
    ds = xr.load_dataset(tmp_path / "o" / "result.nc", engine="h5netcdf")
    assert dict(ds.sizes) == {"unit": 3, "x": 2} and doc["dims"] == {"unit": 3, "x": 2}
    with open(tmp_path / "o" / "result.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["index"] for r in rows] == [str(i) for i in range(6)]
    flat_a = ds["a"].values.ravel()
    assert [float(r["a"]) for r in rows] == list(flat_a) == [p["a"] for p in doc["points"]]
    assert [float(r["k"]) for r in rows] == list(np.repeat(ds["k"].values, 2))
    assert np.all(ds["k"].values > 0)  # lognormal draws


# --- the sweep file ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "over, field",
    [
        ({"kind": "sim"}, "kind"),
        ({"seed": -1}, "seed"),
        ({"seed": 1.5}, "seed"),
        ({"retries": -1}, "retries"),
        ({"chunk": 0}, "chunk"),
        ({"grid": {"x": []}}, "grid.x"),
        ({"grid": {"x": "0:1:0"}}, "grid.x"),
        ({"grid": {"x": [1, 1]}}, "grid.x"),
        ({"grid": {"x": [1, "a"]}}, "grid.x"),
        ({"grid": {}}, "grid"),
        ({"function": "nomodule"}, "function"),
        ({"colour": "red"}, "colour"),
        ({"seconds": 2.0}, "seconds"),
        ({"montecarlo": {"k": {"dist": "normal", "mean": 0, "sd": 1}}}, "montecarlo.units"),
        ({"montecarlo": {"units": 0, "k": {"dist": "normal", "mean": 0, "sd": 1}}}, "montecarlo.units"),
        ({"montecarlo": {"units": 2, "k": {"dist": "cauchy"}}}, "montecarlo.k.dist"),
        ({"montecarlo": {"units": 2, "k": {"dist": "normal", "mean": 0}}}, "montecarlo.k.sd"),
        ({"montecarlo": {"units": 2, "k": {"dist": "normal", "mean": 0, "sd": -1}}}, "montecarlo.k.sd"),
        ({"montecarlo": {"units": 2, "k": {"dist": "uniform", "low": 2, "high": 1}}}, "montecarlo.k"),
        ({"output": {"formats": ["xlsx"]}}, "output.formats"),
        ({"output": {"variables": "a"}}, "output.variables"),
    ],
)
def test_each_bad_field_is_a_value_error_that_names_it(over, field):
    with pytest.raises(ValueError, match=rf"^{field.replace('.', '[.]')}\b|\b{field.replace('.', '[.]')}\b"):
        parse_spec(_doc(**over))


@pytest.mark.parametrize(
    "doc, field",
    [
        ({"kind": "model", "grid": {"rms_g": [1.0]}, "fixed": {"colour": 1}}, "fixed.colour"),
        ({"kind": "model", "grid": {"rms_g": [-1.0]}}, "grid.rms_g"),
        ({"kind": "model", "grid": {"shape": ["square"]}, "fixed": {"rms_g": 1.0}}, "grid.shape"),
        ({"kind": "model", "grid": {"static_g": [1.0]}}, "rms_g"),
        ({"kind": "model", "grid": {"rms_g": "0.5:1:0.5"}, "fixed": {"range_g": "2"}}, "fixed.range_g"),
        ({"kind": "predict", "fixed": {"profile": "flat:50-2000"}, "grid": {"rms_g": [1.0], "axis": ["w"]}},
         "grid.axis"),  # an axis the (default) sensor does not have
        ({"kind": "simulate", "seconds": 0, "grid": {"rms_g": [1.0]}}, "seconds"),
    ],
)
def test_point_kinds_check_their_parameters(doc, field):
    with pytest.raises(ValueError, match=field.replace(".", "[.]")):
        parse_spec(doc)


def test_cli_bad_file_is_one_line_and_exit_2(tmp_path, capsys):
    f = tmp_path / "bad.toml"
    f.write_text('kind = "model"\n[grid]\nrms_g = [0.5, -1]\n')
    assert main(["sweep", str(f), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "grid.rms_g" in err
    f.write_text("kind = \n")
    assert main(["sweep", str(f)]) == 2
    assert "not valid TOML" in capsys.readouterr().err
    assert main(["sweep", str(tmp_path / "missing.toml")]) == 2
    assert main(["sweep", str(f), "--workers", "2", "--scheduler", "local"]) == 2
    f.write_text('kind = "model"\n[grid]\nrms_g = [0.5]\n')
    assert main(["sweep", str(f), "--workers", "0", "--out", str(tmp_path / "o")]) == 2
    assert main(["sweep", str(f), "--retries", "-1", "--out", str(tmp_path / "o")]) == 2
    assert main(["sweep", str(f), "--scheduler", "local:x", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "--workers" in err and "retries" in err and "local:N" in err
    assert not (tmp_path / "o").exists()


def test_missing_dask_extra_is_a_one_line_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # what an uninstalled package looks like
    with pytest.raises(ValueError, match=r"pip install 'vrelab\[dask\]'"):
        DaskBackend("local")


def test_a_value_error_is_bad_input_and_is_not_retried(points_module, tmp_path):
    res = run_sweep(parse_spec(_doc("invalid", fixed={"log_dir": str(tmp_path)})), tmp_path / "o", retries=3)
    failed = [r for r in res.records.values() if r.status == "failed"]
    assert len(failed) == 2 and {r.attempts for r in failed} == {1}
    assert failed[0].error == "ValueError: x must not be 3"
    assert (tmp_path / "calls-3.0-p").read_text() == "x"


def test_zarr_without_the_package_fails_before_any_point(points_module, monkeypatch, tmp_path):
    monkeypatch.setitem(sys.modules, "zarr", None)
    with pytest.raises(ValueError, match="zarr"):
        run_sweep(parse_spec(_doc(output={"formats": ["netcdf", "zarr"]})), tmp_path)
    assert not (tmp_path / "result.nc").exists()


def test_the_example_in_the_help_is_a_valid_sweep_file():
    import tomllib

    from vrelab.cli.sweep import _EXAMPLE

    body = textwrap.dedent(_EXAMPLE.split("\n", 2)[2])
    spec = parse_spec(tomllib.loads(body))
    assert spec.dims == ("unit", "rms_g", "range_g", "odr_hz", "static_g")
    assert spec.shape == (20, 6, 3, 3, 2)


class _DisconnectingExecutor(SerialExecutor):
    """Runs `good` tasks, then behaves like a client that lost its scheduler."""

    def __init__(self, good):
        self.good = good

    def submit(self, fn, /, *args, **kwargs):
        if self.good > 0:
            self.good -= 1
            return super().submit(fn, *args, **kwargs)
        fut = Future()
        fut.cancel()
        fut.set_running_or_notify_cancel()  # what an executor does with a cancelled task
        return fut


def test_a_lost_executor_stops_the_sweep_without_marking_points_failed(points_module, tmp_path):
    spec = parse_spec(_doc())
    with pytest.raises(SweepAborted, match="rerun to resume"):
        run_sweep(spec, tmp_path, backend=Backend(_DisconnectingExecutor(3)))
    lines = _point_lines(tmp_path / "checkpoint.jsonl")
    assert sorted(p["i"] for p in lines) == [0, 1, 2] and {p["status"] for p in lines} == {"ok"}
    res = run_sweep(spec, tmp_path)
    assert res.summary["n_computed"] == 9 and res.summary["n_ok"] == 12


def test_two_runs_cannot_share_a_checkpoint(points_module, tmp_path):
    spec = parse_spec(_doc())
    with Checkpoint(tmp_path, spec.fingerprint(), spec.n_points, spec.point_key):
        with pytest.raises(ValueError, match="another sweep is running"):
            run_sweep(spec, tmp_path)


def test_reserved_and_clashing_names_are_refused(points_module, tmp_path):
    with pytest.raises(ValueError, match=r"grid\.status"):
        parse_spec(_doc(grid={"status": [1, 2]}))
    with pytest.raises(ValueError, match=r"grid\.unit"):
        parse_spec(_doc(grid={"unit": [1, 2]}))
    # a point function returning a value named like an axis: caught, and fixable by resuming
    # with output.variables (which does not change the fingerprint: nothing is recomputed)
    doc = _doc(grid={"a": [1.0, 2.0], "x": [0.0]})
    with pytest.raises(ValueError, match="output variable 'a'"):
        run_sweep(parse_spec(doc), tmp_path)
    res = run_sweep(parse_spec({**doc, "output": {"variables": ["b"]}}), tmp_path)
    assert res.summary["n_computed"] == 0 and list(res.dataset.data_vars) == ["b", "status", "error"]
