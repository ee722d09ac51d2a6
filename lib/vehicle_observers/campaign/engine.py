"""Run a campaign: serially or on Dask distributed, resumable, every batch saved at once.

    run(spec, out_dir, scheduler=None, engine="dask", workers=None, progress=None,
        plugins=(), recompute=False)

``engine="dask"`` without ``scheduler`` starts an embedded ``LocalCluster`` on 127.0.0.1 with
one single-threaded worker *process* per core (``processes=True, threads_per_worker=1``;
``workers`` overrides the count), the thread counts of BLAS/OpenMP, Rayon (Clarabel) and
numba pinned to 1 in each worker's environment before it starts
(:data:`vehicle_observers.campaign.tasks.THREAD_ENV`). ``scheduler="tcp://HOST:PORT"`` runs the
same campaign on an existing cluster (``dask scheduler`` / ``dask worker``, or
dask-jobqueue's ``SLURMCluster``; README); workers whose environment lacks the pins get
them through distributed's ``Environ`` nanny plug-in, which restarts them once. Every worker
warms the numba cache once (:class:`~vehicle_observers.campaign.workers.CampaignPlugin`).
``engine="serial"`` runs the same batches in this process, in order.

Truths (the noise-free drives) are Dask tasks of their own, computed once and passed to the
batches that need them. Each finished batch is written at once by this process
(:mod:`vehicle_observers.campaign.store`); a re-run into the same folder skips the batches
present. The rows do not depend on the engine, the number of workers, the order of
completion or on a worker lost mid-run (its batches are recomputed): every random draw is
keyed by the task (:func:`~vehicle_observers.campaign.spec.seed_sequence`).

The folder records the provenance of its results (:mod:`vehicle_observers.campaign.provenance`:
package version, source hash of every estimator's module and plug-in): a resume with other
code is refused with one line naming what changed, or with ``recompute=True`` (``campaign
--recompute``) the batches holding the affected estimators are deleted and run again; old
and new rows are never mixed.
"""

from __future__ import annotations

import logging
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from vehicle_observers.campaign import lmi_map, provenance, store, tasks
from vehicle_observers.campaign.spec import SpecError, load_spec

ENGINES = ("dask", "serial")
#: Dask configuration of the embedded cluster: no statistical profiler in the workers (it
#: samples every thread's stack every 10 ms: CPU taken from the simulations), and two tasks
#: queued per worker thread (the next batch is there when one finishes: no round trip to the
#: scheduler between batches; idle workers still steal). A cluster started by hand gets the
#: same with ``DASK_DISTRIBUTED__WORKER__PROFILE__ENABLED=False`` (workers) and
#: ``DASK_DISTRIBUTED__SCHEDULER__WORKER_SATURATION=2`` (scheduler).
WORKER_CONFIG = {"distributed.worker.profile.enabled": False,
                 "distributed.scheduler.worker-saturation": 2.0}


class CampaignError(RuntimeError):
    """The campaign machinery failed (not a task: failing tasks are recorded as rows)."""


class CampaignStopped(SpecError):
    """The campaign stopped before its end (a signal, a full disk): the one-line message
    says how many batches are kept and that the same command resumes. ``signum``: the
    signal, or ``None``."""

    def __init__(self, message, signum=None):
        super().__init__(message)
        self.signum = signum


def batch_provenance(spec) -> dict:
    """What produced a batch file, stored in its metadata (:func:`store.batch_meta`): the
    package version and the spec's plug-in modules."""
    import vehicle_observers

    return {"package_version": vehicle_observers.__version__, "plugins": list(spec.plugins)}


class _Signals:
    """SIGINT / SIGTERM during a run raise :class:`CampaignStopped` in the main thread, so
    the cluster is closed (its worker processes and semaphores released) and the batches
    written are counted; a second signal while closing ends the process at once."""

    NAMES = ("SIGINT", "SIGTERM", "SIGHUP")

    def __init__(self):
        self.prev, self.hit = {}, None

    def __enter__(self):
        import signal
        import threading

        if threading.current_thread() is not threading.main_thread():
            return self
        for n in self.NAMES:
            sig = getattr(signal, n, None)
            if sig is not None:
                self.prev[sig] = signal.signal(sig, self._handle)
        return self

    def _handle(self, signum, frame):
        if self.hit is not None:
            os._exit(128 + signum)
        self.hit = signum
        raise CampaignStopped("", signum)

    def __exit__(self, *exc):
        import signal

        for sig, h in self.prev.items():
            signal.signal(sig, h)
        return False


