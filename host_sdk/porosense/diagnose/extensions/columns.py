"""The causes of a record's condition columns: the column tests (:func:`_column_tests`),
load_dependence (with the simulator's own load effect, :data:`SIM_LOAD_COLUMN`) and cross_coupling.
"""

from __future__ import annotations

import numpy as np

from porosense.diagnose import signals, stats
from porosense.diagnose.extensions.context import CauseResult, Context, _explained, _simulated
from porosense.diagnose.extensions.static import _static_sets


def _condition_columns(ctx: Context) -> list:
    names = list(ctx.est[0].conditions)
    cols = []
    for name in names:
        x = np.concatenate([r.conditions[name] for r in ctx.est])
        if np.std(x) > 0:
            cols.append((name, float(np.mean(x)), float(np.std(x))))
    return cols


def _column_tests(ctx: Context) -> dict:
    """Per varying condition column: F of its dynamics (additive) and of its interaction with the
    model output beyond those dynamics (a gain that changes with the column)."""
    if "columns" in ctx._cache:
        return ctx._cache["columns"]
    out = {}
    m, s = float(np.mean(ctx.yhat_est)), float(np.std(ctx.yhat_est)) or 1.0
    knots_out = signals.quantile_knots(ctx.yhat_est, 5)
    for name, mu, sd in _condition_columns(ctx):

        def z_dyn(r, name=name, mu=mu, sd=sd):
            # the column's dynamics, and the same relative to the record's start (dR is taken
            # relative to R0 at the start of every record: what leaks in is zeroed there too)
            bank = ctx.lag_bank((r.conditions[name] - mu) / sd, 3)
            return np.column_stack([bank, bank - bank[0]])

        def z_gain(r, name=name, mu=mu, sd=sd):
            return ((r.conditions[name] - mu) / sd * (r.yhat - m) / s)[:, None]

        lo = float(np.min(np.concatenate([r.conditions[name] for r in ctx.est])))

        def z_sched(r, name=name, lo=lo, sd=sd):
            # the gain scheduled by the column at every output level: the column times a PWL
            # map of the model output (a load shifts where along its stroke the actuator
            # collapses, not only its overall gain)
            c = (r.conditions[name] - lo) / sd  # from the smallest value: zero load changes nothing
            cols = [c * (r.yhat - m) / s] + [c * h / s for h in signals.hinge_basis(r.yhat, knots_out).T]
            return np.column_stack(cols)

        def z_load(r, name=name, lo=lo, sd=sd, z_sched=z_sched):
            return np.column_stack([(r.conditions[name] - lo) / sd, z_sched(r)])

        dyn = ctx.f_test(ctx.stack(z_dyn, ctx.est))
        inter = ctx.f_test(ctx.stack(z_gain, ctx.est), extra_base=ctx.stack(z_dyn, ctx.est))
        Zd, Zs = ctx.stack(z_dyn, ctx.est), ctx.stack(z_sched, ctx.est)
        both = ctx.f_test(ctx.stack(z_load, ctx.est))
        # load-specific: beyond the column's additive dynamics and any static map of the level
        static = _static_sets(ctx)
        Zst = np.column_stack([ctx.stack(z, ctx.est) for z in static.values()])
        sched = ctx.f_test(Zs, extra_base=np.column_stack([Zd, Zst]))
        out[name] = {
            "dyn": dyn,
            "inter": inter,
            "both": both,
            "sched": sched,
            "z_dyn": z_dyn,
            "z_gain": z_gain,
            "z_load": z_load,
        }
    ctx._cache["columns"] = out
    return out


def _no_columns(alpha: float, name: str) -> CauseResult:
    res = stats.StatResult(name, 0.0, np.inf, 1.0, alpha)
    return CauseResult(res, False, "no varying condition column was given", "none", None)


def _of_kind(ctx: Context, cols: dict, other: str) -> dict:
    """The column tests of ``cols`` whose column is not stated to be of kind ``other``
    (porosense.diagnose.Record.column_kinds): a load is no leak of another channel's command,
    and a command no condition that changes the gain."""
    kinds = ctx.est[0].column_kinds
    return {k: v for k, v in cols.items() if kinds.get(k) != other}


