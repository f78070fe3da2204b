"""One set of defaults: the Python API searches as ``porosense identify`` does, and a model always
carries its sample period."""

import argparse
import inspect
import json

import numpy as np
import pytest

from porosense import ident
from porosense.cli import identify as cli_identify
from porosense.errors import InputError


def _cli_defaults():
    parser = argparse.ArgumentParser()
    cli_identify.register(parser.add_subparsers())
    return parser.parse_args(["identify", "--data", "x.csv", "--input", "u", "--output", "y"])


def test_search_options_default_to_the_command_lines():
    args, opts = _cli_defaults(), ident.SearchOptions()
    assert opts.criterion == args.criterion == "fit"
    assert opts.max_nfev == args.max_iter == 200
    assert opts.starts == args.starts == 2
    assert opts.n_breakpoints == args.breakpoints == 10
    assert opts.delay == args.delay == 0
    assert opts.poles == tuple(range(1, args.max_poles + 1))
    assert opts.zeros is None and args.zeros is None
    assert opts.structures == tuple(ident.KINDS) and args.structure == "all"
    # The CLI stages its search unless an order is fixed or --full-grid is given.
    assert opts.staged is (args.poles is None and not args.full_grid) is True
    assert opts.monotone is args.monotone is False and opts.process_noise is args.process_noise is False
    assert inspect.signature(ident.identify).parameters["smoothness"].default == args.smoothness == "auto"
    assert args.decimate == inspect.signature(ident.identify).parameters["decimate_by"].default == 1


def test_search_takes_its_options_from_one_object_or_keywords():
    opts = ident.SearchOptions(poles=(2,), criterion="aic")
    assert ident.SearchOptions.with_overrides(opts, starts=1) == ident.SearchOptions(
        poles=(2,), criterion="aic", starts=1
    )
    with pytest.raises(InputError, match="unknown search option.*n_pole"):
        ident.SearchOptions.with_overrides(opts, n_pole=3)
    with pytest.raises(InputError, match="criterion"):
        ident.SearchOptions(criterion="best")
    assert ident.SearchOptions(poles=[0], structures=["linear"]).order_grid() == [("linear", 0, 0)]


def test_fit_requires_a_sample_period():
    rng = np.random.default_rng(0)
    u = rng.standard_normal((200, 1))
    y = np.convolve(u[:, 0], [0.5, 0.3])[:200]
    with pytest.raises(TypeError, match="ts"):
        ident.Linear(n_poles=1, n_zeros=0).fit(u=u, y=y)
    for bad in (0.0, -0.01, float("nan"), "0.02", True):
        with pytest.raises(InputError, match="ts must be"):
            ident.Linear(n_poles=1, n_zeros=0).fit(u=u, y=y, ts=bad)
    m = ident.Linear(n_poles=1, n_zeros=0).fit(u=u, y=y, ts=0.02)
    assert m.ts == 0.02 and json.loads(json.dumps(m.to_dict()))["ts"] == 0.02


def test_python_and_the_command_line_give_the_same_model(tmp_path, truth, make_recordings):
    """The same files through ``porosense identify`` and through ``ident.identify`` (no validation
    given: the hold-out of the last file) give the same model, parameter for parameter."""
    from porosense.cli import main

    system = truth("wiener")
    us, ys, _ = make_recordings(system, 500, seeds=(41, 42, 43))
    paths = []
    for k, (u, y) in enumerate(zip(us, ys)):
        p = tmp_path / f"rec{k}.csv"
        t = np.arange(len(y)) * system.ts
        lines = ["t_s,dR_0,strain_0"] + [
            f"{a!r},{b!r},{c!r}" for a, b, c in zip(t.tolist(), u[:, 0].tolist(), y.tolist())
        ]
        p.write_text("\n".join(lines) + "\n")
        paths.append(str(p))
    common = dict(structures=("linear", "wiener"), poles=(1, 2), n_breakpoints=5, max_nfev=40)
    rc = main(
        ["identify", "--data", *paths, "--input", "dR_0", "--output", "strain_0", "--structure", "all"]
        + ["--max-poles", "2", "--breakpoints", "5", "--max-iter", "40", "--quiet", "--out", str(tmp_path / "m.json")]
    )
    assert rc == 0
    from_cli = ident.load_model(tmp_path / "m.json")
    found = ident.identify(
        u=us,
        y=ys,
        ts=system.ts,
        inputs=("dR_0",),
        outputs=("strain_0",),
        progress=False,
        **{**common, "structures": tuple(ident.KINDS)},
    )
    assert found.holdout.startswith("hold-out: the last file")
    assert (from_cli.kind, from_cli.n_poles, from_cli.n_zeros) == (
        found.model.kind,
        found.model.n_poles,
        found.model.n_zeros,
    )
    assert np.array_equal(from_cli.theta, found.model.theta)
    assert from_cli.ts == pytest.approx(found.model.ts, rel=1e-12) and found.model.ts == system.ts