@dataclass
class CampaignSummary:
    """What :func:`run` did. ``tasks``: simulations of the plan; ``done_before``: already in
    the folder; ``run_now``: computed by this call; ``failed``: rows with ``ok = False`` in the
    folder; ``lmi_*`` likewise for the LMI map; ``seconds``: wall time of this call."""

    out: Path
    spec_sha256: str
    tasks: int
    batches: int
    done_before: int
    run_now: int
    failed: int
    lmi_points: int
    lmi_done_before: int
    lmi_run_now: int
    seconds: float
    engine: str
    workers: int
    failures: dict = field(default_factory=dict)

    def line(self) -> str:
        txt = (f"{self.run_now} simulation(s) run now, {self.done_before} already done, "
               f"{self.tasks} in the plan ({self.batches} batches); {self.failed} failed")
        if self.lmi_points:
            txt += (f"; LMI map {self.lmi_run_now} point(s) now, {self.lmi_done_before} "
                    f"before, {self.lmi_points} in all")
        return txt + f"; {self.engine}, {self.workers} worker(s), {self.seconds:.1f} s -> {self.out}"


def run(spec, out_dir, scheduler: str | None = None, engine: str = "dask",
        workers: int | None = None, progress: bool | None = None, plugins=(),
        recompute: bool = False) -> CampaignSummary:
    """Run (or resume) the campaign ``spec`` (path, TOML text, dict or
    :class:`~vehicle_observers.campaign.spec.Spec`) into ``out_dir`` (module docstring).
    ``progress``: a tqdm bar on stderr (default: when stderr is a terminal); ``plugins``:
    module names or ``.py`` paths added to the spec's ``plugins`` (loaded here and on every
    worker); ``recompute``: run again the batches whose code changed (else refused). Raises
    :class:`~vehicle_observers.campaign.spec.SpecError` before anything runs when the spec,
    the engine options, the folder or its code provenance are wrong."""
    t_start = time.perf_counter()
    spec = _with_plugins(spec, plugins)
    if engine not in ENGINES:
        raise SpecError(f"engine must be one of {', '.join(ENGINES)}, got {engine!r}")
    if scheduler is not None and engine != "dask":
        raise SpecError("a scheduler address needs engine=\"dask\"")
    if workers is not None and (int(workers) != workers or workers < 1):
        raise SpecError(f"workers must be an integer >= 1, got {workers!r}")
    if scheduler is not None and workers is not None:
        raise SpecError("workers is the size of the embedded cluster; with a scheduler "
                        "address the cluster's own workers run")
    out = Path(out_dir)
    store.prepare(out, spec)
    check_provenance(out, spec, recompute)
    done = store.done_batches(out, "results", spec)
    ldone = store.done_batches(out, "lmi", spec)
    pending = [b for b in spec.batches() if b[0] not in done]
    lpending = [b for b in spec.lmi_batches() if b[0] not in ldone]
    n_before = sum(b - a for k, a, b in spec.batches() if k in done)
    l_before = sum(b - a for k, a, b in spec.lmi_batches() if k in ldone)
    show = sys.stderr.isatty() if progress is None else bool(progress)
    from tqdm import tqdm

    total = spec.n_tasks + len(spec.lmi_points)
    bar = tqdm(total=total, initial=n_before + l_before, unit="sim", file=sys.stderr,
               disable=not show, desc=spec.doc["name"], smoothing=0.05)
    rschema, lschema = tasks.result_schema(), lmi_map.schema()
    ranges = {("results", k): (a, b) for k, a, b in pending}
    ranges.update({("lmi", k): (a, b) for k, a, b in lpending})
    prov = batch_provenance(spec)
    written = []

    def save(kind, bid, cols):
        a, b = ranges[(kind, bid)]
        try:
            store.write_batch(out, kind, bid, cols, rschema if kind == "results" else lschema,
                              store.batch_meta(spec, kind, bid, a, b, prov))
        except OSError as exc:
            raise CampaignStopped(f"{out}: cannot write {kind} batch {bid} "
                                  f"({store.write_reason(exc)})") from None
        written.append(bid)
        bar.update(len(cols["batch"]))

    n_workers = 1
    try:
        with _Signals():
            if engine == "serial":
                if pending:
                    tasks.warm_up(spec.plugins)
                for bid, a, b in pending:
                    save("results", bid, tasks.run_batch(spec.raw, bid, a, b))
                for bid, a, b in lpending:
                    save("lmi", bid, lmi_map.run_lmi_batch(spec.raw, bid, a, b))
            elif pending or lpending:
                n_workers = _run_dask(spec, pending, lpending, save, scheduler, workers)
    except CampaignStopped as exc:
        import signal

        kept = len(store.done_batches(out, "results")) + len(store.done_batches(out, "lmi"))
        why = (f"interrupted by {signal.Signals(exc.signum).name}" if exc.signum is not None
               else str(exc))
        raise CampaignStopped(f"{why}; {kept} of {len(spec.batches()) + len(spec.lmi_batches())} "
                              f"batch(es) kept in {out} ({len(written)} written by this run); "
                              "the same command resumes", exc.signum) from None
    finally:
        bar.close()
    import pyarrow.compute as pc

    res = store.read_results(out, ["ok", "estimator"], spec)
    failed = int(len(res) - pc.sum(res["ok"]).as_py()) if len(res) else 0
    fails = {}
    if failed:
        bad = res.filter(pc.invert(res["ok"]))
        for e in bad["estimator"].to_pylist():
            fails[e] = fails.get(e, 0) + 1
    return CampaignSummary(out, spec.sha256, spec.n_tasks, len(spec.batches()), n_before,
                           sum(b - a for _, a, b in pending), failed, len(spec.lmi_points),
                           l_before, sum(b - a for _, a, b in lpending),
                           time.perf_counter() - t_start, engine, n_workers, fails)


