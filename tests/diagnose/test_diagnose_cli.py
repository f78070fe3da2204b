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
