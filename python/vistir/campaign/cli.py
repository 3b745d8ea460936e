"""``vistir-campaign``: plan, run and report Monte Carlo campaigns of the navigation judge.

    vistir-campaign plan FILE
    vistir-campaign run FILE --out DIR [--local N | --scheduler ADDRESS | --scheduler-file FILE | --slurm JOBS ...]
    vistir-campaign report DIR
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="vistir-campaign", description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="verb", required=True)
    p = sub.add_parser("plan", help="list the cases of a campaign file with their ids")
    p.add_argument("file", type=Path)
    r = sub.add_parser("run", help="run a campaign file (resumes what DIR holds)")
    r.add_argument("file", type=Path, help="the campaign file (TOML)")
    r.add_argument("--out", type=Path, required=True, help="the campaign's folder")
    engine = r.add_mutually_exclusive_group()
    engine.add_argument("--local", type=int, metavar="N", help="a local Dask cluster of N worker processes [default: one per core]")
    engine.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask scheduler, e.g. tcp://head:8786")
    engine.add_argument("--scheduler-file", metavar="FILE", help="the file an existing scheduler wrote (dask scheduler --scheduler-file)")
    engine.add_argument("--slurm", type=int, metavar="JOBS", help="Slurm through dask-jobqueue: JOBS jobs of one worker each")
    engine.add_argument("--serial", action="store_true", help="in this process, without Dask (the reference)")
    r.add_argument("--slurm-cores", type=int, default=2, help="cores per Slurm job [2]")
    r.add_argument("--slurm-memory", default="4GB", help="memory per Slurm job [4GB]")
    r.add_argument("--slurm-walltime", default="01:00:00", help="walltime per Slurm job [01:00:00]")
    r.add_argument("--slurm-queue", help="the Slurm partition")
    r.add_argument("--slurm-account", help="the Slurm account")
    r.add_argument("--threads-per-case", type=int, help="threads each case may use [cores / workers locally, else 1]")
    r.add_argument("--allowed-failures", type=int, default=3, help="workers a case may kill before it is recorded as failed [3]")
    r.add_argument("--allow-changed", action="store_true", help="go on in a folder made by another campaign file or code version")
    r.add_argument("--retry-failed", action="store_true", help="run the cases recorded as failed again")
    r.add_argument("--scratch", metavar="DIR", help="where each case renders its frames (removed after): a node-local disk on a cluster [each worker's temporary folder]")
    r.add_argument("--no-progress", action="store_true", help="no progress bar")
    rep = sub.add_parser("report", help="merge, summarise and chart a campaign's folder")
    rep.add_argument("dir", type=Path)
    return ap


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    try:
        from . import driver
        from .report import report as make_report
        from .store import CampaignError

        if args.verb == "plan":
            print(driver.plan(args.file).table, end="")
            return 0
        if args.verb == "run":
            slurm = None
            if args.slurm is not None:
                slurm = {"jobs": args.slurm, "cores": args.slurm_cores, "processes": 1, "memory": args.slurm_memory, "walltime": args.slurm_walltime}
                if args.slurm_queue:
                    slurm["queue"] = args.slurm_queue
                if args.slurm_account:
                    slurm["account"] = args.slurm_account
            s = driver.run(
                args.file,
                args.out,
                local=args.local,
                scheduler=args.scheduler,
                scheduler_file=args.scheduler_file,
                scratch=args.scratch,
                slurm=slurm,
                serial=args.serial,
                allow_changed=args.allow_changed,
                retry_failed=args.retry_failed,
                threads_per_case=args.threads_per_case,
                allowed_failures=args.allowed_failures,
                progress=not args.no_progress,
            )
            print(
                f"campaign: {s.planned} cases planned, {s.already} finished before, {s.done} done and {s.failed} failed now "
                f"({s.seconds:.0f} s)" + (f"; merged table {s.results}" if s.results else "; not complete: run again to resume")
            )
            for cid, reason in sorted(s.failures.items()):
                print(f"failed {cid}: {reason}", file=sys.stderr)
            return 0
        md = make_report(args.dir)
        print(f"report: {md}")
        return 0
    except (CampaignError, ValueError, OSError) as e:
        print(f"vistir-campaign: {' '.join(str(e).split())}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("vistir-campaign: interrupted; the finished cases are kept, run the same command again to resume", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
