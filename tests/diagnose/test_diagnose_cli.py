"""``porosense diagnose`` end to end: CSV files in, OUT.json and a report directory out."""

from __future__ import annotations

import json

import numpy as np

from porosense import sim
from porosense.cli import main
from porosense.diagnose import CAUSES, NONE, Finding, trials

KEYS = set(Finding.KEYS)


def _write_sim(tmp_path, effects):
    files = []
    for k, exp in enumerate(("staircase", "step_40", "step_60")):
        rec = sim.run_experiment("contractor", exp, rate_hz=20, seed=k + 1, effects=effects)
        path = tmp_path / f"{exp}.csv"
        rec.to_csv(path)
        files.append(str(path))
    return files


def test_cli_sim_finds_a_hidden_periodic_disturbance_and_writes_the_report(tmp_path, capsys):
    files = _write_sim(tmp_path, {"periodic_disturbance": {"amplitude_pct": 2.0, "freq_hz": 3.1}})
    out = tmp_path / "diag.json"
    rc = main(
        [
            "diagnose",
            "--data",
            *files,
            "--input",
            "p_cmd_0",
            "--output",
            "dR_0",
            "--ts",
            "0.05",
            "--sim",
            "contractor",
            "--condition",
            "load_g",
            "--json-out",
            str(out),
            "--out",
            str(tmp_path / "rep"),
        ]
    )
    assert rc == 0
    doc = json.loads(out.read_text())
    assert {"top", "nominal", "corrected", "dynamics", "why_top", "ranking_rule", "baselines", "findings"} <= set(doc)
    assert doc["top"] == "periodic_disturbance"
    assert [f["cause"] for f in doc["findings"]][0] == doc["top"]
    assert {f["cause"] for f in doc["findings"]} == set(CAUSES) | {NONE}
    for f in doc["findings"]:
        assert set(f) == KEYS and 0.0 <= f["confidence"] <= 1.0
        assert f["statistic"].split(" = ")[0] in f["evidence"]
    top = doc["findings"][0]
    assert top["gain"] > 0 and "3.1" in top["evidence"]
    for name in ("correlations.png", "level_direction.png", "spectrum.png", "fits.png", "summary.md"):
        assert (tmp_path / "rep" / name).stat().st_size > 500
    assert "periodic_disturbance" in (tmp_path / "rep" / "summary.md").read_text()


def test_cli_baseline_and_model_paths(tmp_path):
    rng = np.random.default_rng(5)
    plant = trials.draw_plant(rng, "time_delay")
    path = tmp_path / "data.csv"
    rec = plant.record(rng, 120.0)
    cols = {"p_cmd_0": rec.u[:, 0], "dR_0": rec.y, **rec.conditions}
    np.savetxt(path, np.column_stack(list(cols.values())), delimiter=",", header=",".join(cols), comments="")
    out = tmp_path / "base.json"
    rc = main(
        [
            "diagnose",
            "--data",
            str(path),
            "--input",
            "p_cmd_0",
            "--output",
            "dR_0",
            "--ts",
            str(trials.TS),
            "--baseline",
            "linear",
            "--poles",
            "1",
            "--zeros",
            "0",
            "--condition",
            "p_cmd_1",
            "load_g",
            "--estimation",
            "0:1440",
            "--validation",
            "1440:",
            "--json-out",
            str(out),
        ]
    )
    assert rc == 0
    assert json.loads(out.read_text())["top"] == "time_delay"

    from porosense import ident

    model = ident.make_model("linear", n_poles=1, n_zeros=0).fit(
        u=[rec.u[:1440]], y=[rec.y[:1440]], ts=trials.TS, inputs=["p_cmd_0"], output="dR_0"
    )
    model.save(tmp_path / "m.json")
    out2 = tmp_path / "model.json"
    rc = main(
        [
            "diagnose",
            "--data",
            str(path),
            "--input",
            "p_cmd_0",
            "--output",
            "dR_0",
            "--ts",
            str(trials.TS),
            "--model",
            str(tmp_path / "m.json"),
            "--estimation",
            "0:1440",
            "--validation",
            "1440:",
            "--json-out",
            str(out2),
        ]
    )
    assert rc == 0
    assert json.loads(out2.read_text())["top"] == "time_delay"


