"""A campaign's output folder, written by the driver alone.

    DIR/campaign.json     what was planned: name, plan fingerprint, code version, case count
    DIR/campaign.toml     a copy of the campaign file
    DIR/manifest.jsonl    append-only: one line per finished case, {"case", "status", ...}
    DIR/cases/ID.parquet  one table per finished case (written to a temporary name, renamed)
    DIR/results.parquet   the merged table, one row per case, stream and phase (plan order)
    DIR/.lock             held by the running driver

Every file appears whole or not at all: written under a temporary name in the same folder,
flushed to disk, renamed. A driver killed at any point leaves a folder that a rerun resumes:
a case is finished only once its line is in the manifest, and a half-written last line (the
driver killed while appending) is dropped when the manifest is next opened.
"""

from __future__ import annotations

import fcntl
import json
import os
import tempfile
from pathlib import Path
from typing import Dict, Iterable, List

import pyarrow as pa
import pyarrow.parquet as pq

STATE = "campaign.json"
MANIFEST = "manifest.jsonl"
CASES = "cases"
RESULTS = "results.parquet"


class CampaignError(Exception):
    """A campaign refused (a changed file or code, a busy folder): its message is one line."""


def _fsync_dir(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_atomic(path: Path, write) -> None:
    """Calls `write(tmp_path)` for a temporary file beside `path`, then renames it over `path`."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        write(Path(tmp))
        with open(tmp, "rb") as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    _fsync_dir(path.parent)


class Store:
    """The output folder of one campaign, locked for one driver."""

    def __init__(self, out: Path):
        self.out = Path(out)
        self.out.mkdir(parents=True, exist_ok=True)
        (self.out / CASES).mkdir(exist_ok=True)
        self._lock = open(self.out / ".lock", "a")
        try:
            fcntl.flock(self._lock.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self._lock.close()
            raise CampaignError(f"{self.out}: another campaign driver is running on this folder") from None

    def close(self) -> None:
        self._lock.close()

    def __enter__(self) -> "Store":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # What was planned.
    def state(self) -> Dict | None:
        p = self.out / STATE
        return json.loads(p.read_text()) if p.exists() else None

    def write_state(self, state: Dict, campaign_text: str) -> None:
        write_atomic(self.out / "campaign.toml", lambda t: t.write_text(campaign_text))
        write_atomic(self.out / STATE, lambda t: t.write_text(json.dumps(state, indent=2) + "\n"))

    # The manifest.
    def records(self) -> Dict[str, Dict]:
        """The finished cases: id → its last record. Drops a half-written last line."""
        p = self.out / MANIFEST
        if not p.exists():
            return {}
        data = p.read_bytes()
        if data and not data.endswith(b"\n"):
            keep = data.rfind(b"\n") + 1
            with open(p, "r+b") as f:
                f.truncate(keep)
                os.fsync(f.fileno())
            data = data[:keep]
        out: Dict[str, Dict] = {}
        for line in data.splitlines():
            rec = json.loads(line)
            out[rec["case"]] = rec
        return out

    def append(self, record: Dict) -> None:
        """Appends one record to the manifest and flushes it to disk."""
        line = (json.dumps(record, sort_keys=True) + "\n").encode()
        with open(self.out / MANIFEST, "ab") as f:
            f.write(line)
            f.flush()
            os.fsync(f.fileno())

    # Per-case tables.
    def case_path(self, case_id: str) -> Path:
        return self.out / CASES / f"{case_id}.parquet"

    def write_case(self, case_id: str, table: pa.Table) -> None:
        write_atomic(self.case_path(case_id), lambda t: pq.write_table(table, t))

    def merge(self, case_ids: Iterable[str]) -> Path:
        """Writes the merged table of these cases as results.parquet, in plan order (by
        `case_index`; Arrow's sort is stable, so each case keeps its rows' order)."""
        tables: List[pa.Table] = [pq.read_table(self.case_path(c)) for c in case_ids]
        path = self.out / RESULTS
        if tables:
            merged = pa.concat_tables(tables, promote_options="default").sort_by("case_index")
            write_atomic(path, lambda t: pq.write_table(merged, t))
        return path
