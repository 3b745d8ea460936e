"""Monte Carlo campaigns of the navigation judge on Dask.

A campaign file (TOML; the repository's README, "Campaigns") names the axes — trajectory, sun
phase angle, the Earth behind the target or not, target, glare — their values or
distributions, the replicas (sensor seeds), the streams and the sequence length. Each case is
one sequence rendered and every stream judged by the project's Rust code in a Dask worker; the
driver alone writes the results (one Parquet file per case, an append-only manifest), resumes
what a previous run finished, and records a case that keeps killing its worker as failed.

    from vistir import campaign
    campaign.run("examples/campaigns/tiny.toml", "out/tiny", local=2)   # or scheduler=, slurm=
    campaign.report("out/tiny")                                          # tables, CIs, charts

The same from the shell: ``vistir-campaign run FILE --out DIR --local 2``, ``vistir-campaign
report DIR``. Needs ``pip install './python[campaign]'`` (Dask, pyarrow, pandas, tqdm,
matplotlib, dask-jobqueue).
"""

from .driver import CODE_VERSION, Plan, RunSummary, plan, run
from .report import report
from .store import CampaignError

__all__ = ["CODE_VERSION", "CampaignError", "Plan", "RunSummary", "plan", "report", "run"]
