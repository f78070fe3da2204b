"""Models: conversion to the estimator structure, storage, linear blocks, C header, errors."""

import json
import shutil
import subprocess

import numpy as np
import pytest

from porosense import ident
from porosense.errors import InputError, ModelError

KINDS = ("linear", "hammerstein", "wiener", "wh")


@pytest.fixture(scope="module")
def miso_data():
    """Two inputs with different scales, a one-sample delay, three recordings."""
    rng = np.random.default_rng(7)
    us, ys = [], []
    for _ in range(3):
        u = np.column_stack([np.repeat(rng.uniform(-80, 0, 30), 20), np.repeat(rng.uniform(0, 3, 30), 20)])
        y = np.convolve(np.tanh(u[:, 0] / 40.0), [0.0, 0.3, 0.2, 0.1])[: len(u)] + 0.2 * u[:, 1] ** 2
        us.append(u)
        ys.append(y + 5.0)
    return us, ys


@pytest.fixture(scope="module")
def fitted(miso_data):
    us, ys = miso_data
    return {
        k: ident.make_model(k, n_poles=2, n_zeros=1, n_breakpoints=6, delay=1, max_nfev=40).fit(
            u=us, y=ys, ts=0.02, inputs=("dR_0", "dR_1"), output="strain_0"
        )
        for k in KINDS
    }


@pytest.mark.parametrize("kind", KINDS)
def test_structure_simulates_like_the_model(fitted, miso_data, kind):
    m = fitted[kind]
    u = miso_data[0][0]
    s = m.to_structure()
    assert s.outputs[0].kind == ("linear" if kind == "linear" else kind)
    err = np.max(np.abs(s.simulate(u)[:, 0] - m.predict(u=u)))
    assert err < 1e-9 * (1 + np.max(np.abs(m.predict(u=u))))


@pytest.mark.parametrize("kind", KINDS)
def test_save_and_load_are_bit_for_bit(fitted, miso_data, tmp_path, kind):
    m = fitted[kind]
    path = m.save(tmp_path / "m.json")
    back = ident.load_model(path)
    u = miso_data[0][1]
    assert np.array_equal(back.theta, m.theta)
    assert np.array_equal(back.predict(u=u), m.predict(u=u))
    assert json.loads(path.read_text())["version"] == 1


def test_model_set_has_one_output_chain_per_model(fitted, miso_data, tmp_path):
    a, b = fitted["linear"], fitted["wiener"]
    b2 = ident.load_model(b.save(tmp_path / "b.json"))
    b2.output = "strain_1"
    mset = ident.ModelSet([a, b2])
    back = ident.load_model(mset.save(tmp_path / "set.json"))
    u = miso_data[0][0]
    assert back.outputs == ("strain_0", "strain_1")
    assert np.array_equal(back.predict(u=u), mset.predict(u=u))
    assert np.max(np.abs(mset.to_structure().simulate(u) - mset.predict(u=u))) < 1e-9 * 100


def test_linear_blocks_are_transfer_functions_with_the_right_gain(fitted, miso_data):
    import control

    m = fitted["linear"]
    tfs = m.linear_blocks()
    assert set(tfs) == {"h1[dR_0]", "h1[dR_1]"}
    u = miso_data[0][0]
    y = sum(control.forced_response(tfs[f"h1[{n}]"], U=u[:, i]).outputs for i, n in enumerate(m.inputs))
    y = y + m.to_structure().outputs[0].offset
    assert np.max(np.abs(y - m.predict(u=u))) < 1e-8 * (1 + np.max(np.abs(y)))


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not installed")
def test_c_header_compiles(fitted, tmp_path):
    (tmp_path / "m.h").write_text(fitted["wh"].c_header("demo_model"))
    (tmp_path / "m.c").write_text('#include "m.h"\nint main(void){return (int)(demo_model_out0_offset * 0.0f);}\n')
    res = subprocess.run(
        [
            "gcc",
            "-Wall",
            "-Werror",
            "-Wno-unused-variable",
            "-Wno-unused-const-variable",
            "-o",
            str(tmp_path / "m"),
            str(tmp_path / "m.c"),
        ],
        capture_output=True,
        text=True,
    )
    assert res.returncode == 0, res.stderr


def test_every_pole_of_every_fitted_block_is_inside_the_unit_circle(fitted):
    radii = [
        np.max(np.abs(blk.poles()))
        for m in fitted.values()
        for out in m.to_structure().outputs
        for blk in [br.h1 for br in out.branches] + ([out.h2] if out.h2 else [])
    ]
    assert max(radii) < 1.0


def test_user_errors_are_input_errors():
    with pytest.raises(InputError):
        ident.Linear(n_poles=2).fit(u=[np.zeros((10, 1))], y=[np.zeros(9)], ts=1.0)
    with pytest.raises(InputError):
        ident.Hammerstein(n_breakpoints=65)
    with pytest.raises(InputError):
        ident.Linear().fit(u=np.zeros((20, 4)), y=np.zeros(20), ts=1.0)
    with pytest.raises(ModelError):
        ident.Linear().predict(u=np.zeros((5, 1)))


def test_load_rejects_other_files(tmp_path):
    p = tmp_path / "x.json"
    p.write_text('{"format": "something else"}')
    with pytest.raises(ModelError):
        ident.load_model(p)
    p.write_text('{"format": "porosense.ident.model", "version": 99, "models": []}')
    with pytest.raises(ModelError, match="version"):
        ident.load_model(p)
