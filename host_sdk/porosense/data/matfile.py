"""MATLAB .mat files as named columns: v5/v7 through scipy.io, v7.3 (HDF5) through h5py.

What a MATLAB user saves is read without edits:

- named vectors (``save('run.mat', 't', 'u', 'y')``): one column each;
- a struct of vectors (``s.u = ...; s.y = ...; save('run.mat', 's')``): one column per field;
- an N x k matrix ``u``: columns ``u_0 .. u_{k-1}`` (a header group ``u``);
- a scalar ``Ts`` (or ``ts``, ``dt``) states the sample period in seconds, as iddata's ``Ts``.

Every numeric variable whose length is the record length becomes a column; other variables
(strings, scalars, differently sized arrays) are ignored. The columns come back as a
:class:`porosense.data.table.Table`.

A damaged or hostile file ends in one line (InputError), within bounded memory and time: HDF5
links (soft, external) are not followed, every variable's declared size is checked against
:data:`MEMORY_BUDGET_BYTES` (and, stored uncompressed, against the file's size) before it is
read, and structs nest at most :data:`MAX_DEPTH` levels.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from porosense.data.table import Table
from porosense.errors import InputError

TS_NAMES = ("Ts", "ts", "dt", "Ts_s")
TIME_UNIT_NAMES = ("TimeUnit", "time_unit", "t_unit", "Ts_unit")  # iddata's TimeUnit, saved as text
SKIPPED = ("units", "meta", "recording_json")
LINKS = "#links"  # v7.3: the soft and external links left unread, name -> why
#: Bytes all the numeric variables of one file may take once read, 512 MiB (a recording of 10^7 samples
#: on three channels in double precision is 240 MB).
MEMORY_BUDGET_BYTES = 1 << 29
MAX_DEPTH = 16  # struct (group) nesting levels read
MAX_VARIABLES = 10_000


def _is_hdf5(path: Path) -> bool:
    # MATLAB's v7.3 files are HDF5 with a 512-byte user block before the HDF5 signature.
    with open(path, "rb") as fh:
        head = fh.read(520)
    return head[512:520] == b"\x89HDF\r\n\x1a\n" or head[:8] == b"\x89HDF\r\n\x1a\n"


def _flatten(name: str, value, out: dict) -> None:
    """Collect numeric arrays (and struct fields, with a prefix when nested) into ``out``."""
    if isinstance(value, dict):
        for key, sub in value.items():
            _flatten(key if not name else f"{name}.{key}", sub, out)
        return
    arr = np.asarray(value)
    if arr.dtype.kind in "biuf" and arr.size:
        out[name] = arr.astype(float) if arr.dtype.kind != "f" else arr


def _declared_bytes(shape, itemsize: int = 8) -> int:
    n = 1
    for d in shape:
        n *= max(int(d), 0)
    return n * itemsize


def _check_v5_sizes(path: Path) -> None:
    """Refuse a v5 file whose variables declare more than the memory budget (headers only:
    scipy's whosmat reads them without the data, compressed or not)."""
    from scipy.io import whosmat

    try:
        listing = whosmat(path)
    except NotImplementedError:
        return  # v7.3: checked by _read_v73
    except Exception as exc:  # scipy raises several types for a damaged file
        raise InputError(f"{path}: not a readable MATLAB file ({type(exc).__name__}: {exc})") from None
    if len(listing) > MAX_VARIABLES:
        raise InputError(f"{path}: {len(listing):,} variables, more than a recording holds ({MAX_VARIABLES:,})")
    total = sum(_declared_bytes(shape) for _, shape, _ in listing)
    if total > MEMORY_BUDGET_BYTES:
        raise InputError(
            f"{path}: its variables declare {total / 2**30:.3g} GiB, more than the {MEMORY_BUDGET_BYTES / 2**30:.3g} GiB "
            "a file may take in memory"
        )


#: Seconds a v5 file may take to read (a recording of 10^7 samples reads in about a second).
V5_TIME_LIMIT_S = 60.0


def _loadmat(path: Path):
    from scipy.io import loadmat

    return loadmat(path, squeeze_me=True, struct_as_record=False, simplify_cells=False)


def _loadmat_isolated(path: Path):
    """scipy's loadmat in a forked child process with its address space limited to the memory
    budget and a time limit: its compiled reader can crash on a damaged file (a mutated v5
    header made it segfault), which must cost the command one line, not the process.
    Returns what loadmat returns; raises what it raised, or InputError."""
    import pickle
    import resource
    import select
    import signal
    import time

    if not hasattr(os, "fork"):  # no fork (Windows): read in this process
        return _loadmat(path)
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: read, send the result or the exception, leave
        code = 0
        try:
            os.close(r)
            import faulthandler

            faulthandler.disable()  # a crash here is the parent's to report, in one line
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, 2)
            with open("/proc/self/statm") as fh:
                vm = int(fh.read().split()[0]) * resource.getpagesize()
            limit = vm + 2 * MEMORY_BUDGET_BYTES
            resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
            try:
                out = ("ok", _loadmat(path))
            except BaseException as exc:  # noqa: BLE001 - every failure goes back to the parent
                out = ("error", exc if isinstance(exc, Exception) else RuntimeError(repr(exc)))
            data = pickle.dumps(out, protocol=pickle.HIGHEST_PROTOCOL)
            with os.fdopen(w, "wb") as fh:
                fh.write(data)
        except BaseException:  # noqa: BLE001
            code = 1
        os._exit(code)
    os.close(w)
    chunks, deadline = [], time.monotonic() + V5_TIME_LIMIT_S
    with os.fdopen(r, "rb") as fh:
        while True:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([fh], [], [], left)[0]:
                os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
                raise InputError(f"{path}: reading it took more than {V5_TIME_LIMIT_S:.0f} s")
            chunk = os.read(fh.fileno(), 1 << 20)
            if not chunk:
                break
            chunks.append(chunk)
    _, status = os.waitpid(pid, 0)
    if os.WIFSIGNALED(status) or not chunks:
        why = f"signal {os.WTERMSIG(status)}" if os.WIFSIGNALED(status) else "no result"
        raise InputError(f"{path}: not a readable MATLAB file (the reader failed on it: {why})")
    try:
        kind, value = pickle.loads(b"".join(chunks))
    except Exception:  # noqa: BLE001 - a truncated or odd result
        raise InputError(f"{path}: not a readable MATLAB file (the reader's result was incomplete)") from None
    if kind == "error":
        if isinstance(value, MemoryError):
            raise InputError(f"{path}: reading it needs more than the {MEMORY_BUDGET_BYTES / 2**30:.3g} GiB budget")
        raise value
    return value


