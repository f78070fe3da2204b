"""``porosense diagnose --sim material``: what a calibrated material law misses on tensile records
(issue 31 item 4), from the command line.

Records: tests/sim/tensile_generator.py (written apart from porosense.sim and
porosense.diagnose: tunnelling resistance of a network strain relaxing in two Maxwell arms,
damage, R0 that differs between recordings by +-30 % and drifts within one; every parameter
drawn from a wide range, fixed seeds), 10 Hz. The law is calibrated on two recordings read in
full (``porosense calibrate material``); three more recordings of the same material are read
through a range that clips the resistance at a level drawn uniformly between 55 % and 75 % of
the record's span (a divider or ADC range; the law has no clip). Diagnosed: the law on two of
them (estimation), the third held out.

Bounds: saturation is the top cause and its held-out gain is positive (seeds 0-2); on the same
records read in full, saturation is not named (the rests at low strain between cycles, where the
resistance sits at its lowest, are not clipping: there the strain rests at its own rest level,
while at the clip it goes beyond where it is elsewhere). Found input-output causes are never
ranked below one whose held-out gain is significantly smaller. Measured over seeds 0-9 (4-5 s CPU
per seed): saturation top in 9 of 10 clipped trials (held-out gains +14.2 to +48.5 points; in
seed 9 its gain, +3.0, is not confirmed, t = 1.62, and slow_relaxation comes first); before the
input's side of the rest rule it was top in 4 of 10 and rejected as a rest in 6 (gains +3.0 to
+29.3). Read in full, saturation is named in 0 of 10 (before: 0 of 10). The module takes 16 s CPU.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import numpy as np
import pytest

from porosense.cli import main
from porosense.data import Recording

sys.path.insert(0, str(Path(__file__).parent))
import tensile_generator  # noqa: E402

RATE_HZ = 10.0
CLIP_SHARE = (0.55, 0.75)


def _write(path: Path, r: dict, resistance) -> str:
    cols = {"strain": r["strain"] * 100.0, "R": resistance}
    Recording(r["t"], cols, {}, {"strain": "%", "R": "ohm"}).to_csv(path)
    return str(path)


@pytest.fixture(scope="module")
def material(tmp_path_factory):
    """seed -> (calibrated law, measured files read in full, the same read through the clip)."""
    made = {}

    def make(seed: int):
        if seed in made:
            return made[seed]
        d = tmp_path_factory.mktemp(f"material{seed}")
        rng = np.random.default_rng(seed)
        law = tensile_generator.draw_material(rng)
        recs = [tensile_generator.record(rng, law, rate_hz=RATE_HZ) for _ in range(5)]
        tensile = [_write(d / f"tensile{k}.csv", r, r["R"]) for k, r in enumerate(recs[:2])]
        full, clipped = [], []
        for k, r in enumerate(recs[2:]):
            top = np.min(r["R"]) + rng.uniform(*CLIP_SHARE) * np.ptp(r["R"])
            full.append(_write(d / f"full{k}.csv", r, r["R"]))
            clipped.append(_write(d / f"clipped{k}.csv", r, np.minimum(r["R"], top)))
        params = d / "law.json"
        argv = ["calibrate", "material", "--data", *tensile, "--strain", "strain", "--resistance", "R"]
        assert main(argv + ["--out", str(params), "--quiet"]) == 0
        made[seed] = params, full, clipped
        return made[seed]

    return make


_DIAGNOSED: dict = {}


def _diagnose(capsys, params, files) -> dict:
    """The JSON of diagnose --sim material (once per law and files: the tests share them)."""
    key = (str(params), *files)
    if key in _DIAGNOSED:
        return _DIAGNOSED[key]
    capsys.readouterr()
    argv = ["diagnose", "--sim", "material", "--params", str(params), "--data", *files[:2]]
    argv += ["--validation-data", files[2], "--input", "strain", "--output", "R", "--json"]
    assert main(argv) == 0
    _DIAGNOSED[key] = json.loads(capsys.readouterr().out)
    return _DIAGNOSED[key]


def _found(doc) -> list:
    return [(f["cause"], round(f["gain"], 2)) for f in doc["findings"] if f["found"]]


@pytest.mark.parametrize("seed", (0, 1, 2))
def test_a_clipped_read_out_is_named_saturation_with_a_held_out_gain(material, capsys, seed):
    params, _, clipped = material(seed)
    doc = _diagnose(capsys, params, clipped)
    with capsys.disabled():
        print(f"\nseed {seed}, clipped: top {doc['top']}, found (cause, held-out gain) {_found(doc)}")
    assert doc["top"] == "saturation", _found(doc)
    top = doc["findings"][0]
    assert top["cause"] == "saturation" and top["gain"] > 0.0, top
    _assert_no_cause_below_a_significantly_smaller_gain(doc)


def _assert_no_cause_below_a_significantly_smaller_gain(doc) -> None:
    """Among found input-output causes, none is ranked below one whose gain is smaller by more than
    the two gains' combined uncertainty (gain / t is the batch-means standard error, points)."""
    found = [f for f in doc["findings"] if f["found"] and f["cause"] not in ("drift", "periodic_disturbance")]
    for i, above in enumerate(found):
        for below in found[i + 1 :]:
            se = np.hypot(above["gain"] / above["gain_t"], below["gain"] / below["gain_t"])
            assert below["gain"] - above["gain"] < 1.645 * se, (above["cause"], below["cause"], _found(doc))