#: the load column a simulator's recording carries (g; porosense.sim.experiment writes it)
SIM_LOAD_COLUMN = "load_g"


def _simulator_load_dependence(ctx: Context, alpha: float) -> CauseResult:
    """load_dependence of records from a calibrated simulator whose load column varies: the
    simulator's own effect (porosense.sim.effects: the load changes during a record), each
    record's calibrated simulation run again with its measured load column
    (porosense.diagnose.calibrate.Simulation.load_dependence), less itself. The load is measured,
    so the effect has no parameter to search: the test is F of that change beyond the corrected
    model, the extension its share (each record's recording state refitted beside it)."""
    name = SIM_LOAD_COLUMN

    def z(r):
        return r.simulation.load_dependence(r.conditions[name])[:, None]

    Z = ctx.stack(z, ctx.est)
    res = stats.f_result(f"F(residual ~ the simulator's load_dependence effect of {name})", ctx.f_test(Z), alpha, 1)
    pred, _ = ctx.fit_apply(z)
    return CauseResult(
        res,
        True,
        f"the residual follows what the simulator predicts of the measured load {name} ({_explained(res)})",
        f"the simulator's load_dependence effect of the measured {name}",
        pred,
        {"column": name, "n_params": 1},
        Z_est=Z,
    )


def _simulator_load(ctx: Context) -> bool:
    """Whether the records come from a calibrated simulator and carry its load column, stated no
    input (porosense.diagnose.engine.Record.column_kinds), varying on the estimation records."""
    if not _simulated(ctx) or any(SIM_LOAD_COLUMN not in r.conditions for r in ctx.est + ctx.val):
        return False
    if ctx.est[0].column_kinds.get(SIM_LOAD_COLUMN) == "input":
        return False
    return float(np.std(np.concatenate([r.conditions[SIM_LOAD_COLUMN] for r in ctx.est]))) > 0


def load_dependence(ctx: Context, alpha: float) -> CauseResult:
    """Test and extension of a dependence on a measured condition (a load, g, or any column
    stated a condition).

    Records of a calibrated simulator with a load column: the simulation run again with the
    measured load. Otherwise: F of the residual on the column and the column times the model
    output (a load-scheduled gain); the extension adds both to the nominal."""
    if _simulator_load(ctx):
        return _simulator_load_dependence(ctx, alpha)
    cols = _of_kind(ctx, _column_tests(ctx), "input")
    if not cols:
        return _no_columns(alpha, "F(residual ~ column and column x output)")
    name = min(cols, key=lambda k: cols[k]["both"].log10_p)
    c = cols[name]
    res = stats.f_result(f"F(residual ~ {name} and {name} x output)", c["both"], alpha, len(cols), column=name)
    inter = stats.f_result("interaction", c["sched"], alpha, len(cols))
    pred, _ = ctx.fit_apply(c["z_load"])
    return CauseResult(
        res,
        True,
        f"the residual depends on the measured column {name}, and the "
        f"model's gain changes with it (interaction F = {c['sched'].f:.3g}, p = {inter.p:.2g}; "
        f"{_explained(res)})",
        f"{name} as an extra input and a {name}-scheduled gain",
        pred,
        {"column": name},
        Z_est=ctx.stack(c["z_load"], ctx.est),
        n_search=len(cols),
    )