def test_cli_errors_are_one_line(tmp_path, capsys):
    path = tmp_path / "d.csv"
    path.write_text("a,b\n" + "\n".join(f"{i},{i}" for i in range(100)) + "\n")
    rc = main(
        [
            "diagnose",
            "--data",
            str(path),
            "--input",
            "a",
            "--output",
            "nope",
            "--ts",
            "0.1",
            "--baseline",
            "linear",
            "--json-out",
            str(tmp_path / "o.json"),
        ]
    )
    err = capsys.readouterr().err
    assert rc == 2 and "no column 'nope'" in err and "Traceback" not in err


def _clean_lag(rng, n=1500):
    """An independent clean plant: a random staircase through one or two real poles (scipy), white
    noise of 0.2-2 % of the output's range; the record starts with its first level as a step."""
    from scipy import signal

    order = int(rng.integers(1, 3))
    poles = rng.uniform(0.75, 0.95, order)
    den = np.poly(poles)
    gain = rng.uniform(0.2, 2.0)
    u = np.repeat(rng.uniform(-80, 0, n // 50), 50)
    y = signal.lfilter([gain * np.sum(den)], den, -u)
    return order, u, y + rng.normal(0, rng.uniform(0.002, 0.02) * np.ptp(y), n)


def test_a_true_order_model_on_clean_records_is_diagnosed_none(tmp_path, capsys):
    """The model of the right order on clean records, one file split 60/40: nothing is wrong, and
    the diagnosis must say so. The model starts each record as its first samples show (here the
    estimation part at rest, its first level a step): started settled at that level instead, the
    transient it left in the residual was named outliers in 3 of 10 second-order records. Bound: at least 19 of 20 named none (the issue's 95 %; with
    the tests at 1 % family-wise a false finding has about 1 % a trial, P(2 or more in 20) = 1.7 %)."""
    from porosense import ident

    rng = np.random.default_rng(20261128)
    named = []
    for k in range(20):
        order, u, y = _clean_lag(rng)
        t = np.arange(len(u)) / 50.0
        data = tmp_path / f"clean_{k}.csv"
        np.savetxt(data, np.column_stack([t, u, y]), delimiter=",", header="t,dR_0,strain_0", comments="")
        model = tmp_path / f"model_{k}.json"
        ident.make_model("linear", n_poles=order, n_zeros=0).fit(
            u=u[:, None], y=y, ts=0.02, inputs=("dR_0",), output="strain_0"
        ).save(model)
        out = tmp_path / f"diag_{k}.json"
        argv = ["diagnose", "--model", model, "--data", data, "--input", "dR_0", "--output", "strain_0"]
        assert main([str(a) for a in [*argv, "--json-out", out]]) == 0
        capsys.readouterr()
        named.append(json.loads(out.read_text())["top"])
    wrong = [(k, c) for k, c in enumerate(named) if c != NONE]
    print(f"\nclean records named none: {20 - len(wrong)} of 20; named: {wrong}")
    assert len(wrong) <= 1, wrong


def test_cli_sim_segment_is_driven_by_all_its_commands(tmp_path, capsys):
    """A clean 3-DoF segment diagnosed on one contractor (--input p_cmd_0) with the others'
    commands as conditions: the simulator is driven by all three recorded commands (a segment's
    contractors move one another), so it follows its own clean records and the neighbours'
    commands explain nothing more. Driven by p_cmd_0 alone (measured before the fix) the
    nominal's validation fit was 85 % and cross_coupling's test F = 19-21 on every seed tried."""
    files = []
    for k, exp in enumerate(("sequential_60", "two_level", "sequential_40")):
        rec = sim.run_experiment("3dof", exp, porosity=76.0, rate_hz=20, seed=3100 + k)
        path = tmp_path / f"{exp}.csv"
        rec.to_csv(path)
        files.append(str(path))
    out = tmp_path / "diag.json"
    args = ["diagnose", "--data", *files, "--input", "p_cmd_0", "--output", "dR_0", "--ts", "0.05"]
    rc = main([*args, "--sim", "3dof", "--condition", "p_cmd_1", "p_cmd_2", "--json-out", str(out)])
    assert rc == 0
    doc = json.loads(out.read_text())
    cc = next(f for f in doc["findings"] if f["cause"] == "cross_coupling")
    assert doc["top"] == NONE, (doc["top"], cc["statistic"], cc["gain"])
    # what is left is the recording's noise and state: 95 % is 10 points above the fit without
    # the segment's mechanics
    assert doc["nominal"]["fit"] >= 95.0, doc["nominal"]
    assert not cc["significant"], cc["statistic"]
