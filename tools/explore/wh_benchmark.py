"""The measured WH process-noise benchmark's records, for the scripts in this folder.

Reads ../shared/data/wh_process_noise (or POROSENSE_SHARED_DATA); exits with a one-line error
when the folder is not there.
"""

import sys

from porosense.bench.ident import shared_data_folder
from porosense.data import read_table


def tables():
    """(estimation table, test table) of the benchmark, or exit 2 when its folder is missing."""
    folder = shared_data_folder()
    if folder is None:
        print("benchmark data folder not found", file=sys.stderr)
        sys.exit(2)
    return (
        read_table(folder / "wh_process_noise" / "WH_EstimationExample.csv"),
        read_table(folder / "wh_process_noise" / "WH_TestDataset.csv"),
    )


TS = 1.0 / 78_125.0  # s: the benchmark's sample rate, 78,125 Hz (the files' fs column)


def records(n):
    """(us, ys, test u, test y): the estimation realisations ((N, 1) inputs, volts), the first
    ``n`` or those ``n`` lists, and the test multisine."""
    est, test = tables()
    which = range(n) if isinstance(n, int) else list(n)
    us = [est.columns[f"u_{i}"][:, None] for i in which]
    ys = [est.columns[f"y_{i}"] for i in which]
    return us, ys, test.columns["u_0"][:, None], test.columns["y_0"]


def realisations(arg: str):
    """Realisation indices from a command-line word: ``N`` (the first N) or ``A-B`` (A to B)."""
    if "-" in arg:
        lo, hi = (int(v) for v in arg.split("-"))
        return list(range(lo, hi + 1))
    return list(range(int(arg)))
