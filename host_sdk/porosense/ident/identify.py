"""Identify models from recordings as ``porosense identify`` does: validation data or a hold-out,
the order search of every output, the smoothness weight, optional decimation.

    result = identify(u=[U1, U2, U3], y=[Y1, Y2, Y3], ts=0.01, outputs=("strain_0",))
    result.model.save("model.json")

The command line calls this function, so Python and the CLI give the same model from the same
data and options.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.signal import resample_poly

from porosense.errors import InputError
from porosense.ident.candidates import SearchResult
from porosense.ident.models import ModelSet, as_recordings
from porosense.ident.options import SearchOptions
from porosense.ident.search import search
from porosense.ident.smoothness import choose_smoothness, skips_of
from porosense.ident.workers import Cluster, stop

HOLDOUT_FRACTION = 0.25  # the last quarter of every record validates when there is no other data
MIN_SCORED = 20  # samples a held-out part needs to be scored
MIN_FILES_FOR_FILE_HOLDOUT = 3  # with this many records, the last one is held out whole


@dataclass
class Identification:
    """Models identified for every output, with the searches that selected them.

    Attributes
    ----------
    models : list of Model
        One per output.
    results : list of SearchResult
        The search of each output.
    smoothness : list of SmoothnessChoice or None
        Per output, the smoothness weight chosen (None when none was tried).
    outputs : tuple of str
        Output names.
    holdout : str
        How the validation data were made.
    notes : list of str
        What else was done to the data (decimation).
    ts : float
        The models' sample period, s.
    """

    models: list
    results: list[SearchResult]
    smoothness: list
    outputs: tuple
    holdout: str
    notes: list = field(default_factory=list)
    ts: float = float("nan")

    @property
    def model(self):
        """The single model, or a :class:`ModelSet` for several outputs."""
        return self.models[0] if len(self.models) == 1 else ModelSet(self.models)

    def save(self, path):
        """Write the model file (whole or not at all).

        Parameters
        ----------
        path : str or Path
            The model file.

        Returns
        -------
        Path
            The file written.
        """
        return self.model.save(path)

    def to_dict(self) -> dict:
        """The identification as a plain dict.

        Returns
        -------
        dict
            ``holdout``, ``notes``, ``ts`` (s) and per output its search, smoothness choice and
            process-noise level.
        """
        out = []
        for name, res, choice, model in zip(self.outputs, self.results, self.smoothness, self.models):
            out.append(
                {
                    "output": name,
                    **res.to_dict(),
                    "smoothness": {"weight": choice.weight, "validation_fit": choice.fits} if choice else None,
                    "process_noise": model.info.get("process_noise"),
                }
            )
        return {"holdout": self.holdout, "notes": list(self.notes), "ts": self.ts, "results": out}


def holdout(u, y, skip: int = 0, names=None):
    """Estimation and validation records when no validation data are given.

    With at least 3 records the last one validates whole (scored past ``skip``, as estimation);
    with fewer, the last 25 % of every record past ``skip`` validates: each validation record
    is the whole record, simulated from rest and scored from its cut.

    Returns
    -------
    (est_u, est_y, (val_u, val_y, val_skips), description)
    """
    us, ys = _records(u, y)
    if len(us) >= MIN_FILES_FOR_FILE_HOLDOUT:
        name = f" ({names[-1]})" if names else ""
        return us[:-1], ys[:-1], (us[-1:], ys[-1:], [skip]), f"hold-out: the last file{name} left out of estimation"
    est_u, est_y, val_skips = [], [], []
    for k, (x, v) in enumerate(zip(us, ys)):
        n = len(v)
        cut = skip + int(round((1.0 - HOLDOUT_FRACTION) * (n - skip)))
        if n - cut < MIN_SCORED or cut - skip < 10:
            where = f"{names[k]}: " if names else ""
            raise InputError(
                f"{where}the hold-out (last 25 % of {max(n - skip, 0)} samples) is too short to score "
                f"(need >= {MIN_SCORED} samples); give validation data"
            )
        est_u.append(x[:cut])
        est_y.append(v[:cut])
        val_skips.append(cut)
    return est_u, est_y, (us, ys, val_skips), "hold-out: the last 25 % of every file left out of estimation"


def decimate(u, y, factor: int, skip=0):
    """Records decimated by ``factor`` through an anti-alias filter.

    scipy.signal.resample_poly: a zero-phase FIR low-pass at the new Nyquist frequency (Kaiser
    window, beta 5), the record ends extended by a line so that a record starting at rest or at
    an offset gets no edge transient; inputs and outputs alike, so their relation is kept below
    the new Nyquist frequency. ``skip`` (a number or one per record) becomes ceil(skip / factor).

    Returns
    -------
    (inputs, outputs, skip)
    """
    factor = int(factor)
    if factor < 1:
        raise InputError(f"decimation factor must be >= 1, not {factor}")
    us, ys = _records(u, y)
    if factor == 1:
        return us, ys, skip
    if min(len(v) for v in ys) < 20 * factor:
        raise InputError(f"decimating by {factor} leaves fewer than 20 samples in a record")

    def down(x):
        return resample_poly(x, 1, factor, axis=0, window=("kaiser", 5.0), padtype="line")

    out_u = [down(x) for x in us]
    out_y = [down(v[:, None] if v.ndim == 1 else v) for v in ys]
    out_y = [v[:, 0] if v.shape[1] == 1 and ys[0].ndim == 1 else v for v in out_y]
    new_skip = [int(np.ceil(k / factor)) for k in skip] if isinstance(skip, (list, tuple)) else -(-int(skip) // factor)
    return out_u, out_y, new_skip


def _records(u, y):
    """Inputs as (N, n_in) arrays and outputs as (N,) or (N, n_out) arrays, one per record."""
    us = as_recordings(u)[0]
    ys = y if isinstance(y, (list, tuple)) else [y]
    ys = [np.asarray(v, dtype=float) for v in ys]
    if len(ys) != len(us) or any(len(a) != len(b) for a, b in zip(us, ys)):
        raise InputError("u and y need the same number of recordings and of samples in each")
    if any(v.ndim not in (1, 2) for v in ys):
        raise InputError("every output record must be (N,) or (N, n_outputs)")
    return us, ys


def _column(ys, j: int) -> list:
    return [v if v.ndim == 1 else v[:, j] for v in ys]


def identify(
    *,
    u,
    y,
    ts: float,
    validation=None,
    options: SearchOptions | None = None,
    inputs=None,
    outputs=None,
    input_unit=None,
    output_units=None,
    smoothness="auto",
    decimate_by: int = 1,
    record_names=None,
    executor=None,
    progress=True,
    log=None,
    **overrides,
) -> Identification:
    """Identify one model per output column, the way ``porosense identify`` does.

    Parameters
    ----------
    u : list of arrays
        Inputs (N, n_in) per recording, data units (at most 3 inputs).
    y : list of arrays
        Outputs (N,) or (N, n_outputs) per recording, data units.
    ts : float
        Sample period of the records in s.
    validation : tuple, optional
        (inputs, outputs) or (inputs, outputs, skips) of validation records; None: a hold-out
        (:func:`holdout`).
    options : SearchOptions, optional
        The search's options (default ``porosense identify``'s); fields may also be given as
        keywords (``poles=(4,)``), overriding them. ``options.skip`` is where scoring starts in
        every record.
    inputs, outputs : names of the input and output columns.
    input_unit, output_units : units stored in the models.
    smoothness : "auto" or float
        "auto": the selected nonlinear model is refined with the weights 1e-4, 1e-3, 1e-2 and
        the best on validation is kept (unless its process-noise level was measured); a number
        fixes the weight of every candidate.
    decimate_by : int
        Decimate every record by this factor first (:func:`decimate`); the models' sample period
        is then ``ts * decimate_by``.
    record_names : list of str, optional
        Names of the records (file names), for the messages.
    executor, progress : as :func:`porosense.ident.search`; one local pool serves every output.
    log : callable, optional
        Receives one line per step (hold-out, smoothness); None: silent.
    **overrides
        SearchOptions fields replacing those of ``options`` (an unknown name is an InputError).

    Returns
    -------
    Identification
    """
    say = log or (lambda line: None)
    opts = SearchOptions.with_overrides(options, **overrides)
    if smoothness != "auto":
        try:
            weight = float(smoothness)
        except (TypeError, ValueError):
            raise InputError(f"smoothness must be 'auto' or a weight >= 0, not {smoothness!r}") from None
        if not weight >= 0:
            raise InputError(f"smoothness must be 'auto' or a weight >= 0, not {smoothness!r}")
        opts = SearchOptions.with_overrides(opts, smoothness=weight)
    us, ys = _records(u, y)
    notes = []
    skip = opts.skip
    if int(decimate_by) != 1:
        us, ys, skip = decimate(us, ys, decimate_by, skip)
        if validation is not None:
            vskip = validation[2] if len(validation) > 2 else opts.validation_skip
            vu, vy, vskip = decimate(validation[0], validation[1], decimate_by, vskip)
            validation = (vu, vy, vskip)
        notes.append(
            f"decimated by {int(decimate_by)} (anti-alias FIR, zero phase): sample period {ts * int(decimate_by):g} s"
        )
        ts = ts * int(decimate_by)
        opts = SearchOptions.with_overrides(opts, skip=int(skip))
    if validation is None:
        est_u, est_y, val, how = holdout(us, ys, opts.skip, record_names)
    else:
        vu, vy = validation[0], validation[1]
        vskips = validation[2] if len(validation) > 2 else opts.validation_skip
        est_u, est_y = us, ys
        vu_r, vy_r = _records(vu, vy)
        val = (vu_r, vy_r, skips_of(vskips, len(vy_r)))
        how = opts.holdout or "validation data given"
    say(how)
    opts = SearchOptions.with_overrides(opts, holdout=how, validation_skip=tuple(val[2]))
    n_out = 1 if est_y[0].ndim == 1 else est_y[0].shape[1]
    names = tuple(outputs) if outputs is not None else tuple(f"y{j}" if n_out > 1 else "y" for j in range(n_out))
    if len(names) != n_out:
        raise InputError(f"{len(names)} output name(s) for {n_out} output column(s)")
    units = list(output_units) if output_units is not None else [None] * n_out
    own = executor is None and len(opts.order_grid()) > 1
    cluster = Cluster.resolve(executor, tasks=len(opts.order_grid())) if own else None
    pool = cluster.executor if cluster is not None else executor
    models, results, choices = [], [], []
    interrupted = True
    try:
        for j, name in enumerate(names):
            result = search(
                u=est_u,
                y=_column(est_y, j),
                ts=ts,
                validation=(val[0], _column(val[1], j)),
                options=opts,
                executor=pool,
                progress=progress,
                inputs=inputs,
                output=name,
                input_unit=input_unit,
                output_unit=units[j],
            )
            model, choice = result.model, None
            measured = (result.model.info.get("process_noise") or {}).get("method") == "repeated periods"
            if measured:
                # Validation data carry the same process noise: they cannot choose g's smoothness
                # (a smoother g validates alike), so the noise fit's own weight stays.
                say(
                    f"smoothness weight {result.model.info['process_noise']['smoothness']:g} kept: the process-noise "
                    "level was measured, and validation data carrying the same noise cannot choose the weight"
                )
            elif smoothness == "auto" and not opts.smoothness and result.best.structure != "linear":
                choice = choose_smoothness(
                    result,
                    u=est_u,
                    y=_column(est_y, j),
                    validation=(val[0], _column(val[1], j)),
                    validation_skip=list(val[2]),
                    monotone=opts.monotone,
                )
                assert choice.model is not None  # choose_smoothness always returns a model
                model = choice.model
            models.append(model)
            results.append(result)
            choices.append(choice)
        interrupted = False
    finally:
        if cluster is not None:
            cluster.close(interrupted)
        elif interrupted and executor is not None and not hasattr(executor, "scatter"):
            stop(executor)
    return Identification(models, results, choices, names, how, notes, ts)
