"""The settings of an order search, in one object with the command line's defaults.

``porosense identify`` and :func:`porosense.ident.search` / :func:`porosense.ident.identify` read
the same :class:`SearchOptions`, so the same data and the same defaults give the same model.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields, replace

from porosense.errors import InputError
from porosense.ident.models import KINDS, MAX_BREAKPOINTS

STRUCTURES = tuple(KINDS)
CRITERIA = ("paper", "fit", "aic", "bic")
MAX_POLES = 10  # the paper searches 1..10 poles
# Estimation samples (scored) beyond which candidates are screened on a subset of the records
# and only the finalists are refined on all of them (screening.py says why this size).
SCREEN_SAMPLES = 30_000


@dataclass(frozen=True)
class SearchOptions:
    """How an order search runs (defaults: those of ``porosense identify``).

    Parameters
    ----------
    structures : tuple of str
        Model structures searched: linear, hammerstein, wiener, wh.
    poles : tuple of int
        Pole counts searched (zeros < poles).
    zeros : tuple of int or None
        Zero counts searched (None: all of 0..poles - 1).
    grid : tuple or None
        An explicit list of (structure, n_poles, n_zeros) instead of structures/poles/zeros.
    n_breakpoints : int
        Breakpoints of every piecewise-linear map (2..64).
    delay : int
        Input delay in samples.
    starts : int
        Starts per nonlinear model (the paper uses 2).
    max_nfev : int
        Residual evaluations per refinement (the paper: 200).
    skip : int
        Leading samples of every estimation recording simulated but not scored.
    validation_skip : int or tuple of int
        The same for the validation recordings (one number or one per recording).
    criterion : str
        ``fit`` (validation NRMSE fit, the default), ``paper`` (mean fit over estimation and
        validation recordings), ``aic`` or ``bic``.
    tie_tol : float
        Smallest tie band of the fit criteria, in fit points.
    staged : bool
        Linear orders first, then the nonlinear structures at the ``staged_orders`` best linear
        orders (and the one the tie rule picks) only.
    staged_orders : int
        See ``staged``.
    smoothness : float
        Weight of the smoothness penalty on the breakpoint values (dimensionless, 0: none).
    monotone : bool
        Constrain the static maps to be monotone.
    process_noise : bool
        Refit the best Wiener and WH candidates with a Gaussian noise at g's input.
    constraint : callable or None
        ``constraint(structure) -> bool``: candidates it refuses are never selected.
    size_fn : callable or None
        ``size_fn(structure) -> bytes``, with ``max_bytes`` a device budget.
    max_bytes : int or None
        See ``size_fn``.
    screen_samples : int
        Scored estimation samples beyond which candidates are fitted on a subset of that size
        and only the finalists are refined on all samples (0: never).
    holdout : str
        How the validation data were made (reported with the selection rule).
    """

    structures: tuple = STRUCTURES
    poles: tuple = tuple(range(1, MAX_POLES + 1))
    zeros: tuple | None = None
    grid: tuple | None = None
    n_breakpoints: int = 10
    delay: int = 0
    starts: int = 2
    max_nfev: int = 200
    skip: int = 0
    validation_skip: int | tuple = 0
    criterion: str = "fit"
    tie_tol: float = 0.01
    staged: bool = True
    staged_orders: int = 2
    smoothness: float = 0.0
    monotone: bool = False
    process_noise: bool = False
    constraint: Callable | None = None
    size_fn: Callable | None = None
    max_bytes: int | None = None
    screen_samples: int = SCREEN_SAMPLES
    holdout: str = ""

    def __post_init__(self):
        for name in ("structures", "poles", "zeros", "grid", "validation_skip"):
            value = getattr(self, name)
            if value is not None and not isinstance(value, (int, str, tuple)):
                object.__setattr__(self, name, tuple(tuple(v) if name == "grid" else v for v in value))
        if self.criterion not in CRITERIA:
            raise InputError(f"unknown criterion {self.criterion!r}; choose from {', '.join(CRITERIA)}")
        if not 2 <= self.n_breakpoints <= MAX_BREAKPOINTS:
            raise InputError(f"n_breakpoints must be 2..{MAX_BREAKPOINTS}")
        if self.max_nfev < 1 or self.starts < 1 or self.delay < 0 or self.skip < 0:
            raise InputError("max_nfev and starts must be >= 1, delay and skip >= 0")
        if self.screen_samples < 0:
            raise InputError("screen_samples must be >= 0")

    @classmethod
    def with_overrides(cls, options: SearchOptions | None = None, **overrides) -> SearchOptions:
        """Options with named fields replaced.

        Parameters
        ----------
        options : SearchOptions or None
            The options to start from (None: the defaults).
        **overrides
            Field name to value (``poles=(4,)``, ``criterion="bic"``, ...).

        Returns
        -------
        SearchOptions
            The copy.

        Raises
        ------
        InputError
            An unknown field name (the message lists the known ones) or a bad value.
        """
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(overrides) - names)
        if unknown:
            raise InputError(f"unknown search option(s) {', '.join(unknown)}; known: {', '.join(sorted(names))}")
        return replace(options or cls(), **overrides)

    def order_grid(self) -> list[tuple[str, int, int]]:
        """The (structure, n_poles, n_zeros) to estimate: ``grid``, or every structure, pole count and
        zero count < poles (0 poles: the static models).

        Returns
        -------
        list of (str, int, int)
            The grid.

        Raises
        ------
        InputError
            Orders that leave no model to estimate.
        """
        grid = list(self.grid) if self.grid is not None else order_grid(self.structures, self.poles, self.zeros)
        if not grid:
            raise InputError("the orders given leave no model to estimate (zeros must be < poles)")
        return grid


def order_grid(structures=STRUCTURES, poles=range(1, MAX_POLES + 1), zeros=None) -> list[tuple[str, int, int]]:
    """(structure, n_poles, n_zeros) for every structure, pole count and zero count < poles.

    Parameters
    ----------
    structures : sequence of str
        Structures (default all four).
    poles : iterable of int
        Pole counts (default 1..10, the paper's); 0 gives each structure's static model (0 poles,
        0 zeros).
    zeros : iterable of int or None
        Zero counts allowed (still < poles); None: all of 0..n_poles-1.

    Returns
    -------
    list of (str, int, int)
        The grid, structure by structure.

    Raises
    ------
    InputError
        An unknown structure.
    """
    grid = []
    for s in structures:
        if s not in KINDS:
            raise InputError(f"unknown structure {s!r}; choose from {', '.join(KINDS)}")
        for p in poles:
            if p == 0:
                grid.append((s, 0, 0))
                continue
            for z in range(p):
                if zeros is None or z in zeros:
                    grid.append((s, int(p), int(z)))
    return grid
