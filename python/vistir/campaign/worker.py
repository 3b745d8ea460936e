"""What a worker runs for one case: the project's Rust code through the extension (the case's
sequence rendered into a scratch folder and judged), its rows returned as an Arrow table. The
worker writes nothing the campaign keeps; the driver alone writes results.

Fault injection, for the tests and for anyone checking a cluster's behaviour: the environment
variable ``VISTIR_CAMPAIGN_FAULT`` (seen by the worker processes) lists ``kill:ID`` (the
worker kills itself with SIGKILL whenever it starts case ID) and ``kill-once:ID`` (only the
first time: a marker file in the scratch folder remembers it), separated by commas.
"""

from __future__ import annotations

import json
import os
import signal
import tempfile
import time
from pathlib import Path
from typing import Optional, Tuple

import pyarrow as pa

from .. import _vistir

#: Columns that are not floating-point figures.
_STRING = {"case_id", "trajectory", "target", "source", "phase"}
_INT = {"case_index", "replica", "seed", "frames"}
_BOOL = {"earth", "glare"}


def rows_to_table(rows: list) -> pa.Table:
    """The rows of a case (dicts in the Rust crate's order) as an Arrow table with fixed types:
    strings, int64, bools, and float64 (null where the judge has no value)."""
    if not rows:
        raise ValueError("a case returned no rows")
    fields = []
    for name in rows[0]:
        if name in _STRING:
            t = pa.string()
        elif name in _INT:
            t = pa.int64()
        elif name in _BOOL:
            t = pa.bool_()
        else:
            t = pa.float64()
        fields.append(pa.field(name, t))
    schema = pa.schema(fields)
    return pa.Table.from_pylist(rows, schema=schema)


def _fault(case_id: str, scratch: Path) -> None:
    for item in filter(None, os.environ.get("VISTIR_CAMPAIGN_FAULT", "").split(",")):
        kind, _, target = item.partition(":")
        if target != case_id:
            continue
        if kind == "kill":
            os.kill(os.getpid(), signal.SIGKILL)
        elif kind == "kill-once":
            marker = scratch / f"fault-{case_id}"
            if not marker.exists():
                marker.write_text("killed once\n")
                os.kill(os.getpid(), signal.SIGKILL)


def run_case(case: dict, scratch: Optional[str], threads: int = 1) -> Tuple[pa.Table, float]:
    """Runs one planned case in a scratch folder (`None`: this process's temporary folder);
    returns its table (one row per stream and phase) and the seconds it took in the worker."""
    start = time.monotonic()
    scratch_path = Path(scratch or tempfile.gettempdir())
    scratch_path.mkdir(parents=True, exist_ok=True)
    _fault(case["id"], scratch_path)
    rows = json.loads(_vistir._campaign_case(json.dumps(case), str(scratch_path), threads))
    return rows_to_table(rows), time.monotonic() - start
