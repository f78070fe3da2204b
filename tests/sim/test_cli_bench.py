"""`porosense simulate` and `porosense bench sim`."""

import json

import numpy as np
import pytest

from porosense.cli import main
from porosense.data import Recording


def test_simulate_writes_recordings(tmp_path, capsys):
    code = main(
        [
            "simulate",
            "contractor",
            "--experiment",
            "step_40",
            "--porosity",
            "86",
            "--load-g",
            "200",
            "--rate",
            "50",
            "--seed",
            "3",
            "--repeats",
            "2",
            "--format",
            "both",
            "--effect",
            "time_delay:delay_s=0.2",
            "--out",
            str(tmp_path),
        ]
    )
    assert code == 0
    csvs = sorted(tmp_path.glob("*.csv"))
    assert [p.name for p in csvs] == ["contractor_step_40_p86_l200_s3.csv", "contractor_step_40_p86_l200_s4.csv"]
    rec = Recording.from_csv(csvs[0])
    assert rec.meta["porosity"] == 86.0 and rec.meta["load_g"] == 200.0 and rec.fs == pytest.approx(50.0)
    assert rec.meta["effects"] == {"time_delay": {"delay_s": 0.2}}
    mat = Recording.from_mat(csvs[0].with_suffix(".mat"))
    assert np.array_equal(mat["dR_0"], rec["dR_0"])
    assert "2 " not in capsys.readouterr().err


def test_simulate_paper_set_for_the_bending_actuator(tmp_path):
    assert main(["simulate", "bending", "-e", "paper", "--rate", "10", "--out", str(tmp_path)]) == 0
    names = sorted(p.stem.split("_p")[0] for p in tmp_path.glob("*.csv"))
    assert names.count("bending_step_60") == 2 and "bending_staircase" in names and len(names) == 9


@pytest.mark.parametrize(
    "argv, message",
    [
        (["simulate", "contractor", "-e", "step_30"], "unknown experiment"),
        (["simulate", "contractor", "-e", "step_10", "--porosity", "99"], "outside 60-90"),
        (["simulate", "contractor", "-e", "step_10", "--effect", "drift:fast"], "expected NAME:param=number"),
    ],
)
def test_simulate_user_errors_are_one_line(tmp_path, capsys, argv, message):
    assert main(argv + ["--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and err.count("\n") == 1


@pytest.mark.bench
def test_bench_sim_small(capsys):
    assert main(["bench", "sim", "--json", "--size", "small"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["simulated_s"] > 300.0
    assert result["power_law_strain"]["r2"] >= 0.8 and result["power_law_dR"]["r2"] >= 0.8
    assert result["loop_area_step20"] > result["loop_area_staircase"]
    assert result["overshoot_pct"]["60"] >= 2.0 and result["overshoot_decayed"]["60"] >= 0.63
    assert result["realtime_ratio"] >= 1000.0 and len(result["summary"]) >= 5
