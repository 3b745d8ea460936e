"""The campaign driver: plans the cases (the Rust crate `fusion-campaign`), hands the
unfinished ones to Dask, writes each result as it arrives, and resumes where a previous run
stopped.

Engine: Dask's distributed scheduler — a local cluster of worker processes (each restarted by
its nanny if it dies), an existing scheduler, or Slurm through dask-jobqueue. A worker that
dies in the middle of a case makes the scheduler run the case again elsewhere; a case that has
killed ``allowed_failures`` workers is given up (``KilledWorker``) and recorded as failed with
its reason; a case whose code raises is recorded as failed with the error. Either way the
campaign goes on, and each case is recorded exactly once: the driver alone writes, one result
per case future.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional

from .. import _vistir
from .store import CampaignError, Store
from .worker import run_case

#: The code that produced a campaign's results: the package version and its commit.
CODE_VERSION: str = _vistir._code_version


@dataclass
class Plan:
    """A campaign file's plan: its name, fingerprint and cases (dicts, as the Rust crate's)."""

    name: str
    fingerprint: str
    cases: List[Dict]
    text: str
    table: str

    @property
    def ids(self) -> List[str]:
        return [c["id"] for c in self.cases]


def plan(file) -> Plan:
    """Reads and plans a campaign file (the same cases and ids as `fusion campaign plan`)."""
    p = json.loads(_vistir._campaign_plan(str(file)))
    return Plan(p["name"], p["fingerprint"], p["cases"], Path(file).read_text(), p["table"])


@dataclass
class RunSummary:
    """What a run did."""

    planned: int
    already: int
    done: int
    failed: int
    seconds: float
    results: Optional[Path]
    failures: Dict[str, str] = field(default_factory=dict)


def _reason(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _check_state(store: Store, p: Plan, allow_changed: bool) -> None:
    state = store.state()
    want = {"name": p.name, "fingerprint": p.fingerprint, "code_version": CODE_VERSION, "cases": len(p.cases)}
    if state is not None and not allow_changed:
        if state.get("fingerprint") != p.fingerprint:
            raise CampaignError(
                f"{store.out}: holds campaign '{state.get('name')}' (plan {state.get('fingerprint')}), "
                f"the file plans {p.fingerprint}: another folder, or --allow-changed to go on with it"
            )
        if state.get("code_version") != CODE_VERSION:
            raise CampaignError(
                f"{store.out}: its results come from code {state.get('code_version')}, this is {CODE_VERSION}: "
                "another folder, or --allow-changed to mix them"
            )
    if state != want:
        store.write_state(want, p.text)


class _Progress:
    """A progress bar (tqdm) of cases done and failed, with rate and time left."""

    def __init__(self, total: int, initial: int, name: str, show: bool):
        self.bar = None
        if show:
            from tqdm import tqdm

            self.bar = tqdm(total=total, initial=initial, desc=name, unit="case", dynamic_ncols=True)
        self.failed = 0

    def step(self, failed: bool) -> None:
        self.failed += failed
        if self.bar is not None:
            self.bar.set_postfix(failed=self.failed, refresh=False)
            self.bar.update(1)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _client(local, scheduler, scheduler_file, slurm, cluster, threads_per_case):
    """The Dask client and what to close afterwards, and the threads each case may use."""
    from dask.distributed import Client, LocalCluster

    if cluster is not None:
        return Client(cluster), [], threads_per_case or 1
    if scheduler is not None:
        return Client(scheduler), [], threads_per_case or 1
    if scheduler_file is not None:
        return Client(scheduler_file=str(scheduler_file)), [], threads_per_case or 1
    if slurm is not None:
        from dask_jobqueue import SLURMCluster

        slurm = dict(slurm)
        jobs = slurm.pop("jobs", 1)
        c = SLURMCluster(**slurm)
        c.scale(jobs=jobs)
        return Client(c), [c], threads_per_case or slurm.get("cores", 1)
    n = local or max(1, (os.cpu_count() or 1))
    threads = threads_per_case or max(1, (os.cpu_count() or 1) // n)
    c = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None)
    return Client(c), [c], threads


def run(
    file,
    out,
    *,
    local: Optional[int] = None,
    scheduler: Optional[str] = None,
    scheduler_file: Optional[str] = None,
    slurm: Optional[Dict] = None,
    cluster=None,
    serial: bool = False,
    allow_changed: bool = False,
    retry_failed: bool = False,
    threads_per_case: Optional[int] = None,
    allowed_failures: int = 3,
    scratch: Optional[str] = None,
    progress: bool = True,
) -> RunSummary:
    """Runs a campaign file into the folder `out`, resuming what is finished there.

    Engines: `local=N` worker processes on this machine (default: one per core), `scheduler`
    (a Dask scheduler's address) or `scheduler_file` (the file `dask scheduler
    --scheduler-file` writes), `slurm` (keyword arguments of dask_jobqueue.SLURMCluster,
    plus `jobs`), `cluster` (any Dask cluster object), or `serial=True` (in this process, no
    Dask: the reference a distributed run must equal). `allowed_failures`: how many workers a
    case may kill before it is recorded as failed (set on the clusters started here; an
    existing scheduler applies its own `distributed.scheduler.allowed-failures`). Returns what the run did; the merged table
    is written once every planned case is finished."""
    start = time.monotonic()
    p = plan(file)
    out = Path(out)
    with Store(out) as store:
        _check_state(store, p, allow_changed)
        records = store.records()
        planned = set(p.ids)

        def is_finished(cid: str, r: Dict) -> bool:
            if cid not in planned:
                return False
            if r["status"] == "done":
                return store.case_path(cid).exists()
            return not retry_failed

        finished = {cid for cid, r in records.items() if is_finished(cid, r)}
        todo = [c for c in p.cases if c["id"] not in finished]
        bar = _Progress(len(p.cases), len(finished), p.name, progress)
        done = failed = 0
        failures: Dict[str, str] = {}

        def record(case: Dict, result=None, exc: Optional[BaseException] = None) -> None:
            nonlocal done, failed
            if exc is None:
                table, seconds = result
                store.write_case(case["id"], table)
                store.append({"case": case["id"], "status": "done", "rows": table.num_rows, "seconds": round(seconds, 3)})
                done += 1
            else:
                reason = _reason(exc)
                store.append({"case": case["id"], "status": "failed", "reason": reason})
                failures[case["id"]] = reason
                failed += 1
            bar.step(exc is not None)

        try:
            if serial or not todo:
                for case in todo:
                    try:
                        result = run_case(case, scratch, threads_per_case or 0)
                    except Exception as e:  # a case's error is its result, the campaign goes on
                        record(case, exc=e)
                    else:
                        record(case, result)
            else:
                import dask
                from dask.distributed import as_completed

                with dask.config.set({"distributed.scheduler.allowed-failures": allowed_failures}):
                    client, closers, threads = _client(local, scheduler, scheduler_file, slurm, cluster, threads_per_case)
                    try:
                        token = os.urandom(4).hex()
                        futures = {}
                        for case in todo:
                            # `scratch` None: each worker's own temporary folder (one on another machine,
                            # a scheduler's or a Slurm job's, has its own).
                            f = client.submit(run_case, case, scratch, threads, key=f"case-{case['id']}-{token}", retries=0)
                            futures[f] = case
                        for f in as_completed(list(futures)):
                            case = futures.pop(f)
                            try:
                                result = f.result()
                            except Exception as e:  # KilledWorker, or the case's own error
                                record(case, exc=e)
                            else:
                                record(case, result)
                            f.release()
                    finally:
                        client.close()
                        for c in closers:
                            c.close()
        finally:
            bar.close()
        records = store.records()
        complete = all(cid in records for cid in p.ids)
        ok = [cid for cid in p.ids if records.get(cid, {}).get("status") == "done"]
        results = store.merge(ok) if complete and ok else None
        for cid, r in records.items():
            if r["status"] == "failed" and cid in planned:
                failures.setdefault(cid, r.get("reason", ""))
    return RunSummary(len(p.cases), len(finished), done, failed, time.monotonic() - start, results, failures)