def _with_plugins(spec, plugins):
    """The spec with ``plugins`` (``.py`` paths made absolute) added to its ``plugins`` key;
    they are loaded first, so that the spec may name their estimators."""
    from vehicle_observers.core.errors import RegistryError
    from vehicle_observers.estimation import registry

    refs = [str(Path(p).resolve()) if str(p).endswith(".py") else str(p) for p in plugins]
    if not refs:
        return load_spec(spec)
    try:
        registry.load_plugins(refs)
    except RegistryError as exc:
        raise SpecError(f"--plugin: {exc}") from None
    s = load_spec(spec)
    doc = dict(s.raw)
    doc["plugins"] = list(dict.fromkeys([*doc.get("plugins", []), *refs]))
    from vehicle_observers.campaign.spec import Spec

    return Spec(doc, s.source)


def spec_provenance(spec) -> dict:
    """:func:`~vehicle_observers.campaign.provenance.code_provenance` of the estimators,
    options and plug-ins of ``spec``."""
    from vehicle_observers.campaign.provenance import code_provenance

    avail = tasks.estimators_of(spec.plugins)
    labels = list(dict.fromkeys(p[0] for p in spec.pairs))
    names = {spec.estimator_of(lab)[0] for lab in labels}
    return code_provenance({n: avail[n] for n in sorted(names)},
                           {lab: spec.estimator_of(lab)[1] for lab in labels}, spec.plugins)


def check_provenance(out: Path, spec, recompute: bool = False):
    """Compare the folder's recorded provenance with this code's; refuse a difference (one
    line naming it) unless ``recompute``, which deletes the result batches of the affected
    estimators (all of them when the package version, a plug-in or the options changed).
    A folder with results and no record is treated as of unknown code. Then record this
    code's provenance."""
    new = spec_provenance(spec)
    old = provenance.read(out)
    done = store.done_batches(out, "results")
    if done and old != new:
        what = provenance.changes(old, new) if old else ["no provenance recorded"]
        if what:
            if not recompute:
                raise SpecError(f"{out}: its results were computed by other code "
                                f"({'; '.join(what)}): use another folder, or --recompute "
                                "to run the affected batches again")
            aff = provenance.affected_estimators(old, new) if old else None
            for bid, a, b in spec.batches():
                if bid in done and (aff is None or any(
                        spec.estimator_of(spec.task(i).estimator)[0] in aff
                        for i in range(a, b))):
                    store.batch_path(out, "results", bid).unlink(missing_ok=True)
    provenance.write(out, new)