def _leak_before_map(ctx: Context, cols: dict, leaking: list, z_add):
    """A leak of other channels' commands that enters before the sensor's static map (a column
    stated an input, porosense.diagnose.Record.column_kinds: another channel's strain into this
    one's contact strain). With the map g and the channel's own contact strain x, the output is
    g(x + l) = g(x) + g'(x) l to first order in the leak l: the leak's dynamics (the columns' own
    Laguerre banks, as the additive leak) scaled by the map's slope at the operating point, whose
    first-order expansion in the output level is a + b (yhat - mean) / sd. The nominal fitted to
    records that carry the leak has its own level map bent by it (its calibration took part of
    g'(x) l for g(x)): a static PWL of the output level (static_nonlinearity's output-side map)
    enters the extension too, and the leak must gain beyond that map alone (the rival).

    Returns (builder of the extension's regressors, detail entries: the rival's validation
    prediction and its name)."""
    m, s = float(np.mean(ctx.yhat_est)), float(np.std(ctx.yhat_est)) or 1.0
    static = _static_sets(ctx)["output"]
    n_bank = 3  # the leak's own dynamics: the first half of each column's z_dyn (its Laguerre bank)

    def z(r):
        banks = np.column_stack([cols[k]["z_dyn"](r)[:, :n_bank] for k in leaking])
        return np.column_stack([z_add(r), banks * ((r.yhat - m) / s)[:, None], static(r)])

    rival, _ = ctx.fit_apply(static)
    return z, {"rival_val": rival, "rival": "static_nonlinearity's extension (a static PWL on the output side)"}


def cross_coupling(ctx: Context, alpha: float) -> CauseResult:
    """Test and extension of a coupling from another channel (a column the model does not use).

    Test: F of the residual on the column's dynamics (a Laguerre bank), the strongest column at
    alpha / columns. Extension: the dynamics of every column that holds at that level; a column
    stated an input leaks before the sensor's static map (scaled by the map's slope)."""
    cols = _of_kind(ctx, _column_tests(ctx), "condition")
    if not cols:
        return _no_columns(alpha, "F(residual ~ filtered unused input)")
    name = min(cols, key=lambda k: cols[k]["dyn"].log10_p)
    c = cols[name]
    res = stats.f_result(f"F(residual ~ dynamics of unused input {name})", c["dyn"], alpha, len(cols), column=name)
    # a channel can leak from every neighbour: the extension takes each column whose own test
    # holds at the same level (alpha / columns), the strongest always
    leaking = [k for k in cols if k == name or stats.f_result(k, cols[k]["dyn"], alpha, len(cols)).significant]

    stated = ctx.est[0].column_kinds.get(name) == "input"

    def z_add(r, leaking=leaking):
        return np.column_stack([cols[k]["z_dyn"](r) for k in leaking])

    z_leak, detail = z_add, {}
    if stated:
        z_leak, detail = _leak_before_map(ctx, cols, leaking, z_add)
    inter = stats.f_result("interaction", c["inter"], alpha, len(cols))
    pred, _ = ctx.fit_apply(z_leak)
    # a leak adds to the output: a column that changes the model's gain (an interaction with the
    # output beyond the column's own dynamics, at the same level as the test) is a dependence on
    # a condition, which load_dependence names. A column stated an input (Record.column_kinds) is
    # no condition: its leak enters before the sensor's static map (another channel's strain into
    # this one's contact strain), whose slope changes with the operating point, so an interaction
    # is what such a leak shows and is no evidence against it
    additive = stated or not inter.significant
    named = ", ".join(leaking)
    return CauseResult(
        res,
        True,
        f"the residual follows the unused input{'s' if len(leaking) > 1 else ''} {named} through "
        f"dynamics (interaction of {name} with the output F = {c['inter'].f:.3g}, p = {inter.p:.2g}"
        + ("; the column is stated an input" if stated else ", additively")
        + f"; {_explained(res)})",
        f"{named} as extra MISO input{'s' if len(leaking) > 1 else ''}"
        + (
            ", scaled by the slope of the sensor's map at the output level, with a static PWL on the output side"
            if stated
            else ""
        ),
        pred,
        {
            **detail,
            "column": name,
            "columns": leaking,
            "evidence_ok": additive,
            "evidence_note": ""
            if additive
            else f"{name} changes the model's gain (interaction with the output F = {c['inter'].f:.3g}, "
            f"p = {inter.p:.2g}): a dependence on a condition, not an additive leak",
        },
        Z_est=ctx.stack(z_leak, ctx.est),
        n_search=len(cols),
    )
