"""Output files written whole or not at all.

Every file a command produces is written to a hidden temporary file in the same folder and
renamed over the target when complete (``os.replace`` is atomic on one file system): a command
stopped by Ctrl-C, an error or a full disk leaves no partial file, and an existing file keeps its
old content until the new one is whole.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path


def _temporary_name(path: Path) -> Path:
    # Same folder (the rename stays on one file system), same suffix (writers that pick the
    # format from it, such as matplotlib, keep working), hidden and unique to this process.
    return path.with_name(f".{path.stem}.part-{os.getpid()}{path.suffix}")


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; rename it onto ``path`` when the block succeeds.

    Parameters
    ----------
    path : str or Path
        The file to produce. Its folder must exist.

    Yields
    ------
    Path
        Where to write. On an exception (KeyboardInterrupt included) it is removed and the
        exception goes on; ``path`` is untouched.
    """
    path = Path(path)
    tmp = _temporary_name(path)
    try:
        yield tmp
        if tmp.exists():
            os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()


def write_text(path, text: str, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` whole or not at all; returns the path."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding=encoding)
    return Path(path)


def write_bytes(path, data: bytes) -> Path:
    """Write ``data`` to ``path`` whole or not at all; returns the path."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


LABELS_KEY = "porosense.labels"  # PNG text chunk holding figure_labels() as JSON


def figure_labels(fig) -> dict:
    """Titles, axis labels and legend entries of every axes of ``fig`` (colour bars included)."""
    axes = []
    for ax in fig.axes:
        legend = ax.get_legend()
        axes.append(
            {
                "title": ax.get_title(),
                "xlabel": ax.get_xlabel(),
                "ylabel": ax.get_ylabel(),
                "legend": [t.get_text() for t in legend.get_texts()] if legend else [],
            }
        )
    suptitle = getattr(fig, "_suptitle", None)
    return {"title": suptitle.get_text() if suptitle else "", "axes": axes}


def save_figure(fig, path, **kwargs) -> Path:
    """``fig.savefig(path, **kwargs)`` whole or not at all (the format from the suffix); returns the path.

    A PNG carries the figure's text (:func:`figure_labels`) as JSON in a text chunk, so that a report
    page and its tests read what every figure says."""
    import json

    path = Path(path)
    if path.suffix.lower() == ".png":
        kwargs["metadata"] = {LABELS_KEY: json.dumps(figure_labels(fig)), **(kwargs.get("metadata") or {})}
    with atomic_path(path) as tmp:
        fig.savefig(tmp, **kwargs)
    return path