def _read_v5(path: Path) -> dict:
    from scipy.io.matlab import mat_struct

    _check_v5_sizes(path)
    try:
        content = _loadmat_isolated(path)
    except InputError:
        raise
    except NotImplementedError:  # v7.3 without the usual signature position
        return _read_v73(path)
    except Exception as exc:  # scipy raises several types for a damaged file
        raise InputError(f"{path}: not a readable MATLAB file ({type(exc).__name__}: {exc})") from None

    def convert(value):
        if isinstance(value, mat_struct):
            return {k: convert(getattr(value, k)) for k in value._fieldnames}
        if isinstance(value, np.ndarray) and value.dtype == object:
            if value.size == 1:
                return convert(value.item())
            return None  # struct arrays and cell arrays: not a column
        return value

    return {k: convert(v) for k, v in content.items() if not k.startswith("__")}


def _read_v73(path: Path) -> dict:
    try:
        import h5py
    except ImportError:  # pragma: no cover - h5py is a dependency
        raise InputError(f"{path}: a MATLAB v7.3 file needs h5py (pip install h5py)") from None

    file_size = path.stat().st_size
    budget = [MEMORY_BUDGET_BYTES]  # what is left of it
    count = [0]
    links: dict = {}  # variable or field name -> why it was not read

    def members(group, depth: int) -> dict:
        """A group's datasets and groups, hard links only: soft and external links (which can
        loop or point into other files) are not followed."""
        if depth > MAX_DEPTH:
            raise InputError(f"{path}: structs nested more than {MAX_DEPTH} levels")
        out = {}
        for k in group:
            if k.startswith("#"):
                continue
            count[0] += 1
            if count[0] > MAX_VARIABLES:
                raise InputError(f"{path}: more than {MAX_VARIABLES:,} variables and fields")
            link = group.get(k, getlink=True)
            name = ".".join([*filter(None, group.name.split("/")), k])  # a struct's field as s.field
            if isinstance(link, h5py.ExternalLink):
                links[name] = f"is a link to {link.filename}:{link.path} in another file, not followed"
                continue
            if not isinstance(link, h5py.HardLink):
                links[name] = f"is a link to {getattr(link, 'path', '?')}, not followed"
                continue
            out[k] = convert(group[k], depth)
        return out

    def convert(node, depth: int):
        if isinstance(node, h5py.Group):
            return members(node, depth + 1)
        if not isinstance(node, h5py.Dataset):
            return None
        cls = node.attrs.get("MATLAB_class", b"double")
        cls = cls.decode() if isinstance(cls, bytes) else str(cls)
        if cls == "char" and node.dtype.kind in "iu" and not node.attrs.get("MATLAB_empty", 0):
            return "".join(chr(int(c)) for c in np.asarray(node[()]).T.ravel())  # UTF-16 code units
        if cls in ("char", "cell", "function_handle") or node.dtype.kind not in "biuf":
            return None
        if node.attrs.get("MATLAB_empty", 0):
            return None
        need = _declared_bytes(node.shape, max(node.dtype.itemsize, 8))
        if need > budget[0]:
            raise InputError(
                f"{path}: variable {node.name} declares {node.shape} values ({need / 2**30:.3g} GiB), more than "
                f"the {MEMORY_BUDGET_BYTES / 2**30:.3g} GiB a file may take in memory"
            )
        if (
            node.compression is None
            and node.chunks is None
            and _declared_bytes(node.shape, node.dtype.itemsize) > file_size
        ):
            raise InputError(
                f"{path}: variable {node.name} declares more data than the file holds ({file_size:,} bytes)"
            )
        budget[0] -= need
        # HDF5 stores MATLAB's column-major arrays transposed: an N x k matrix reads as (k, N).
        return np.asarray(node[()]).T

    try:
        with h5py.File(path, "r") as fh:
            content = members(fh, 0)
            if links:
                content[LINKS] = links
            return content
    except InputError:
        raise
    except (OSError, KeyError, ValueError, TypeError, RuntimeError, RecursionError) as exc:
        raise InputError(f"{path}: not a readable MATLAB v7.3 (HDF5) file ({type(exc).__name__}: {exc})") from None


