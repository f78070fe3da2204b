"""The package works installed, away from the repository: build the wheel, install it in a
fresh virtual environment outside the checkout, and from there identify a model, quantize
it, and exchange frames with the emulator (whose firmware core is the library the wheel
built), then start the simboard from the packaged ELF and harness.

The fresh environment takes its third-party dependencies from the test's own environment
(one .pth line) so that the test needs no network beyond the wheel's build requirements.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest

from porosense.protocol._messages import VERSION_MAJOR

ROOT = Path(__file__).resolve().parents[2]
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("wheel")]

EXCHANGE = r"""
import json, sys
import numpy as np
import porosense
from porosense.device import Device
from porosense.emulator import Emulator
from porosense.firmware import files, hostlib
blob = open(sys.argv[1], "rb").read()
with Emulator(actuator="contractor", seed=1) as emu, Device.open(emu.url) as dev:
    info = dev.hello()
    valid = dev.write_model(blob).valid
    dev.start_stream(100)
    samples = list(dev.samples(50))
    dev.stop_stream()
print(json.dumps({
    "package": porosense.__file__, "library": str(hostlib.library_path()),
    "source_tree": str(files.source_tree()), "proto": [info.proto_major, info.proto_minor],
    "model_valid": valid, "samples": len(samples), "estimates": [int(s.estimate[0]) for s in samples],
    "t_us": [int(s.t_us) for s in samples],
}))
"""

SIMBOARD = r"""
import json
from porosense.device import Device
from porosense.firmware import files
from porosense.simboard import SimBoard
with SimBoard(actuator="contractor") as board, Device.open(board.url, timeout_scale=5.0) as dev:
    info = dev.hello()
print(json.dumps({"elf": str(files.elf_path()), "fw": info.firmware, "emulated": info.emulated}))
"""


def _run(args, cwd, env, timeout=600):
    proc = subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, f"{args[:3]} failed ({proc.returncode}):\n{proc.stdout[-2000:]}\n{proc.stderr[-3000:]}"
    return proc


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(venv python, scratch folder outside the checkout, clean environment)."""
    if shutil.which("c++") is None and shutil.which("g++") is None:
        pytest.skip("no C++ compiler: the wheel cannot build the firmware core")
    tmp = tmp_path_factory.mktemp("wheel")
    assert ROOT not in tmp.parents
    wheels = tmp / "dist"
    # A copy with the firmware links resolved: nothing is written into the checkout, and no
    # stale build/ folder of an earlier build can slip old modules into the wheel.
    src = tmp / "host_sdk"
    shutil.copytree(
        ROOT / "host_sdk",
        src,
        symlinks=False,
        ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__", "*.o", "*.d"),
    )
    build = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(wheels), str(src)],
        capture_output=True,
        text=True,
        timeout=900,
    )
    if build.returncode != 0 and "setuptools" in build.stderr and "No matching distribution" in build.stderr:
        pytest.skip("the wheel's build requirements (setuptools, wheel) cannot be fetched here")
    assert build.returncode == 0, build.stderr[-3000:]
    (wheel,) = wheels.glob("porosense-*.whl")
    env_dir = tmp / "venv"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    py = env_dir / "bin" / "python"
    site = Path(
        subprocess.check_output(
            [str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], text=True
        ).strip()
    )
    # Third-party dependencies from this environment; porosense itself only from the wheel.
    (site / "_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    _run([sys.executable, "-m", "pip", "--python", str(py), "install", "-q", "--no-deps", str(wheel)], tmp, None)
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "POROSENSE", "VIRTUAL_ENV"))}
    env["POROSENSE_CACHE"] = str(tmp / "cache")  # stays empty: the wheel's library matches
    env["PATH"] = f"{env_dir / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    work = tmp / "work"
    work.mkdir()
    return py, work, env


def test_installed_wheel_identifies_quantizes_and_talks_to_the_emulator(installed):
    py, work, env = installed
    cli = str(py.parent / "porosense")
    _run(
        [cli, "simulate", "contractor", "-e", "step_40", "--rate", "100", "--out", "data", "--json"],
        work,
        env,
    )
    data = sorted(str(p) for p in (work / "data").glob("*.csv"))
    assert len(data) == 1
    # One recording and one Wiener-Hammerstein model at fixed orders: what proves the installed copy
    # identifies (its nonlinear fit, the hold-out split) and quantizes a model with tables; the order
    # search over structures is the source tree's to test (tests/ident). 5.1 CPU s instead of 11.7.
    _run(
        [
            cli,
            "identify",
            "--data",
            *data,
            "--input",
            "dR_0",
            "--output",
            "strain_0",
            "--ts",
            "0.01",
            "--structure",
            "wh",
            "--poles",
            "2",
            "--zeros",
            "1",
            "--out",
            "model.json",
            "--json-out",
            "ident.json",
        ],
        work,
        env,
    )
    _run([cli, "quantize", "--model", "model.json", "--out", "model.bin", "--json-out", "quant.json"], work, env)
    blob = (work / "model.bin").read_bytes()
    assert len(blob) > 26
    assert json.loads((work / "ident.json").read_text())["results"][0]["best"]["structure"] == "wh"
    out = json.loads(_run([str(py), "-c", EXCHANGE, "model.bin"], work, env).stdout.strip().splitlines()[-1])
    pkg = Path(out["package"])
    assert py.parent.parent in pkg.parents and ROOT not in pkg.parents  # the installed copy ran
    assert out["source_tree"] == "None"
    assert Path(out["library"]).parent.name == "lib" and py.parent.parent in Path(out["library"]).parents
    assert not (Path(env["POROSENSE_CACHE"])).exists()  # nothing rebuilt: the wheel's library served
    assert out["model_valid"] and out["samples"] == 50 and out["proto"][0] == VERSION_MAJOR
    assert any(e != 0 for e in out["estimates"])  # the firmware's estimator ran on the model
    assert all(b - a == 10_000 for a, b in zip(out["t_us"], out["t_us"][1:]))
    where = json.loads(_run([cli, "firmware", "where", "--json"], work, env).stdout)
    assert where["core"]["present"]


def test_installed_wheel_runs_the_simboard(installed):
    py, work, env = installed
    where = json.loads(_run([str(py.parent / "porosense"), "firmware", "where", "--json"], work, env).stdout)
    if not (where["elf"]["present"] and where["simboard"]["present"]):
        pytest.skip("the wheel carries no firmware ELF or simboard harness (gcc-avr / libsimavr-dev absent)")
    out = json.loads(_run([str(py), "-c", SIMBOARD], work, env).stdout.strip().splitlines()[-1])
    assert py.parent.parent in Path(out["elf"]).parents
    assert out["fw"].startswith("1.") and out["emulated"] is False


def test_installed_wheel_carries_the_one_version(installed):
    """pyproject.toml reads the version from porosense/_version.py: the installed metadata, the
    module and `porosense --version` agree."""
    py, work, env = installed
    code = "import importlib.metadata as m, porosense; print(m.version('porosense'), porosense.__version__)"
    meta, module = _run([str(py), "-c", code], work, env).stdout.split()
    cli = _run([str(py), "-m", "porosense", "--version"], work, env).stdout.split()[-1]
    assert meta == module == cli, (meta, module, cli)