@pytest.mark.parametrize("seed", (0, 1))
def test_rests_at_low_strain_read_in_full_are_not_saturation(material, capsys, seed):
    params, full, _ = material(seed)
    doc = _diagnose(capsys, params, full)
    with capsys.disabled():
        print(f"\nseed {seed}, read in full: top {doc['top']}, found {_found(doc)}")
    assert "saturation" not in [c for c, _ in _found(doc)]


@pytest.mark.parametrize(
    "options, message",
    [
        ("--input strain --output R", "give --params PARAMS.json"),
        ("--params {law} --input strain R --output R", "takes one input, the strain column"),
        (
            "--params {law} --input strain --output R --save-extended {tmp}/ext.json",
            "--save-extended with --sim material",
        ),
        ("--params {law} --input R --output strain", "positive resistance"),
    ],
)
def test_material_mistakes_are_one_line(tmp_path, capsys, options, message):
    rec = tmp_path / "rec.csv"
    t = np.arange(200) * 0.1
    strain = 10.0 * np.abs(np.sin(t / 3.0)) - 1.0
    Recording(t, {"strain": strain, "R": 1e4 * (1 + strain / 100)}, {}, {"strain": "%", "R": "ohm"}).to_csv(rec)
    law = tmp_path / "law.json"
    calibrate = ["calibrate", "material", "--data", str(rec), "--strain", "strain", "--resistance", "R"]
    assert main(calibrate + ["--out", str(law), "--quiet"]) == 0
    argv = ["diagnose", "--sim", "material", "--data", str(rec)]
    argv += options.format(law=law, tmp=tmp_path).split()
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and err.count("\n") == 1, err


def _seeds() -> list:
    """MATERIAL_SEEDS ('A-B', default 0-2: the seeds above, already calibrated)."""
    a, _, b = os.environ.get("MATERIAL_SEEDS", "0-2").partition("-")
    return list(range(int(a), int(b or a) + 1))


def test_the_rates_over_seeds(material, capsys):
    """Over the seeds: saturation named on records read in full in none; the top cause on clipped
    records in at least 80 % (measured 9 of 10 over seeds 0-9, 3 of 3 over 0-2)."""
    seeds = _seeds()
    top, named_in_full = 0, 0
    for seed in seeds:
        params, full, clipped = material(seed)
        top += _diagnose(capsys, params, clipped)["top"] == "saturation"
        named_in_full += "saturation" in [c for c, _ in _found(_diagnose(capsys, params, full))]
    with capsys.disabled():
        print(
            f"\nseeds {seeds[0]}-{seeds[-1]}: saturation top in {top} of {len(seeds)} clipped, named in {named_in_full} read in full"
        )
    assert named_in_full == 0
    assert top >= 0.8 * len(seeds)