def read_mat(path) -> Table:
    """Columns of the MATLAB file at ``path`` (v5/v7 or v7.3) as a :class:`Table` (ts set when stated)."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    content = _read_v73(path) if _is_hdf5(path) else _read_v5(path)
    links = content.pop(LINKS, {})
    flat: dict = {}
    for name, value in content.items():
        if name in SKIPPED or value is None:
            continue
        _flatten(name, value, flat)
    ts = None
    for name in list(flat):
        base = name.rsplit(".", 1)[-1]
        if base in TS_NAMES and np.size(flat[name]) == 1:
            ts = float(np.ravel(flat.pop(name))[0])
    vectors = {}
    for name, value in flat.items():
        v = np.squeeze(value)
        if v.ndim == 1 and v.size > 1:
            vectors[name] = v.reshape(-1, 1)
        elif v.ndim == 2:
            vectors[name] = v
    if not vectors:
        if links:
            name, why = next(iter(links.items()))
            more = f" ({len(links) - 1} more links)" if len(links) > 1 else ""
            raise InputError(
                f"{path}: no numeric vectors found: '{name}' {why}{more}; save the data in the file itself"
            )
        raise InputError(
            f"{path}: no numeric vectors found (variables: {', '.join(content) or 'none'}); "
            "save the signals as vectors or a struct of vectors (MATLAB tables, timetables and "
            "iddata objects cannot be read: save(f, '-struct', 's') of their columns)"
        )
    units = _text_fields(content.get("units"))
    time_unit = next((str(content[k]) for k in TIME_UNIT_NAMES if isinstance(content.get(k), str)), None)
    lengths = [max(v.shape) for v in vectors.values()]
    n = max(set(lengths), key=lambda L: (lengths.count(L), L))
    # Signals stored as rows (k x N) read as columns.
    vectors = {k: (v.T if v.shape[0] != n and v.shape[1] == n else v) for k, v in vectors.items()}
    # A struct's fields keep their own names unless two structs share one.
    short = {}
    for name in vectors:
        base = name.rsplit(".", 1)[-1]
        short[name] = base if sum(1 for m in vectors if m.rsplit(".", 1)[-1] == base) == 1 else name
    names, columns, groups, skipped = [], {}, {}, {}
    for name, v in vectors.items():
        if v.shape[0] != n:
            skipped[short[name]] = (
                f"has {max(v.shape)} samples where the other variables have {n}: "
                "the signals of one record must have one length"
            )
            continue
        label = short[name]
        if v.shape[1] == 1:
            members = [label]
        else:
            members = [f"{label}_{i}" for i in range(v.shape[1])]
            groups[label] = members
        for i, m in enumerate(members):
            columns[m] = np.ascontiguousarray(v[:, i], dtype=float)
            names.append(m)
    version = "v7.3 (HDF5)" if _is_hdf5(path) else "v5/v7"
    table = Table(
        path=path,
        names=names,
        columns=columns,
        groups=groups,
        lines=None,
        dialect=f"MATLAB {version} file",
        ts=ts,
        ts_source=f"variable Ts in {path.name}" if ts else "",
        units={k: v for k, v in units.items() if k in columns or k == "t"},
        units_source=f"the units struct in {path.name}" if units else "",
        time_unit=time_unit,
        skipped={**{k: f"{why}: save the data in the file itself" for k, why in links.items()}, **skipped},
        meta=_recording_meta(content),
    )
    return table


def _recording_meta(content: dict) -> dict:
    """The recording's metadata (porosity, load_g, ...) as ``Recording.to_mat`` stores it: the exact
    JSON in ``recording_json``, else the scalar fields of a ``meta`` struct; {} when neither reads."""
    import json

    text = content.get("recording_json")
    if isinstance(text, str):
        try:
            doc = json.loads(text)
        except (ValueError, RecursionError):
            doc = None
        if isinstance(doc, dict) and isinstance(doc.get("meta"), dict):
            return doc["meta"]
    out: dict = {}
    meta = content.get("meta")
    if isinstance(meta, dict):
        for key, value in meta.items():
            if isinstance(value, str):
                out[str(key)] = value
                continue
            v = np.asarray(value)
            if v.size == 1 and v.dtype.kind in "iuf" and np.isfinite(v.item()):
                out[str(key)] = v.item()
    return out


def _text_fields(value) -> dict:
    """{field: text} of a struct of strings (a ``units`` struct), else {}."""
    if not isinstance(value, dict):
        return {}
    return {str(k): str(v) for k, v in value.items() if isinstance(v, str)}
