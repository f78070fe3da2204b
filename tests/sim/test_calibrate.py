"""Calibration of the simulator (porosense.sim.calibrate, ``porosense calibrate``, ``simulate
--params/--replay``) on records of generators written independently of porosense.sim.

No measured actuator or tensile recording is in the repository (the public carbon-black
tensile records found carry no licence that allows copying them here), so:

- material: tests/sim/tensile_generator.py (tunnelling resistance of a network strain that
  relaxes in two Maxwell arms, damage, R0 that differs between recordings by +-30 % and drifts);
  the law is calibrated on the first 60 % of two recordings and must predict the other 40 %
  better than linear and WH models identified on the same 60 % of each recording, and find
  each recording's R0;
- actuator: tests/sim/actuator_generator.py (Kelvin-Voigt strain, Hill-function resistance with
  a lag and a log-domain relaxation); the simulator is calibrated on the paper's estimation
  experiments and must predict the validation experiments (-20, -40 kPa) better than with its
  default parameters.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from porosense import ident
from porosense.cli import main
from porosense.data import Recording
from porosense.sim import Physics, schedule
from porosense.sim.calibrate import (
    ActuatorRecord,
    MaterialRecord,
    _fit_percent,
    calibrate_actuator,
    calibrate_material,
    simulate_record,
)

sys.path.insert(0, str(Path(__file__).parent))
import actuator_generator  # noqa: E402
import load_calibration  # noqa: E402
import tensile_generator  # noqa: E402

ESTIMATION_SHARE = 0.6
RATE_HZ = 10.0


@pytest.fixture(scope="module")
def tensile():
    rng = np.random.default_rng(0)
    material = tensile_generator.draw_material(rng)
    return [tensile_generator.record(rng, material, rate_hz=RATE_HZ) for _ in range(2)]


def _material_records(recs):
    out = []
    for k, r in enumerate(recs):
        mask = np.arange(r["t"].size) < int(ESTIMATION_SHARE * r["t"].size)
        out.append(MaterialRecord(r["t"], r["strain"], r["R"], mask, f"rec{k}"))
    return out


def _held_out_fit_of_identified(r, kind: str) -> float:
    """The best model of ``kind`` (orders up to 3 poles) identified on the first 60 % of one
    recording, strain in, resistance out, simulated over the whole recording and scored on the rest."""
    cut = int(ESTIMATION_SHARE * r["t"].size)
    u, y = r["strain"][:, None], r["R"]
    grid = [(kind, p, z) for p in (1, 2, 3) for z in range(p)]
    model = ident.search(u=[u[:cut]], y=[y[:cut]], ts=1.0 / RATE_HZ, grid=grid, progress=False, criterion="fit")
    return _fit_percent(y[cut:], model.model.predict(u=u)[cut:])


@pytest.mark.slow
def test_material_law_predicts_held_out_resistance_better_than_linear_and_wh(tensile):
    """Also what each effect contributes (``ablation``: the law refitted without it, mean
    held-out fit of R): the generator relaxes at constant strain and its R0 drifts, so the law
    without relaxation or without drift predicts the held-out part worse (relaxation by more
    than 10 points: the generator's two arms carry 10-40 % of the network strain)."""
    cal = calibrate_material(_material_records(tensile), ablation=True)
    print(cal)
    law_mean = float(np.mean(cal.fit_held_out))
    assert set(cal.ablation) == {"rate_hysteresis", "relaxation", "softening", "drift"}
    assert cal.ablation["relaxation"] < law_mean - 10.0, (cal.ablation, law_mean)
    assert cal.ablation["drift"] < law_mean, (cal.ablation, law_mean)
    for k, r in enumerate(tensile):
        linear = _held_out_fit_of_identified(r, "linear")
        wh = _held_out_fit_of_identified(r, "wh")
        law = cal.fit_held_out[k]
        print(f"record {k}: held-out fit of R: law {law:.2f} %, linear {linear:.2f} %, WH {wh:.2f} %")
        assert law > max(linear, wh), (law, linear, wh)
        # R0 changes by up to 30 % between the recordings: the calibration finds each one's
        assert abs(cal.r0_ohm[k] / r["r0_ohm"] - 1.0) < 0.02


@pytest.mark.parametrize("seed", (0, 1))
def test_actuator_calibration_predicts_the_validation_experiments(seed):
    rng = np.random.default_rng(seed)
    par = actuator_generator.draw(rng)

    def recording(name):
        s = schedule(name)
        sp = s.setpoints(s.times(25.0))[:, 0]
        r = actuator_generator.record(rng, par, sp, 25.0)
        return ActuatorRecord(r["p_cmd_0"][:, None], 0.04, r["dR_0"][:, None], {"strain_0": r["strain_0"]}, name=name)

    est = [recording(n) for n in ("staircase", "step_10", "step_60")]
    val = [recording(n) for n in ("step_20", "step_40")]
    cal = calibrate_actuator("contractor", est)
    print(cal)
    default = Physics().without("repeat_variation", "baseline_drift")
    for r in val:
        before = simulate_record("contractor", default, r)
        after = simulate_record("contractor", cal.physics.without("baseline_drift"), r)
        fits = {
            col: (_fit_percent(y, before[col]), _fit_percent(y, after[col]))
            for col, y in (("dR_0", r.dr[:, 0]), ("strain_0", r.outputs["strain_0"]))
        }
        print(r.name, {k: f"{a:.1f} -> {b:.1f} %" for k, (a, b) in fits.items()})
        assert fits["dR_0"][1] >= 80.0 and fits["dR_0"][1] >= fits["dR_0"][0] + 10.0
        assert fits["strain_0"][1] >= fits["strain_0"][0]


def test_calibrate_and_replay_from_the_command_line(tmp_path, capsys):
    assert (
        main(
            [
                "simulate",
                "contractor",
                "-e",
                "staircase",
                "-e",
                "step_60",
                "-e",
                "step_40",
                "--rate",
                "20",
                "--out",
                str(tmp_path / "d"),
            ]
        )
        == 0
    )
    d = tmp_path / "d"
    est = [str(d / "contractor_staircase_p82_l0_s0.csv"), str(d / "contractor_step_60_p82_l0_s0.csv")]
    params = tmp_path / "params.json"
    assert main(["calibrate", "contractor", "--data", *est, "--out", str(params), "--quiet"]) == 0
    assert Physics.load(params).variation.contact_strain_sd == 0.0  # the print measured
    out = tmp_path / "sim.csv"
    capsys.readouterr()
    code = main(
        [
            "simulate",
            "contractor",
            "--params",
            str(params),
            "--replay",
            str(d / "contractor_step_40_p82_l0_s0.csv"),
            "--out",
            str(out),
            "--json",
        ]
    )
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    rec = Recording.from_csv(out)
    assert {"R_sim_0", "dR_sim_0", "strain_sim_0"} <= set(rec.names) and rec.t[1] == pytest.approx(0.05)
    assert doc["fits"]["dR_sim_0"] > 90.0 and doc["fits"]["strain_sim_0"] > 85.0


def test_material_calibration_from_the_command_line(tmp_path, tensile, capsys):
    r = tensile[1]
    path = tmp_path / "tensile.csv"
    Recording(r["t"], {"strain": r["strain"] * 100.0, "R": r["R"]}, {}, {"strain": "%", "R": "ohm"}).to_csv(path)
    law = tmp_path / "law.json"
    cut = int(ESTIMATION_SHARE * r["t"].size)
    args = ["calibrate", "material", "--data", str(path), "--strain", "strain", "--resistance", "R"]
    assert main(args + ["--estimation", f"0:{cut}", "--out", str(law), "--quiet"]) == 0
    capsys.readouterr()
    replay = ["simulate", "material", "--params", str(law), "--replay", str(path), "--strain", "strain"]
    assert main(replay + ["--resistance", "R", "--out", str(tmp_path / "sim.csv"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["fits"]["R_sim"] > 90.0


@pytest.mark.parametrize(
    "argv, message",
    [
        (
            ["calibrate", "material", "--data", "{rec}", "--out", "{tmp}/p.json"],
            "needs --strain COL and --resistance COL",
        ),
        (["calibrate", "contractor", "--data", "{tensile}", "--out", "{tmp}/p.json"], "no column"),
        (["simulate", "contractor", "--params", "{tensile}", "--replay", "{rec}"], "not a simulator parameter file"),
        (["simulate", "material", "--replay", "{rec}"], "needs --params"),
        (
            [
                "calibrate",
                "material",
                "--data",
                "{rec}",
                "--strain",
                "strain",
                "--resistance",
                "R",
                "--load-column",
                "m",
            ]
            + ["--out", "{tmp}/p.json"],
            "calibrate material has none",
        ),
    ],
)
def test_calibration_mistakes_are_one_line(tmp_path, capsys, argv, message):
    rec = tmp_path / "rec.csv"
    Recording(np.arange(50) * 0.1, {"strain": np.linspace(0, 10, 50), "R": np.linspace(1e3, 2e3, 50)}, {}, {}).to_csv(
        rec
    )
    fill = {"rec": str(rec), "tensile": str(rec), "tmp": str(tmp_path)}
    assert main([a.format(**fill) for a in argv]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and err.count("\n") == 1


def test_a_parameter_file_sets_the_simulated_board(tmp_path):
    """open_board (emulator, the demo's and control's board) builds its plant from --params:
    a file with R0 = 3 kOhm (default 2.2 kOhm, print variation off) calibrates to 3 kOhm within
    the ADS1115's resolution and the contact noise (1 %)."""
    from porosense.boards import open_board

    physics = Physics().with_(piezo={"r0_ohm": 3000.0}).without("repeat_variation", "baseline_drift")
    with open_board("emulator", physics=physics) as board:
        r0 = board.device.calibrate_r0(n_samples=32, channels=0b001)[0]
    with open_board("emulator") as board:
        r0_default = board.device.calibrate_r0(n_samples=32, channels=0b001)[0]
    assert abs(r0 / 3000.0 - 1.0) < 0.01, r0
    assert abs(r0_default / 2200.0 - 1.0) < 0.1, r0_default


def test_the_loop_extends_a_calibrated_simulator_by_the_hidden_cause(tmp_path, capsys):
    """Records of tests/sim/actuator_generator.py with a resistance reading that lags by 0.4 s
    (10 samples at 25 Hz; the generator has no delay of its own and the default simulator none):
    the simulator calibrated on them (the calibration absorbs part of the lag in its kinetics)
    and extended by time_delay gains on the held-out experiments (measured +1.25 fit points,
    delay 0.24 s), more than extended by hysteresis (+0.39) or drift (+0.00); the extended
    parameter file replays with the better dR fit."""
    from porosense.sim.extend import extend

    rng = np.random.default_rng(0)
    par = actuator_generator.draw(rng)
    lag = 10

    def recording(name):
        s = schedule(name)
        r = actuator_generator.record(rng, par, s.setpoints(s.times(25.0))[:, 0], 25.0)
        dr = np.r_[np.full(lag, r["dR_0"][0]), r["dR_0"][:-lag]]
        return ActuatorRecord(r["p_cmd_0"][:, None], 0.04, dr[:, None], {"strain_0": r["strain_0"]}, name=name)

    est = [recording(n) for n in ("staircase", "step_10", "step_60")]
    val = [recording(n) for n in ("step_20", "step_40")]
    cal = calibrate_actuator("contractor", est)
    ext = {cause: extend("contractor", cal.physics, cause, est, val) for cause in ("time_delay", "hysteresis", "drift")}
    for e in ext.values():
        print(e)
    assert ext["time_delay"].gain > 0.5
    assert ext["time_delay"].gain > max(ext["hysteresis"].gain, ext["drift"].gain)
    assert 0.1 <= ext["time_delay"].fitted["delay_s"] <= 0.6
    # the extended file runs: simulate --params --replay of a held-out record
    cal.physics.save(tmp_path / "cal.json")
    ext["time_delay"].save(tmp_path / "ext.json")
    rec = tmp_path / "step_40.csv"
    r = val[1]
    Recording(np.arange(r.dr.shape[0]) * 0.04, {"p_cmd_0": r.p_cmd[:, 0], "dR_0": r.dr[:, 0]}, {}, {}).to_csv(rec)
    fits = {}
    for name in ("cal", "ext"):
        capsys.readouterr()
        argv = ["simulate", "contractor", "--params", str(tmp_path / f"{name}.json"), "--replay", str(rec)]
        assert main(argv + ["--out", str(tmp_path / f"{name}_sim.csv"), "--json"]) == 0
        fits[name] = json.loads(capsys.readouterr().out)["fits"]["dR_sim_0"]
    assert fits["ext"] > fits["cal"], fits


LOAD_SEEDS = range(6)


def _load_extension(seed):
    """load_dependence fitted and scored on one seed's loaded records (see the test below)."""
    from porosense.sim.extend import extend

    rng = np.random.default_rng(seed)
    par, load_par = actuator_generator.draw(rng), actuator_generator.draw_load(rng)

    def recording(name, loaded):
        s = schedule(name)
        p = s.setpoints(s.times(25.0))[:, 0]
        load = None
        if loaded:
            t = np.arange(p.size) / 25.0
            delta, start, ramp = rng.uniform(200.0, 500.0), rng.uniform(10.0, 30.0), rng.uniform(5.0, 15.0)
            load = delta * np.clip((t - start) / ramp, 0.0, 1.0)
        r = actuator_generator.record(rng, par, p, 25.0, load, load_par if loaded else None)
        return ActuatorRecord(p[:, None], 0.04, r["dR_0"][:, None], {"strain_0": r["strain_0"]}, name=name, load_g=load)

    cal = calibrate_actuator("contractor", [recording(n, False) for n in ("staircase", "step_10", "step_60")])
    est = [recording(n, True) for n in ("staircase", "step_10", "step_60")]
    val = [recording(n, True) for n in ("step_20", "step_40")]
    return extend("contractor", cal.physics, "load_dependence", est, val)


def test_the_load_column_extends_a_calibrated_simulator_and_gains_held_out():
    """load_dependence as a saved extension, measured on records of tests/sim/actuator_generator.py
    under a hanging load (its own physics: the load scales the contraction down by 10-30 % at
    500 g, lengthens the actuator by 1-5 % and raises ln R by 0.02-0.10, no lag; the default
    simulator's load acts through its foam stress and contact opening instead). Per seed the
    simulator is calibrated on the generator's unloaded estimation experiments (staircase, -10,
    -60 kPa at 25 Hz), then extended by the load column (``load_g``, g) of the same experiments
    loaded (200-500 g ramped in from 10-30 s over 5-15 s) and scored on the loaded -20 / -40 kPa
    experiments. Bounds, seeds 0-5: the held-out gain is positive in at least 5 of 6; the factor
    on the measured load is kept exactly where it predicts estimation records left out of its
    fit better than factor 1, and the kept extension never gains less held out than the load
    taken as measured. Measured (factor kept, held-out gain, with factor 1, cost cut left out):
    0: 1, +8.25, +8.25, -56.5 %; 1: 0.63, +9.34, -5.86, +38.3 %; 2: 0.75, -1.02, -3.20, +13.3 %;
    3: 1, +25.56, +25.56, -151 %; 4: 1, +19.04, +19.04, -26.8 %; 5: 0.68, +9.58, +5.83, +8.2 %.
    Seed 2 loses held out whatever the factor: the simulator's load moves dR where this
    generator's moves the strain (-40 kPa: dR fit 78.5 -> 57.9 %, strain 67.5 -> 77.3 %).
    About 1.5 s CPU per seed."""
    exts = [_load_extension(seed) for seed in LOAD_SEEDS]
    for seed, ext in zip(LOAD_SEEDS, exts):
        print(f"seed {seed}: {ext}")
        assert ext.effects["load_dependence"] == {"column": "load_g", "unit": "g", "factor": ext.fitted["factor"]}
        assert (ext.fitted["factor"] == 1.0) == (ext.factor_cross_validated <= 0.0), ext
        assert ext.gain >= ext.gain_unit_factor, ext
    assert sum(e.gain > 0.0 for e in exts) >= 5, [round(e.gain, 2) for e in exts]


LOAD_CAL_SEEDS = range(3)


def test_calibrating_under_the_recorded_load_predicts_held_out_records_better():
    """Calibration runs each record under its recorded load (tests/sim/load_calibration.py: an
    independent generator's records, estimation a mix of unloaded and 500 g records, held out
    -20 / -40 kPa unloaded and under 500 g, mean fit of dR and strain). Measured over seeds 0-9
    (``python tools/sim_load_calibration.py 0 9``), held-out fit without -> with the load:
    unloaded +21.72 fit points on average (least -1.14, seed 0; positive in 9 of 10), loaded
    +20.16 (least -0.84, seed 8; positive in 9 of 10). Seeds 0-2 here: unloaded -1.14, +16.76,
    +31.61 (mean +15.74), loaded +17.48, +7.12, +3.99 (mean +9.53). Bounds: no seed loses more
    than 2 points on either kind (the worst of ten lost 1.14), and the mean gain over the seeds
    is at least +5 points on each kind (about half the smaller mean measured here). About 3 s CPU
    per seed."""
    gains = {"unloaded": [], "loaded": []}
    for seed in LOAD_CAL_SEEDS:
        m = load_calibration.measure(seed)
        print(f"seed {seed}: without {m['without']}, with {m['with']}")
        for kind in gains:
            gains[kind].append(m["with"][kind] - m["without"][kind])
    for kind, g in gains.items():
        assert min(g) >= -2.0, (kind, g)
        assert np.mean(g) >= 5.0, (kind, g)


def _load_cli_records(tmp_path):
    """Seed 0's staircase unloaded (no load column) and under 500 g, and its loaded -40 kPa record, as CSV."""
    est, val = load_calibration.records(0)
    paths = []
    for r in (est[0], est[3], val[3]):
        cols = {"p_cmd_0": r.p_cmd[:, 0], "dR_0": r.dr[:, 0], "strain_0": r.outputs["strain_0"]}
        units = {"p_cmd_0": "kPa", "dR_0": "%", "strain_0": "%"}
        if r.load_g is not None:
            cols["load_g"], units["load_g"] = r.load_g, "g"
        path = tmp_path / f"{r.name.replace('@', '_')}.csv"
        Recording(np.arange(r.dr.shape[0]) * r.ts, cols, {}, units).to_csv(path)
        paths.append(path)
    return paths, val[3]


def test_calibrate_takes_the_load_column_and_replay_reads_it(tmp_path, capsys):
    """``calibrate`` runs a record with a load_g column (g) under that load and one without it
    unloaded, saying so once; the file names the column; ``simulate --params --replay`` of a loaded
    record runs it under its load column (the same figure as the library's replay under the load)."""
    from porosense.sim.calibrate import calibrated_load_column

    (bare, loaded, held), rec = _load_cli_records(tmp_path)
    params = tmp_path / "params.json"
    assert main(["calibrate", "contractor", "--data", str(bare), str(loaded), "--out", str(params)]) == 0
    out = capsys.readouterr().out
    assert out.count("no load column 'load_g'") == 1 and f"calibrated unloaded ({bare})" in out, out
    doc = json.loads(params.read_text())
    assert doc["calibrated_load"] == {"column": "load_g", "unit": "g", "records": [str(loaded)]}
    assert calibrated_load_column(params) == "load_g"
    argv = ["simulate", "contractor", "--params", str(params), "--replay", str(held), "--json"]
    assert main(argv + ["--out", str(tmp_path / "sim.csv")]) == 0
    fit = json.loads(capsys.readouterr().out)["fits"]["dR_sim_0"]
    physics = Physics.load(params)
    under = simulate_record("contractor", physics, rec, load_g=rec.load_g)["dR_0"]
    unloaded = simulate_record("contractor", physics, rec)["dR_0"]
    assert fit == pytest.approx(_fit_percent(rec.dr[:, 0], under), abs=1e-6)
    assert fit != pytest.approx(_fit_percent(rec.dr[:, 0], unloaded), abs=0.1)
    # a record without the column replays unloaded, and says so
    assert (
        main(
            ["simulate", "contractor", "--params", str(params), "--replay", str(bare), "--out", str(tmp_path / "b.csv")]
        )
        == 0
    )
    assert "no load column 'load_g'" in capsys.readouterr().out


@pytest.mark.parametrize(
    "unit, column, message",
    [
        ("kg", None, "column 'load_g' is in kg; the simulator takes the load in g"),
        ("g", "mass", "--load-column mass: no recording has that column"),
        ("g", None, "a load is a finite mass >= 0 g"),
    ],
)
def test_a_load_column_in_another_unit_or_missing_is_one_line(tmp_path, capsys, unit, column, message):
    t = np.arange(100) * 0.04
    load = np.full(100, 0.5 if unit == "kg" else 500.0)
    if message.startswith("a load"):
        load[7] = -1.0
    cols = {"p_cmd_0": -10.0 * (t > 1.0), "dR_0": -5.0 * (t > 1.0), "load_g": load}
    Recording(t, cols, {}, {"p_cmd_0": "kPa", "dR_0": "%", "load_g": unit}).to_csv(tmp_path / "r.csv")
    argv = ["calibrate", "contractor", "--data", str(tmp_path / "r.csv"), "--out", str(tmp_path / "p.json")]
    assert main(argv + (["--load-column", column] if column else [])) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and err.count("\n") == 1, err
    assert not (tmp_path / "p.json").exists()


@pytest.mark.parametrize(
    "argv",
    [
        ["emulator", "--params", "{ext}", "--listen", "tcp://127.0.0.1:0"],
        ["demo", "--params", "{ext}", "--out", "{tmp}/demo"],
    ],
)
def test_the_boards_refuse_an_extended_parameter_file_in_one_line(tmp_path, capsys, argv):
    """The emulator, the simboard, the demo and control run a plant's physics, not an extension's
    effects: an extended file (diagnose --sim --save-extended) is refused before anything runs,
    not run as the calibrated simulator it is not."""
    ext = Physics().save(tmp_path / "ext.json", effects={"saturation": {"low_V": 1.0, "high_V": 4.096}})
    assert main([a.format(ext=ext, tmp=tmp_path) for a in argv]) == 2
    err = capsys.readouterr().err
    assert "extended by saturation" in err and "Traceback" not in err and err.count("\n") == 1, err
    assert not (tmp_path / "demo").exists()
