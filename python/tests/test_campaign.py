"""Campaigns on a real local Dask cluster (3 worker processes): every planned case recorded
exactly once, the merged table bit-identical to a serial run of the same file, through a worker
killed in the middle of a case, a case that always kills its worker, the driver killed and
restarted; a hand-started scheduler and its workers; Slurm jobs (where a Slurm runs: CI starts
one); changed files and code refused; the report.

Needs ``pip install './python[campaign]'``.
"""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from vistir import campaign
from vistir.campaign.report import bootstrap_mean

REPO = Path(__file__).resolve().parents[2]
FUSION = Path(os.environ.get("FUSION_BIN", REPO / "target" / "release" / "fusion"))
WORKERS = 3

CAMPAIGN = """
name = "faults"
seed = 5
replicas = 3
frames = {frames}
vis_size = 96
sources = ["vis", "adaptive"]

[axes]
trajectory = ["flyaround"]
sun_phase = [30, 150]
"""


def write_campaign(path: Path, frames: int = 8, replicas: int = 3) -> Path:
    path.write_text(CAMPAIGN.format(frames=frames).replace("replicas = 3", f"replicas = {replicas}"))
    return path


def manifest(out: Path):
    return [json.loads(line) for line in (out / "manifest.jsonl").read_text().splitlines()]


