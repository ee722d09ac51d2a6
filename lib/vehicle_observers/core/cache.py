"""On-disk cache entries that cannot run code: NumPy ``.npz`` (``allow_pickle=False``) and JSON.

The caches of the command line (LMI designs, ``identify``'s fits, the ML noise tuning) keep
results that take seconds to compute. A pickle would run any code planted in the file by
whoever can write the cache folder; these entries are data only:

* :func:`save` / :func:`load` - an object tree of numbers, strings, ``None``, tuples, lists,
  dicts, NumPy arrays (not of dtype object) and instances of the package's own classes
  (``vehicle_observers.*``, rebuilt from their attribute dict without calling any of their
  code) in one ``.npz`` file: the arrays as NumPy arrays, the tree as a JSON text.
  Anything else (a function, a solver object) is not cacheable (:class:`NotCacheable`: the
  caller keeps the result in memory only).
* :func:`save_json` / :func:`load_json` - a JSON document.

Every entry records :data:`SCHEMA_VERSION`, its ``kind`` and the SHA-256 of its content; an
entry that is unreadable, of another version or kind, fails its checksum, names a class
that is not the package's or whose fields changed, or fails the caller's ``validate``
(finite, positive, positive definite, ...) is ignored with one warning line naming the
file (logger ``vehicle_observers.cache``) and rebuilt by the caller.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib
import io
import json
import logging
import math
import os
import re
from pathlib import Path

import numpy as np

#: version of the entries' layout (an entry of another version is rebuilt)
SCHEMA_VERSION = 1
#: the only package whose classes an entry may name
PACKAGE = "vehicle_observers"
log = logging.getLogger("vehicle_observers.cache")


class NotCacheable(TypeError):
    """The object holds something that is not plain data (a function, a solver object)."""


class InvalidEntry(ValueError):
    """A cache entry that is not to be used (the message says why)."""


# ------------------------------------------------------------------ encoding --------------
def _encode(obj, arrays: dict):
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, np.generic):
        key = f"a{len(arrays)}"
        arrays[key] = np.asarray(obj)
        return {"__scalar__": key}
    if isinstance(obj, int):
        return obj
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else {"__float__": repr(obj)}
    if isinstance(obj, np.ndarray):
        if obj.dtype.hasobject:
            raise NotCacheable(f"array of dtype {obj.dtype}")
        key = f"a{len(arrays)}"
        arrays[key] = obj
        return {"__nd__": key}
    if isinstance(obj, tuple):
        return {"__tuple__": [_encode(x, arrays) for x in obj]}
    if isinstance(obj, list):
        return [_encode(x, arrays) for x in obj]
    if isinstance(obj, (set, frozenset)):
        return {"__set__": [_encode(x, arrays) for x in sorted(obj, key=repr)]}
    if isinstance(obj, dict):
        return {"__dict__": [[_encode(k, arrays), _encode(v, arrays)] for k, v in obj.items()]}
    cls = type(obj)
    state = getattr(obj, "__dict__", None)
    if state is None or not cls.__module__.startswith(PACKAGE + ".") or "<locals>" in \
            cls.__qualname__:
        raise NotCacheable(f"{cls.__module__}.{cls.__qualname__}")
    return {"__obj__": f"{cls.__module__}:{cls.__qualname__}",
            "state": {k: _encode(v, arrays) for k, v in state.items()}}


def _class(name: str):
    """The package's class ``module:qualname``; anything else is refused (no import of a
    module outside the package, nothing called)."""
    mod, _, qual = name.partition(":")
    if not mod.startswith(PACKAGE + ".") or not qual:
        raise InvalidEntry(f"names {name!r}, not a class of {PACKAGE}")
    try:
        obj = importlib.import_module(mod)
        for part in qual.split("."):
            obj = getattr(obj, part)
    except (ImportError, AttributeError):
        raise InvalidEntry(f"names {name!r}, which this version does not have") from None
    if not isinstance(obj, type):
        raise InvalidEntry(f"names {name!r}, not a class")
    return obj


def _decode(node, arrays):
    if isinstance(node, list):
        return [_decode(x, arrays) for x in node]
    if not isinstance(node, dict):
        return node
    if "__nd__" in node:
        return arrays[node["__nd__"]]
    if "__scalar__" in node:
        return arrays[node["__scalar__"]][()]
    if "__float__" in node:
        return float(node["__float__"])
    if "__tuple__" in node:
        return tuple(_decode(x, arrays) for x in node["__tuple__"])
    if "__set__" in node:
        return {_decode(x, arrays) for x in node["__set__"]}
    if "__dict__" in node:
        return {_hashable(_decode(k, arrays)): _decode(v, arrays) for k, v in node["__dict__"]}
    if "__obj__" in node:
        cls = _class(node["__obj__"])
        state = {k: _decode(v, arrays) for k, v in node["state"].items()}
        if dataclasses.is_dataclass(cls):
            need = {f.name for f in dataclasses.fields(cls)}
            if not need <= set(state):
                raise InvalidEntry(f"{node['__obj__']} lacks field(s) "
                                   f"{', '.join(sorted(need - set(state)))} (another version)")
        obj = object.__new__(cls)
        obj.__dict__.update(state)
        return obj
    raise InvalidEntry(f"unknown node {sorted(node)[:3]}")


def _hashable(x):
    return tuple(_hashable(v) for v in x) if isinstance(x, list) else x


def _digest(tree_text: str, arrays: dict) -> str:
    h = hashlib.sha256(tree_text.encode())
    for k in sorted(arrays):
        a = np.ascontiguousarray(arrays[k])
        h.update(f"{k}:{a.dtype.str}:{a.shape}".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def _atomic_write(path: Path, data: bytes) -> bool:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        tmp.write_bytes(data)
        os.replace(tmp, path)
        return True
    except OSError:
        return False                    # a read-only or full cache folder: not kept


# ------------------------------------------------------------------ npz entries ----------
def save(path, obj, kind: str, validate=None) -> bool:
    """Store ``obj`` in ``path`` (``.npz``, written atomically). Returns False (nothing
    written) when ``obj`` is not plain data, fails ``validate`` or the folder is not
    writable."""
    arrays: dict = {}
    try:
        tree = _encode(obj, arrays)
        if validate is not None:
            validate(obj)
    except (NotCacheable, InvalidEntry, RecursionError):
        return False
    text = json.dumps(tree, sort_keys=True)
    meta = {"schema_version": SCHEMA_VERSION, "kind": kind, "sha256": _digest(text, arrays)}
    buf = io.BytesIO()
    np.savez(buf, __tree__=np.array(text), __meta__=np.array(json.dumps(meta)), **arrays)
    return _atomic_write(Path(path), buf.getvalue())


def load(path, kind: str, validate=None):
    """The object stored in ``path`` by :func:`save`, or ``None`` when absent or not to be
    used (then one warning line names the file and why; the caller rebuilds it).
    ``validate(obj)`` raises :class:`InvalidEntry` (or ValueError) for an entry whose numbers
    are wrong."""
    path = Path(path)
    if not path.exists():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            files = {k: z[k] for k in z.files}
        meta = json.loads(str(files.pop("__meta__")))
        text = str(files.pop("__tree__"))
        _check_meta(meta, kind, _digest(text, files))
        obj = _decode(json.loads(text), files)
        if validate is not None:
            validate(obj)
        return obj
    except Exception as exc:  # noqa: BLE001 - any bad entry is rebuilt, never trusted
        _rebuilt(path, exc)
        return None


def _check_meta(meta, kind, digest):
    got = meta.get("schema_version") if isinstance(meta, dict) else None
    if got != SCHEMA_VERSION:
        raise InvalidEntry(f"schema version {got!r}, expected {SCHEMA_VERSION}")
    if meta.get("kind") != kind:
        raise InvalidEntry(f"holds a {meta.get('kind')!r} entry, expected {kind!r}")
    if meta.get("sha256") != digest:
        raise InvalidEntry("checksum mismatch (edited or corrupt)")


def _rebuilt(path: Path, exc: Exception):
    why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    if not isinstance(exc, InvalidEntry):
        why = f"unreadable: {type(exc).__name__}: {why}"
    log.warning("warning: cache file %s ignored and rebuilt (%s)", path, why)


# ------------------------------------------------------------------ JSON entries ---------
def save_json(path, doc: dict, kind: str) -> bool:
    """Store the JSON document ``doc`` in ``path`` (atomic; False when not writable)."""
    text = json.dumps(doc, sort_keys=True, allow_nan=False)
    meta = {"schema_version": SCHEMA_VERSION, "kind": kind,
            "sha256": hashlib.sha256(text.encode()).hexdigest()}
    return _atomic_write(Path(path), json.dumps({"meta": meta, "entry": doc}, sort_keys=True,
                                                allow_nan=False).encode())


def load_json(path, kind: str, validate=None):
    """The document stored by :func:`save_json`, or ``None`` (absent, or not to be used: one
    warning line naming the file)."""
    path = Path(path)
    if not path.exists():
        return None
    try:
        d = json.loads(path.read_text())
        if not isinstance(d, dict) or not isinstance(d.get("entry"), dict):
            raise InvalidEntry("not a cache entry of this version")
        doc = d["entry"]
        _check_meta(d.get("meta"), kind, hashlib.sha256(
            json.dumps(doc, sort_keys=True, allow_nan=False).encode()).hexdigest())
        if validate is not None:
            validate(doc)
        return doc
    except Exception as exc:  # noqa: BLE001 - any bad entry is rebuilt, never trusted
        _rebuilt(path, exc)
        return None


# ------------------------------------------------------------------ validators -----------
def check_finite(obj, where="entry"):
    """Raise :class:`InvalidEntry` naming the first float array or number (anywhere in the
    tree) that is NaN or infinite, or any matrix named ``P`` (``P``, ``P00``, ...) that is
    not positive definite (a vector ``P``: the diagonal, every entry > 0)."""
    _walk(obj, where, set())


def _walk(o, where, seen):
    if id(o) in seen:
        return
    if isinstance(o, np.ndarray):
        if o.dtype.kind in "fc" and not np.all(np.isfinite(o)):
            raise InvalidEntry(f"{where} is not finite")
        name = where.rsplit(".", 1)[-1]
        if o.dtype.kind == "f" and re.fullmatch(r"P\d*", name):
            _positive_definite(o, where)
        return
    if isinstance(o, float | np.floating):
        if not math.isfinite(o):
            raise InvalidEntry(f"{where} is not finite")
        return
    if isinstance(o, (str, bytes, int, bool, type(None))):
        return
    seen.add(id(o))
    if isinstance(o, (list, tuple)):
        for i, x in enumerate(o):
            _walk(x, f"{where}[{i}]", seen)
    elif isinstance(o, dict):
        for k, x in o.items():
            _walk(x, f"{where}.{k}", seen)
    elif hasattr(o, "__dict__"):
        for k, x in vars(o).items():
            _walk(x, f"{where}.{k}", seen)


def _positive_definite(P, where):
    if P.ndim >= 2 and P.shape[-1] == P.shape[-2]:
        M = P.reshape(-1, P.shape[-1], P.shape[-1])
        for A in M:
            if not np.allclose(A, A.T, rtol=1e-9, atol=0.0) or np.linalg.eigvalsh(A).min() <= 0:
                raise InvalidEntry(f"{where} is not symmetric positive definite")
    elif np.any(P <= 0):
        raise InvalidEntry(f"{where} (a diagonal) has an entry <= 0")
