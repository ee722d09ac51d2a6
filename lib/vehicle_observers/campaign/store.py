"""The results folder of a campaign: one Parquet file per finished batch, written atomically.

Layout of ``DIR``::

    campaign.json          spec hash, format, plan size (written before any batch)
    spec.json              the spec as given and normalised
    results/batch-000042.parquet   rows of simulation batch 42 (schema: tasks.result_schema)
    lmi/batch-000003.parquet       rows of LMI-map batch 3 (schema: lmi_map.schema)

A batch file is written to ``<name>.partial-<pid>`` and renamed onto its name when complete
(``os.replace``, atomic on POSIX), so a file that exists is whole; a run killed at any moment
loses at most the batches in flight, and the next run with the same spec skips the files
present (and deletes partial files of dead processes). A folder of another campaign (other
spec hash or format) is refused.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

from vehicle_observers.campaign.spec import FORMAT, Spec, SpecError, canonical

KINDS = ("results", "lmi")
_BATCH = re.compile(r"^batch-(\d{6,})\.parquet$")


def batch_path(out: Path, kind: str, bid: int) -> Path:
    return Path(out) / kind / f"batch-{bid:06d}.parquet"


def prepare(out, spec: Spec) -> dict:
    """Create or check the folder ``out`` for ``spec``. Returns the manifest. Raises
    :class:`SpecError` (one line) when ``out`` holds another campaign or is not a folder."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise SpecError(f"--out {out}: exists and is not a folder")
    man = {"format": FORMAT, "spec_sha256": spec.sha256, "name": spec.doc["name"],
           "tasks": spec.n_tasks, "batches": len(spec.batches()), "batch_size": spec.batch_size,
           "lmi_points": len(spec.lmi_points), "lmi_batches": len(spec.lmi_batches())}
    mf = out / "campaign.json"
    if mf.exists():
        try:
            old = json.loads(mf.read_text())
        except (OSError, ValueError) as exc:
            raise SpecError(f"{mf}: unreadable campaign manifest ({exc})") from None
        if old.get("format") != FORMAT or old.get("spec_sha256") != spec.sha256:
            raise SpecError(f"{out}: holds another campaign (spec sha256 "
                            f"{str(old.get('spec_sha256'))[:12]}, format {old.get('format')}; this "
                            f"spec is {spec.sha256[:12]}, format {FORMAT}): use another folder")
        return old
    elif out.exists() and any(out.iterdir()):
        raise SpecError(f"--out {out}: not empty and not a campaign folder (no campaign.json)")
    out.mkdir(parents=True, exist_ok=True)
    for k in KINDS:
        (out / k).mkdir(exist_ok=True)
    _atomic_text(out / "spec.json", json.dumps({"sha256": spec.sha256, "given": spec.raw,
                                                "normalised": spec.doc}, indent=1, sort_keys=True))
    _atomic_text(mf, json.dumps(man, indent=1, sort_keys=True))
    return man


def _atomic_text(path: Path, text: str):
    tmp = path.with_name(f"{path.name}.partial-{os.getpid()}")
    tmp.write_text(text + "\n")
    os.replace(tmp, path)


def _remove_if_writer_gone(f: Path):
    """Delete ``f`` (``<batch>.partial-<pid>`` inside a campaign folder, which only this
    program writes) when no process ``pid`` runs on this machine."""
    try:
        pid = int(f.name.rsplit(".partial-", 1)[1])
    except (IndexError, ValueError):
        return
    try:
        os.kill(pid, 0)
        return                                  # still running (or not ours to judge)
    except ProcessLookupError:
        pass
    except PermissionError:
        return
    try:
        f.unlink()
    except OSError:
        pass


def done_batches(out, kind: str) -> set[int]:
    """Ids of the batch files present (complete by construction); stale partial files of
    dead processes are deleted."""
    d = Path(out) / kind
    if not d.is_dir():
        return set()
    for f in list(d.glob("*.partial-*")):
        _remove_if_writer_gone(f)
    return {int(m.group(1)) for f in d.iterdir() if (m := _BATCH.match(f.name))}


def write_batch(out, kind: str, bid: int, columns: dict, schema) -> Path:
    """Write one batch (columns -> Parquet, ``schema``) atomically. Returns the file."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    path = batch_path(out, kind, bid)
    tmp = path.with_name(f"{path.name}.partial-{os.getpid()}")
    table = pa.table({n: pa.array(columns[n], type=schema.field(n).type) for n in schema.names},
                     schema=schema)
    pq.write_table(table, tmp, compression="snappy")
    os.replace(tmp, path)
    return path


def read_table(out, kind: str, columns=None):
    """Every batch of ``kind`` as one pyarrow table sorted by its index column (``task`` or
    ``point``); an empty table of the right schema when none is done. ``columns``: read only
    these (the index column is added)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    d = Path(out) / kind
    files = sorted(f for f in d.glob("batch-*.parquet") if _BATCH.match(f.name)) if d.is_dir() else []
    if not files:
        if kind == "results":
            from vehicle_observers.campaign.tasks import result_schema
            t = result_schema().empty_table()
        else:
            from vehicle_observers.campaign.lmi_map import schema
            t = schema().empty_table()
        return t if columns is None else t.select(list(columns))
    key = "task" if kind == "results" else "point"
    cols = None if columns is None else list(dict.fromkeys([key, *columns]))
    t = pa.concat_tables([pq.read_table(f, columns=cols) for f in files])
    return t.sort_by(key)


def read_results(out, columns=None):
    """The simulation rows of a campaign folder (pyarrow table, sorted by ``task``)."""
    return read_table(out, "results", columns)


def read_lmi(out):
    """The LMI-map rows of a campaign folder (pyarrow table, sorted by ``point``)."""
    return read_table(out, "lmi")


def manifest(out) -> dict:
    mf = Path(out) / "campaign.json"
    if not mf.exists():
        raise SpecError(f"{out}: not a campaign folder (no campaign.json)")
    return json.loads(mf.read_text())


def spec_of_folder(out) -> Spec:
    """The :class:`Spec` a campaign folder was run with."""
    doc = json.loads((Path(out) / "spec.json").read_text())
    spec = Spec(doc["given"], str(Path(out) / "spec.json"))
    if spec.sha256 != doc["sha256"]:
        raise SpecError(f"{out}: spec.json gives sha256 {spec.sha256[:12]} != recorded "
                        f"{doc['sha256'][:12]} (registry or code changed since the run)")
    return spec


__all__ = ["batch_path", "canonical", "done_batches", "manifest", "prepare", "read_lmi",
           "read_results", "spec_of_folder", "write_batch"]