def local_cluster(workers: int | None = None):
    """The embedded cluster: ``workers`` (default: cores) single-threaded worker processes on
    127.0.0.1, thread pins in their environment, no dashboard, :data:`WORKER_CONFIG`."""
    import dask
    from distributed import LocalCluster

    n = int(workers or os.cpu_count() or 1)
    with dask.config.set(WORKER_CONFIG):
        return LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                            host="127.0.0.1", dashboard_address=None,
                            # the scheduler's HTTP routes on a free port of 127.0.0.1: the
                            # default 8787 warns on stderr when another cluster holds it
                            scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                            silence_logs=logging.ERROR, env=dict(tasks.THREAD_ENV))


def prepare_client(client, plugins=()):
    """Pin the threads of every worker (restarting those started without the pins, through
    their nanny) and register :class:`~vehicle_observers.campaign.workers.CampaignPlugin`."""
    from distributed.diagnostics.plugin import Environ

    from vehicle_observers.campaign.workers import CampaignPlugin, thread_env

    envs = client.run(thread_env)
    if any(any(v != tasks.THREAD_ENV[k] for k, v in e.items()) for e in envs.values()):
        try:
            client.register_plugin(Environ(tasks.THREAD_ENV))
        except Exception:  # noqa: BLE001 - workers without a nanny: pinned by the plug-in only
            pass
    client.register_plugin(CampaignPlugin(plugins))


def _run_dask(spec, pending, lpending, save, scheduler, workers) -> int:
    from distributed import Client, as_completed

    for name in ("distributed", "distributed.worker", "distributed.scheduler",
                 "distributed.nanny", "distributed.core", "distributed.client"):
        logging.getLogger(name).setLevel(logging.ERROR)
    cluster = None
    try:
        if scheduler is None:
            cluster = local_cluster(workers)
            client = Client(cluster, set_as_default=False)
        else:
            try:
                client = Client(scheduler, set_as_default=False, timeout=30)
            except OSError as exc:
                raise SpecError(f"--scheduler {scheduler}: cannot connect ({exc})") from None
        try:
            prepare_client(client, spec.plugins)
            n_workers = len(client.scheduler_info()["workers"])
            tag = spec.sha256[:16]
            tfut, futs = {}, {}
            for bid, a, b in pending:       # streamed: each batch is submitted at once
                tr = []
                for args in tasks.truths_of_batch(spec, a, b):
                    if args not in tfut:
                        tfut[args] = client.submit(tasks.make_truth, args,
                                                   key=f"vo-truth-{tag}-{len(tfut)}", pure=False)
                    tr.append(tfut[args])
                f = client.submit(tasks.run_batch, spec.raw, bid, a, b, tr,
                                  key=f"vo-batch-{tag}-{bid}", pure=False)
                futs[f.key] = ("results", bid, f)
            for bid, a, b in lpending:
                f = client.submit(lmi_map.run_lmi_batch, spec.raw, bid, a, b,
                                  key=f"vo-lmi-{tag}-{bid}", pure=False)
                futs[f.key] = ("lmi", bid, f)
            for f in as_completed([v[2] for v in futs.values()], loop=client.loop):
                kind, bid, _ = futs.pop(f.key)
                if f.status != "finished":
                    exc = f.exception()
                    for _, _, g in futs.values():
                        g.cancel()
                    msg = str(exc).splitlines()[0] if str(exc) else ""
                    raise CampaignError(f"{kind} batch {bid} failed on the cluster: "
                                        f"{type(exc).__name__}: {msg}")
                save(kind, bid, f.result())
                f.release()
            return n_workers
        finally:
            client.close()
    finally:
        if cluster is not None:
            cluster.close()
