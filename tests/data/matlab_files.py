"""Files written the way MATLAB and European spreadsheets write them (test helpers).

The v7.3 writer follows MATLAB's own layout, independently of porosense's reader: an HDF5
file with a 512-byte user block holding MATLAB's text header, each variable a dataset
with a ``MATLAB_class`` attribute, stored transposed (MATLAB is column-major: an N x 1
column vector is an HDF5 dataset of shape (1, N)), and a struct as an HDF5 group.
"""

from __future__ import annotations

import numpy as np


def write_mat_v5(path, variables: dict, struct_name: str | None = None) -> None:
    """``save(path, names...)`` (or ``save(path, 's')`` of a struct ``s``) as MATLAB v5 does."""
    from scipy.io import savemat

    content = {k: np.asarray(v, dtype=float).reshape(-1, 1) if np.ndim(v) == 1 else v for k, v in variables.items()}
    if struct_name:
        content = {struct_name: content}
    savemat(path, content, format="5", oned_as="column")


def write_mat_v73(path, variables: dict, struct_name: str | None = None) -> None:
    """``save(path, ..., '-v7.3')``: HDF5 with MATLAB's user block, classes and transposed arrays."""
    import h5py

    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  5 10:00:00 2026 HDF5 schema 1.00 ."
    with h5py.File(path, "w", userblock_size=512) as fh:
        group = fh
        if struct_name:
            group = fh.create_group(struct_name)
            group.attrs["MATLAB_class"] = np.bytes_(b"struct")
        for name, value in variables.items():
            arr = np.asarray(value, dtype=float)
            arr = arr.reshape(-1, 1) if arr.ndim == 1 else arr
            ds = group.create_dataset(name, data=arr.T)  # column-major: stored transposed
            ds.attrs["MATLAB_class"] = np.bytes_(b"double")
        note = fh.create_dataset(
            "note", data=np.frombuffer("run 3".encode("utf-16-le"), dtype=np.uint16).reshape(-1, 1)
        )
        note.attrs["MATLAB_class"] = np.bytes_(b"char")
    with open(path, "r+b") as fh:
        fh.write(header.ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02IM")


def write_european_csv(path, columns: dict, fmt: str = "{:.6f}") -> None:
    """A spreadsheet's CSV in a European locale: ';' separators and decimal commas."""
    names = list(columns)
    rows = zip(*[np.asarray(columns[n], dtype=float) for n in names])
    lines = [";".join(names)]
    lines += [";".join(fmt.format(v).replace(".", ",") for v in row) for row in rows]
    with open(path, "w", encoding="utf-8", newline="") as fh:
        fh.write("\r\n".join(lines) + "\r\n")
