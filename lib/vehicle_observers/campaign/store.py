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

Every batch file carries in its Parquet key-value metadata (key :data:`META_KEY`, JSON) the
schema version :data:`SCHEMA_VERSION`, the campaign's spec hash, its kind, batch id and task
range ``[start, stop)``, and the ``provenance`` the engine passes (package version, ...).
:func:`verify_batch` checks a file against the plan (metadata, row count, and the index
column being exactly ``start..stop-1``): on resume a file that does not belong (another
campaign's file under the same name, a file of an older format, a torn or foreign file) is
moved to ``DIR/rejected/`` with a line naming it and its batch is recomputed; the report
reads only verified files, so each task is counted once, and names the tasks missing.
"""

from __future__ import annotations

import json
import logging
import os
import re
from pathlib import Path

from vehicle_observers.campaign.spec import FORMAT, Spec, SpecError, canonical

KINDS = ("results", "lmi")
_BATCH = re.compile(r"^batch-(\d{6,})\.parquet$")
#: version of the batch files' metadata (:func:`batch_meta`); a file of another version is
#: not this campaign's (recomputed on resume, left out of the report)
SCHEMA_VERSION = 2   # 2: result rows with coverage_vy, nees_vy, warnings, warning_kinds
#: Parquet key-value metadata key of a batch file's description
META_KEY = b"vehicle_observers.batch"
#: index column of each kind of batch
INDEX = {"results": "task", "lmi": "point"}
#: rejected files named one by one (the others counted in one line)
MAX_NAMED = 5
log = logging.getLogger(__name__)


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
    try:
        out.mkdir(parents=True, exist_ok=True)
        for k in KINDS:
            (out / k).mkdir(exist_ok=True)
        _atomic_text(out / "spec.json", json.dumps({"sha256": spec.sha256, "given": spec.raw,
                                                    "normalised": spec.doc}, indent=1,
                                                   sort_keys=True))
        _atomic_text(mf, json.dumps(man, indent=1, sort_keys=True))
    except OSError as exc:
        raise SpecError(f"--out {out}: cannot write there ({write_reason(exc)})") from None
    return man


def write_reason(exc: OSError) -> str:
    """Why a write failed, in words (a full disk or quota named as such)."""
    import errno

    if exc.errno in (errno.ENOSPC, errno.EDQUOT) or "No space left" in str(exc):
        return "the disk is full"
    if exc.errno == errno.EROFS:
        return "read-only file system"
    return exc.strerror or str(exc)


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


def batch_meta(spec: Spec, kind: str, bid: int, start: int, stop: int,
               provenance: dict | None = None) -> dict:
    """The description every batch file carries (module docstring)."""
    return {"schema_version": SCHEMA_VERSION, "spec_sha256": spec.sha256, "kind": kind,
            "batch": int(bid), "start": int(start), "stop": int(stop),
            "provenance": dict(provenance or {})}


def read_meta(path) -> dict:
    """The description of batch file ``path`` (``{}`` when it has none)."""
    import pyarrow.parquet as pq

    kv = pq.read_schema(path).metadata or {}
    raw = kv.get(META_KEY)
    if raw is None:
        return {}
    m = json.loads(raw)
    return m if isinstance(m, dict) else {}


def verify_batch(path, spec: Spec, kind: str, bid: int, start: int, stop: int) -> str | None:
    """``None`` when ``path`` is batch ``bid`` (tasks ``start..stop-1``) of campaign ``spec``,
    else the reason it is not (one phrase)."""
    import pyarrow.parquet as pq

    try:
        m = read_meta(path)
        if not m:
            return "no campaign metadata (a foreign or older file)"
        if m.get("schema_version") != SCHEMA_VERSION:
            return f"schema version {m.get('schema_version')!r}, expected {SCHEMA_VERSION}"
        if m.get("spec_sha256") != spec.sha256:
            return (f"written by another campaign (spec sha256 {str(m.get('spec_sha256'))[:12]}, "
                    f"this one {spec.sha256[:12]})")
        want = {"kind": kind, "batch": bid, "start": start, "stop": stop}
        got = {k: m.get(k) for k in want}
        if got != want:
            return f"describes {got}, expected {want}"
        idx = pq.read_table(path, columns=[INDEX[kind]])[INDEX[kind]].to_pylist()
    except Exception as exc:  # noqa: BLE001 - any unreadable file is not a batch of ours
        return f"unreadable ({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})"
    if idx != list(range(start, stop)):
        return (f"holds {len(idx)} row(s) of {INDEX[kind]}s {idx[:3]}..., expected "
                f"{start}..{stop - 1}")
    return None


def plan_of(spec: Spec, kind: str):
    """``[(batch id, start, stop), ...]`` of ``kind`` in the plan of ``spec``."""
    return spec.batches() if kind == "results" else spec.lmi_batches()


def check_batches(out, spec: Spec, kind: str, reject: bool = False):
    """Verify every batch file of ``kind`` in ``out`` against the plan of ``spec``. Returns
    ``(ids of the files that belong, [(file, reason), ...] of those that do not)``. With
    ``reject`` a file that does not belong is moved to ``out/rejected/`` (never deleted) so
    its batch is recomputed, with a warning line naming it."""
    d = Path(out) / kind
    if not d.is_dir():
        return set(), []
    for f in list(d.glob("*.partial-*")):
        _remove_if_writer_gone(f)
    plan = {k: (a, b) for k, a, b in plan_of(spec, kind)}
    good, bad = set(), []
    for f in sorted(d.iterdir()):
        m = _BATCH.match(f.name)
        if not m:
            continue
        bid = int(m.group(1))
        why = "batch id outside the plan" if bid not in plan else \
            verify_batch(f, spec, kind, bid, *plan[bid])
        if why is None:
            good.add(bid)
            continue
        bad.append((f, why))
        if reject:
            dest = Path(out) / "rejected" / f"{kind}-{f.name}"
            try:
                dest.parent.mkdir(exist_ok=True)
                k = 1
                while dest.exists():
                    dest = dest.with_name(f"{kind}-{f.stem}.{k}.parquet")
                    k += 1
                os.replace(f, dest)
            except OSError as exc:
                raise SpecError(f"{f}: does not belong to this campaign ({why}) and cannot "
                                f"be moved aside ({write_reason(exc)})") from None
            if len(bad) <= MAX_NAMED:
                log.warning("warning: %s does not belong to this campaign (%s): moved to %s, "
                            "batch %d recomputed", f, why, dest, bid)
    if reject and len(bad) > MAX_NAMED:
        log.warning("warning: %d more %s file(s) did not belong to this campaign: moved to "
                    "%s, their batches recomputed", len(bad) - MAX_NAMED, kind,
                    Path(out) / "rejected")
    return good, bad


def done_batches(out, kind: str, spec: Spec | None = None) -> set[int]:
    """Ids of the batch files present (complete by construction); stale partial files of
    dead processes are deleted. With ``spec``: only the files that belong to it (a file
    that does not is moved aside, :func:`check_batches`)."""
    if spec is not None:
        return check_batches(out, spec, kind, reject=True)[0]
    d = Path(out) / kind
    if not d.is_dir():
        return set()
    for f in list(d.glob("*.partial-*")):
        _remove_if_writer_gone(f)
    return {int(m.group(1)) for f in d.iterdir() if (m := _BATCH.match(f.name))}


def write_batch(out, kind: str, bid: int, columns: dict, schema, meta: dict | None = None) -> Path:
    """Write one batch (columns -> Parquet, ``schema``) atomically, with ``meta``
    (:func:`batch_meta`) in its key-value metadata. Returns the file."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    path = batch_path(out, kind, bid)
    tmp = path.with_name(f"{path.name}.partial-{os.getpid()}")
    table = pa.table({n: pa.array(columns[n], type=schema.field(n).type) for n in schema.names},
                     schema=schema)
    if meta is not None:
        table = table.replace_schema_metadata({**(schema.metadata or {}),
                                               META_KEY: json.dumps(meta, sort_keys=True)})
    try:
        pq.write_table(table, tmp, compression="snappy")
        os.replace(tmp, path)
    except BaseException:
        try:
            tmp.unlink()
        except OSError:
            pass
        raise
    return path


def read_table(out, kind: str, columns=None, spec: Spec | None = None):
    """Every batch of ``kind`` as one pyarrow table sorted by its index column (``task`` or
    ``point``); an empty table of the right schema when none is done. ``columns``: read only
    these (the index column is added). ``spec``: only the files that belong to it
    (:func:`check_batches`)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    d = Path(out) / kind
    files = sorted(f for f in d.glob("batch-*.parquet") if _BATCH.match(f.name)) if d.is_dir() else []
    if spec is not None:
        good = check_batches(out, spec, kind)[0]
        files = [f for f in files if int(_BATCH.match(f.name).group(1)) in good]
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


def read_results(out, columns=None, spec: Spec | None = None):
    """The simulation rows of a campaign folder (pyarrow table, sorted by ``task``;
    ``spec``: the verified files only)."""
    return read_table(out, "results", columns, spec)


def read_lmi(out, spec: Spec | None = None):
    """The LMI-map rows of a campaign folder (pyarrow table, sorted by ``point``)."""
    return read_table(out, "lmi", spec=spec)


def missing(spec: Spec, kind: str, good: set) -> list[tuple[int, int]]:
    """Ranges ``[(start, stop), ...]`` of the tasks (points) of ``kind`` not in a verified
    file, consecutive ranges merged."""
    out = []
    for k, a, b in plan_of(spec, kind):
        if k in good:
            continue
        if out and out[-1][1] == a:
            out[-1] = (out[-1][0], b)
        else:
            out.append((a, b))
    return out


def ranges_text(rs: list[tuple[int, int]], limit: int = 6) -> str:
    """``"3..5, 9, 12..20"`` (inclusive), at most ``limit`` ranges then ``(+k more)``."""
    txt = [f"{a}" if b - a == 1 else f"{a}..{b - 1}" for a, b in rs[:limit]]
    return ", ".join(txt) + (f" (+{len(rs) - limit} more range(s))" if len(rs) > limit else "")


def manifest(out) -> dict:
    mf = Path(out) / "campaign.json"
    if not mf.exists():
        raise SpecError(f"{out}: not a campaign folder (no campaign.json)")
    try:
        return json.loads(mf.read_text())
    except (OSError, ValueError) as exc:
        raise SpecError(f"{mf}: unreadable campaign manifest ({exc})") from None


def spec_of_folder(out) -> Spec:
    """The :class:`Spec` a campaign folder was run with."""
    try:
        doc = json.loads((Path(out) / "spec.json").read_text())
        given, sha = doc["given"], doc["sha256"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise SpecError(f"{Path(out) / 'spec.json'}: unreadable campaign spec ({exc})") from None
    spec = Spec(given, str(Path(out) / "spec.json"))
    if spec.sha256 != sha:
        raise SpecError(f"{out}: spec.json gives sha256 {spec.sha256[:12]} != recorded "
                        f"{doc['sha256'][:12]} (registry or code changed since the run)")
    return spec


__all__ = ["batch_meta", "batch_path", "canonical", "check_batches", "done_batches", "manifest",
           "missing", "prepare", "read_lmi", "read_results", "spec_of_folder", "verify_batch",
           "write_batch"]