def assert_once_each(out: Path, ids, status="done"):
    recs = manifest(out)
    assert sorted(r["case"] for r in recs) == sorted(ids), "one record per planned case"
    assert all(r["status"] == status for r in recs)
    assert sorted(p.stem for p in (out / "cases").glob("*.parquet")) == sorted(ids)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The campaign run serially, in this process (no Dask)."""
    d = tmp_path_factory.mktemp("serial")
    f = write_campaign(d / "c.toml")
    s = campaign.run(f, d / "out", serial=True, progress=False)
    assert s.done == 6 and s.failed == 0
    return f, pq.read_table(d / "out" / "results.parquet")


def test_a_local_cluster_gives_the_serial_table(reference, tmp_path):
    f, table = reference
    plan = campaign.plan(f)
    s = campaign.run(f, tmp_path / "out", local=WORKERS, progress=False)
    assert (s.planned, s.already, s.done, s.failed) == (6, 0, 6, 0)
    assert_once_each(tmp_path / "out", plan.ids)
    merged = pq.read_table(tmp_path / "out" / "results.parquet")
    assert merged.equals(table)
    # One row per case, stream (and baselines) and phase its frames fall in, in plan order.
    rows = merged.to_pylist()
    assert merged.num_rows == sum(r["rows"] for r in manifest(tmp_path / "out"))
    assert list(dict.fromkeys(r["case_id"] for r in rows)) == plan.ids
    for cid in plan.ids:
        whole = sorted(r["source"] for r in rows if r["case_id"] == cid and r["phase"] == "all")
        assert whole == ["adaptive", "oracle", "vis", "zero-motion"]
    # A rerun finds everything finished and runs nothing.
    again = campaign.run(f, tmp_path / "out", local=WORKERS, progress=False)
    assert (again.already, again.done, again.failed) == (6, 0, 0)
    assert len(manifest(tmp_path / "out")) == 6


def test_a_worker_killed_in_the_middle_of_a_case_loses_nothing(reference, tmp_path, monkeypatch):
    f, table = reference
    plan = campaign.plan(f)
    victim = plan.ids[2]
    monkeypatch.setenv("VISTIR_CAMPAIGN_FAULT", f"kill-once:{victim}")
    scratch = tmp_path / "scratch"
    s = campaign.run(f, tmp_path / "out", local=WORKERS, scratch=str(scratch), progress=False)
    assert (scratch / f"fault-{victim}").exists(), "the worker running the case was killed"
    assert (s.done, s.failed) == (6, 0)
    assert_once_each(tmp_path / "out", plan.ids)
    assert pq.read_table(tmp_path / "out" / "results.parquet").equals(table)


def test_a_case_that_always_kills_its_worker_is_recorded_as_failed(reference, tmp_path, monkeypatch):
    f, table = reference
    plan = campaign.plan(f)
    victim = plan.ids[4]
    monkeypatch.setenv("VISTIR_CAMPAIGN_FAULT", f"kill:{victim}")
    out = tmp_path / "out"
    s = campaign.run(f, out, local=WORKERS, allowed_failures=1, progress=False)
    assert (s.done, s.failed) == (5, 1)
    assert list(s.failures) == [victim] and "KilledWorker" in s.failures[victim]
    recs = {r["case"]: r for r in manifest(out)}
    assert len(manifest(out)) == 6 and recs[victim]["status"] == "failed"
    assert "KilledWorker" in recs[victim]["reason"]
    # The campaign finished: the merged table holds the other five cases.
    merged = pq.read_table(out / "results.parquet")
    assert sorted(set(merged.column("case_id").to_pylist())) == sorted(i for i in plan.ids if i != victim)
    # The failure is finished too: a rerun does not run it; asked, it runs it (the fault gone).
    monkeypatch.delenv("VISTIR_CAMPAIGN_FAULT")
    assert campaign.run(f, out, local=WORKERS, progress=False).done == 0
    again = campaign.run(f, out, local=WORKERS, retry_failed=True, progress=False)
    assert (again.done, again.failed) == (1, 0)
    assert pq.read_table(out / "results.parquet").equals(table)


def test_the_driver_killed_and_restarted_resumes(tmp_path):
    # More cases than the others, so the driver can be killed while some are left.
    f = write_campaign(tmp_path / "c.toml", frames=12, replicas=6)
    plan = campaign.plan(f)
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "vistir.campaign", "run", str(f), "--out", str(out), "--local", str(WORKERS), "--no-progress"]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 300
    seen = 0
    while time.monotonic() < deadline and proc.poll() is None:
        m = out / "manifest.jsonl"
        seen = len(m.read_text().splitlines()) if m.exists() else 0
        if seen >= 2:
            break
        time.sleep(0.02)
    assert proc.poll() is None, f"the driver ended before it was killed: {proc.stderr.read().decode()}"
    os.killpg(proc.pid, signal.SIGKILL)  # the driver and its cluster
    proc.wait()
    before = len(manifest(out))
    assert 2 <= before < len(plan.ids), before
    s = campaign.run(f, out, local=WORKERS, progress=False)
    assert s.already == before and s.done == len(plan.ids) - before and s.failed == 0
    assert_once_each(out, plan.ids)
    serial = campaign.run(f, tmp_path / "serial", serial=True, progress=False)
    assert serial.done == len(plan.ids)
    assert pq.read_table(out / "results.parquet").equals(pq.read_table(tmp_path / "serial" / "results.parquet"))


def test_an_existing_scheduler_and_its_workers_give_the_serial_table(reference, tmp_path):
    """The way a cluster without Slurm is used: a `dask scheduler` and `dask worker` processes
    started by hand, the campaign pointed at them through the command line."""
    f, table = reference
    sched_file = tmp_path / "scheduler.json"
    procs = [
        subprocess.Popen(
            ["dask", "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard", "--scheduler-file", str(sched_file)],
            start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )
    ]
    try:
        deadline = time.monotonic() + 60
        while not sched_file.exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        address = json.loads(sched_file.read_text())["address"]
        procs.append(
            subprocess.Popen(
                ["dask", "worker", address, "--nworkers", str(WORKERS), "--nthreads", "1", "--no-dashboard"],
                start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            )
        )
        out = tmp_path / "out"
        for how in (["--scheduler", address], ["--scheduler-file", str(sched_file)]):
            cmd = [sys.executable, "-m", "vistir.campaign", "run", str(f), "--out", str(out), *how, "--no-progress"]
            r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
            assert r.returncode == 0, r.stderr
        # The first run did every case; the second, through the scheduler file, found them done.
        assert_once_each(out, campaign.plan(f).ids)
        assert pq.read_table(out / "results.parquet").equals(table)
    finally:
        for p in reversed(procs):
            os.killpg(p.pid, signal.SIGTERM)
            p.wait(timeout=60)


def _slurm_idle() -> bool:
    try:
        r = subprocess.run(["sinfo", "-h", "-o", "%t"], capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return r.returncode == 0 and "idle" in r.stdout


def test_slurm_jobs_give_the_serial_table(reference, tmp_path):
    """`--slurm`: Dask workers in real sbatch jobs (dask-jobqueue). CI starts a one-node Slurm
    (`.ci/slurm-single-node`) and sets VISTIR_TEST_SLURM=1, so there the test cannot skip."""
    if not _slurm_idle():
        if os.environ.get("VISTIR_TEST_SLURM") == "1":
            pytest.fail("VISTIR_TEST_SLURM=1 but no idle Slurm node (run .ci/slurm-single-node)")
        pytest.skip("no Slurm here (.ci/slurm-single-node starts one)")
    f, table = reference
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "vistir.campaign", "run", str(f), "--out", str(out), "--no-progress",
           "--slurm", "2", "--slurm-cores", "1", "--slurm-memory", "1GB", "--slurm-walltime", "00:10:00"]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert_once_each(out, campaign.plan(f).ids)
    assert pq.read_table(out / "results.parquet").equals(table)
    # The workers ran as Slurm jobs: each job's output file (sbatch writes it where the driver
    # runs) holds a Dask worker's log.
    logs = [p.read_text(errors="replace") for p in tmp_path.glob("slurm-*.out")]
    assert logs and any("Start worker" in text for text in logs), logs
    # A worker killed in the middle of a case inside its Slurm job: its nanny restarts it there,
    # the case runs again, once in the results.
    victim = campaign.plan(f).ids[1]
    env = dict(os.environ, VISTIR_CAMPAIGN_FAULT=f"kill-once:{victim}")
    scratch = tmp_path / "scratch"
    again = [*cmd[:6], str(tmp_path / "faulted"), *cmd[7:], "--scratch", str(scratch)]
    r = subprocess.run(again, capture_output=True, text=True, timeout=600, cwd=tmp_path, env=env)
    assert r.returncode == 0, r.stderr
    assert (scratch / f"fault-{victim}").exists(), "the worker running the case was killed"
    assert_once_each(tmp_path / "faulted", campaign.plan(f).ids)
    assert pq.read_table(tmp_path / "faulted" / "results.parquet").equals(table)


def test_a_half_written_manifest_line_is_dropped(reference, tmp_path):
    f, table = reference
    out = tmp_path / "out"
    campaign.run(f, out, serial=True, progress=False)
    lines = (out / "manifest.jsonl").read_bytes().splitlines(keepends=True)
    # The driver killed while appending the last record: that case runs again.
    (out / "manifest.jsonl").write_bytes(b"".join(lines[:-1]) + lines[-1][:10])
    s = campaign.run(f, out, serial=True, progress=False)
    assert (s.already, s.done) == (5, 1)
    assert len(manifest(out)) == 6
    assert pq.read_table(out / "results.parquet").equals(table)


def test_a_changed_file_or_code_is_refused_unless_asked(reference, tmp_path):
    f, _ = reference
    out = tmp_path / "out"
    campaign.run(f, out, serial=True, progress=False)
    changed = write_campaign(tmp_path / "changed.toml", frames=9)
    with pytest.raises(campaign.CampaignError, match="the file plans"):
        campaign.run(changed, out, serial=True, progress=False)
    state = json.loads((out / "campaign.json").read_text())
    (out / "campaign.json").write_text(json.dumps({**state, "code_version": "0.0.0+elsewhere"}))
    with pytest.raises(campaign.CampaignError, match="come from code 0.0.0"):
        campaign.run(f, out, serial=True, progress=False)
    s = campaign.run(f, out, serial=True, allow_changed=True, progress=False)
    assert s.already == 6 and s.done == 0
    assert json.loads((out / "campaign.json").read_text())["code_version"] == campaign.CODE_VERSION
    # Another driver on the same folder is refused while one runs.
    from vistir.campaign.store import Store

    with Store(out):
        with pytest.raises(campaign.CampaignError, match="another campaign driver"):
            campaign.run(f, out, serial=True, progress=False)


def test_bad_files_are_refused_in_one_line(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(CAMPAIGN.format(frames=8).replace('"flyaround"', '"flyarond"'))
    with pytest.raises(ValueError, match=r"bad.toml, line \d+: unknown variant `flyarond`"):
        campaign.plan(bad)
    done = subprocess.run([sys.executable, "-m", "vistir.campaign", "plan", str(bad)], capture_output=True, text=True)
    assert done.returncode == 1 and done.stderr.count("\n") == 1 and "flyarond" in done.stderr


def test_the_plan_is_the_clis(reference):
    f, _ = reference
    if not FUSION.exists():
        pytest.fail(f"the fusion CLI is not at {FUSION}: build it or set FUSION_BIN")
    cli = json.loads(subprocess.run([str(FUSION), "campaign", "plan", str(f), "--json"], capture_output=True, text=True, check=True).stdout)
    assert cli == campaign.plan(f).cases
    # The table both commands print is one function's.
    table = subprocess.run([str(FUSION), "campaign", "plan", str(f)], capture_output=True, text=True, check=True).stdout
    ours = subprocess.run([sys.executable, "-m", "vistir.campaign", "plan", str(f)], capture_output=True, text=True, check=True).stdout
    assert ours == table and table.count("\n") == 2 + len(cli)


def test_the_report(reference, tmp_path):
    f, table = reference
    out = tmp_path / "out"
    campaign.run(f, out, serial=True, progress=False)
    md = campaign.report(out).read_text()
    for needle in ["# Campaign `faults`", "6 cases finished of 6 planned", "## By sun phase angle", "## Which stream to fly", "| adaptive |", "| vis |"]:
        assert needle in md, needle
    for chart in ["flyaround_availability.png", "flyaround_att_rms_deg.png"]:
        assert (out / chart).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # The report's merge is the run's.
    assert pq.read_table(out / "results.parquet").equals(table)
    # Its interval: a constant's is the constant; a sample's holds its mean, inside its range.
    assert bootstrap_mean(np.full(7, 0.25)) == (0.25, 0.25, 0.25)
    v = np.array([0.1, 0.5, 0.9, 0.3, 0.7, np.nan])
    m, lo, hi = bootstrap_mean(v)
    assert m == pytest.approx(0.5) and 0.1 <= lo < m < hi <= 0.9


def test_the_verdict_names_streams_that_tie_on_every_case_as_one():
    import pandas as pd

    from vistir.campaign.report import HEADLINE, MAX_LINES, _best, _headline

    cases = [f"c{i}" for i in range(8)]
    rng = np.random.default_rng(3)
    base = rng.uniform(0.2, 0.4, size=len(cases))

    def frame(avail):
        return pd.DataFrame([{"case_id": c, "source": s, "availability": v} for s, vs in avail.items() for c, v in zip(cases, vs)])

    # a and b give the same figure on every case, c is lower by 0.2 on each: a ≡ b, separated.
    df = frame({"a": base + 0.2, "b": base + 0.2, "c": base})
    assert _best(df, ["a", "b", "c"]) == f"**a ≡ b** ({float(np.mean(base + 0.2)):.2f})"
    # b differs from a on one case only, by a little: not separated, named beside it.
    b = base + 0.2
    b[0] -= 0.01
    assert "≈ b" in _best(frame({"a": base + 0.2, "b": b, "c": base}), ["a", "b", "c"])
    # Every stream the same: no winner.
    assert _best(frame({s: base for s in "abcd"}), list("abcd")).startswith("every stream alike")
    # Under 10 % availability no stream navigates.
    assert _best(frame({"a": base / 10, "b": base / 20}), ["a", "b"]).startswith("none navigates")
    # Lines: every stream when few, else the headline ones.
    many = [f"s{i}" for i in range(MAX_LINES + 1)] + list(HEADLINE)
    assert _headline(["vis", "x"]) == ["vis", "x"] and _headline(many) == list(HEADLINE)
