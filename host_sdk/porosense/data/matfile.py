"""MATLAB .mat files as named columns: v5/v7 through scipy.io, v7.3 (HDF5) through h5py.

What a MATLAB user saves is read without edits:

- named vectors (``save('run.mat', 't', 'u', 'y')``): one column each;
- a struct of vectors (``s.u = ...; s.y = ...; save('run.mat', 's')``): one column per field;
- an N x k matrix ``u``: columns ``u_0 .. u_{k-1}`` (a header group ``u``);
- a scalar ``Ts`` (or ``ts``, ``dt``) states the sample period in seconds, as iddata's ``Ts``.

Every numeric variable whose length is the record length becomes a column; other variables
(strings, scalars, differently sized arrays) are ignored. The columns come back as a
:class:`porosense.data.table.Table`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from porosense.data.table import Table
from porosense.errors import InputError

TS_NAMES = ("Ts", "ts", "dt", "Ts_s")
TIME_UNIT_NAMES = ("TimeUnit", "time_unit", "t_unit", "Ts_unit")  # iddata's TimeUnit, saved as text
SKIPPED = ("units", "meta", "recording_json")


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


def _read_v5(path: Path) -> dict:
    from scipy.io import loadmat
    from scipy.io.matlab import mat_struct

    try:
        content = loadmat(path, squeeze_me=True, struct_as_record=False, simplify_cells=False)
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

    def convert(node):
        if isinstance(node, h5py.Group):
            return {k: convert(node[k]) for k in node if not k.startswith("#")}
        cls = node.attrs.get("MATLAB_class", b"double")
        cls = cls.decode() if isinstance(cls, bytes) else str(cls)
        if cls == "char" and node.dtype.kind in "iu" and not node.attrs.get("MATLAB_empty", 0):
            return "".join(chr(int(c)) for c in np.asarray(node[()]).T.ravel())  # UTF-16 code units
        if cls in ("char", "cell", "function_handle") or node.dtype.kind not in "biuf":
            return None
        if node.attrs.get("MATLAB_empty", 0):
            return None
        # HDF5 stores MATLAB's column-major arrays transposed: an N x k matrix reads as (k, N).
        return np.asarray(node[()]).T

    try:
        with h5py.File(path, "r") as fh:
            return {k: convert(fh[k]) for k in fh if not k.startswith("#")}
    except OSError as exc:
        raise InputError(f"{path}: not a readable MATLAB v7.3 (HDF5) file ({exc})") from None


def read_mat(path) -> Table:
    """Columns of the MATLAB file at ``path`` (v5/v7 or v7.3) as a :class:`Table` (ts set when stated)."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    content = _read_v73(path) if _is_hdf5(path) else _read_v5(path)
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
            skipped[short[name]] = f"{max(v.shape)} samples where the other variables have {n}"
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
        skipped=skipped,
    )
    return table


def _text_fields(value) -> dict:
    """{field: text} of a struct of strings (a ``units`` struct), else {}."""
    if not isinstance(value, dict):
        return {}
    return {str(k): str(v) for k, v in value.items() if isinstance(v, str)}
