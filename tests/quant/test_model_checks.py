"""Models that cannot hurt the board: quantize refuses (ModelError, exit 4 on the command line,
one line) a structure with a pole on or outside the unit circle, a NaN or infinite coefficient
(named as such), breakpoints that do not increase, or a fixed-point estimate that saturates;
--force writes the blob with a warning (not an unstable one: the board refuses that). A model identified on real-looking simulated data
passes; the same model with its parameters scrambled (scaled x100, reversed) is refused. The
blob reader refuses an unstable section as the board does (tests/core/test_section_stable.cpp)."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from scipy import signal

from porosense.cli import main
from porosense.errors import ModelError
from porosense.protocol.model_blob import ModelBlob
from porosense.quant import quantize
from porosense.quant.checks import MIN_FIXED_VS_FLOAT_FIT
from porosense.structure import Branch, EstimatorStructure, OutputChain, PiecewiseLinear, SOSCascade


def _structure(poles=(0.9, 0.5), g=None, f=None, peak=90.0) -> EstimatorStructure:
    h1 = SOSCascade(signal.zpk2sos([-0.5], list(poles), 0.05))
    out = OutputChain("strain_0", (Branch(0, h1, f),), g=g)
    return EstimatorStructure(("dR_0",), (out,), 0.02, input_units=("%",), input_peak=(peak,))


def test_a_stable_model_passes_and_is_checked_on_a_probe_without_data():
    result = quantize(_structure())
    (fit,) = result.report.fits
    assert fit.recording.startswith("probe") and fit.fit_fixed_vs_float >= MIN_FIXED_VS_FLOAT_FIT
    # The model's own range (+- 1.5 x its identification peak of 90 % dR), not +-100 %.
    assert "[-135, 135]" in result.report.scaling


@pytest.mark.parametrize(
    ("case", "words"),
    [
        ({"poles": (1.02, 0.5)}, "pole at |z| = 1.02"),
        ({"poles": (-1.0, 0.3)}, "pole at |z| = 1"),
    ],
)
def test_models_that_could_hurt_the_board_are_refused(case, words):
    with pytest.raises(ModelError, match=words.replace("|", r"\|")):
        quantize(_structure(**case))
    with pytest.raises(ModelError, match="unstable"):  # not even forced: the board refuses it
        quantize(_structure(**case), force=True)


def test_tables_name_nan_and_inf_and_refuse_breakpoints_out_of_order():
    for y, words in (([1.0, np.nan, 2.0], "hold NaN"), ([1.0, np.inf, 2.0], r"infinite value \(inf\)")):
        with pytest.raises(ModelError, match=words):
            PiecewiseLinear(np.array([-2.0, 0.0, 1.0]), np.array(y))
    with pytest.raises(ModelError, match="breakpoints hold NaN"):
        PiecewiseLinear(np.array([np.nan, 0.0, 1.0]), np.array([0.0, 1.0, 2.0]))
    with pytest.raises(ModelError, match="strictly increasing"):
        PiecewiseLinear(np.array([-50.0, 10.0, 0.0]), np.array([-1.0, 0.0, 1.0]))
    good = _structure()
    sos = good.outputs[0].branches[0].h1.sos.copy()
    sos[0, 5] = np.nan
    out = dataclasses.replace(good.outputs[0], branches=(Branch(0, SOSCascade(sos)),))
    with pytest.raises(ModelError, match="H1 of input dR_0 holds NaN"):
        quantize(dataclasses.replace(good, outputs=(out,)))


def test_saturating_fixed_point_estimate_is_refused():
    # A range far narrower than the data the model will see: the estimate saturates.
    u = np.repeat(np.linspace(-80, 0, 20), 50)[:, None]
    with pytest.raises(ModelError, match="saturates"):
        quantize(_structure(), recordings=[("steps", u, None)], input_range=(-5.0, 0.0))


def test_unstable_section_in_a_blob_is_refused_by_the_reader():
    data = bytearray(quantize(_structure()).to_bytes())
    blob = ModelBlob.from_bytes(bytes(data))
    sec = blob.outputs[0].branches[0].sections[0]
    bad = dataclasses.replace(
        sec, m=(2, 0), k=(16384, 0), delta=False
    )  # c1 = 2.25: a pole at 2.25, outside the unit circle
    out = dataclasses.replace(
        blob.outputs[0], branches=(dataclasses.replace(blob.outputs[0].branches[0], sections=(bad,)),)
    )
    raw = dataclasses.replace(blob, outputs=(out,)).to_bytes()
    with pytest.raises(ModelError, match="on or outside the unit circle"):
        ModelBlob.from_bytes(raw)


@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    from porosense import ident
    from porosense.sim import run_experiment

    d = tmp_path_factory.mktemp("checks")
    rec = run_experiment("contractor", "staircase", rate_hz=50, seed=3)
    m = ident.Linear(n_poles=2, n_zeros=1).fit(
        u=[rec["dR_0"][:, None]], y=[rec["strain_0"]], ts=0.02, inputs=["dR_0"], output="strain_0"
    )
    m.save(d / "model.json")
    rec.to_csv(d / "staircase.csv")
    return d


def _scrambled(d, name, how):
    doc = json.loads((d / "model.json").read_text())

    def walk(node):
        if isinstance(node, dict):
            for k, v in node.items():
                if k == "theta":
                    node[k] = how(np.asarray(v, dtype=float)).tolist()
                else:
                    walk(v)
        elif isinstance(node, list):
            for v in node:
                walk(v)

    walk(doc)
    path = d / name
    path.write_text(json.dumps(doc))
    return path


def test_cli_refuses_scrambled_models_in_one_line_and_force_writes_them(model_file, capsys):
    d = model_file
    assert main(["quantize", "--model", str(d / "model.json"), "--out", str(d / "ok.bin")]) == 0
    capsys.readouterr()
    assert "theta" in (d / "model.json").read_text(), "the model file layout changed: update _scrambled"
    for name, how in (("x100.json", lambda t: t * 100), ("reversed.json", lambda t: t[::-1])):
        path = _scrambled(d, name, how)
        out = d / (name + ".bin")
        data = ["--data", str(d / "staircase.csv")]
        code = main(["quantize", "--model", str(path), "--out", str(out), *data])
        err = capsys.readouterr().err.strip()
        assert code == 4 and len(err.splitlines()) == 1 and not out.exists(), (name, err)
        assert "unit circle" in err or "not a model of this data" in err or "saturates" in err, err
        if "unit circle" in err:
            continue  # cannot be forced: the board refuses an unstable blob
        code = main(["quantize", "--model", str(path), "--out", str(out), "--force", *data])
        err = capsys.readouterr().err
        assert code == 0 and out.exists() and "warning: forced past a refusal" in err, (name, err)
    # An existing blob is not replaced without --force.
    code = main(["quantize", "--model", str(d / "model.json"), "--out", str(d / "ok.bin")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "exists" in err and "--force" in err
