"""Hostile and damaged files end in one line, within bounded memory: a fuzz of mutated CSV,
MATLAB v5, MATLAB v7.3 (HDF5) and model files (10,000 cases in all, in-process through
`porosense predict`), plus files made to hurt: an HDF5 dataset declared 1e5 x 1e5, soft-link
loops and external links, structs nested 200 deep, JSON nested 200,000 deep, NaN and "0.02"
where numbers belong.

Every case must end with exit 0 (the mutation left a readable file), 2 (bad input) or 4 (bad
model), with at most one line on stderr, never a traceback; the process's peak memory may grow
by at most MEMORY_SLACK_MB over the whole fuzz (the readers' budget is 512 MiB per file)."""

from __future__ import annotations

import contextlib
import io
import json
import os
import resource
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from porosense import cli

MEMORY_SLACK_MB = 700
SEED = 3410


def _maxrss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


@pytest.fixture(scope="module", autouse=True)
def one_parser():
    """The command line's parser built once (building it costs ~0.1 s of CPU per command)."""
    parser = cli.build_parser()
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(cli, "build_parser", lambda: parser)
        yield


def _run(model: Path, data: Path) -> tuple[int, str]:
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        try:
            code = cli.main(["predict", "--model", str(model), "--data", str(data)])
        except SystemExit as exc:  # argparse
            code = int(exc.code or 0)
    return code, err.getvalue()


def _check(outcomes: Counter, code: int, err: str, what: str) -> None:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    ok = code in (0, 2, 4) and "Traceback" not in err and (code == 0 or len(lines) == 1)
    assert ok, f"{what}: exit {code}, stderr:\n{err[-3000:]}"
    outcomes[code] += 1


def _overwrite(path: Path, data: bytes) -> None:
    """Write ``data`` over the file in place and cut it to length. Path.write_bytes truncates to
    zero first, which hands the file's block back: on a disk mounted with discard that waits
    ~3 ms per case (28 s of the fuzz's 10,000), against 0.02 ms in place; the bytes are the same."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT, 0o644)
    try:
        os.write(fd, data)
        os.ftruncate(fd, len(data))
    finally:
        os.close(fd)


def _mutate(rng: np.random.Generator, data: bytes) -> bytes:
    b = bytearray(data)
    kind = rng.integers(0, 6)
    if kind == 0:  # flip bits
        for _ in range(int(rng.integers(1, 9))):
            i = int(rng.integers(0, len(b)))
            b[i] ^= 1 << int(rng.integers(0, 8))
    elif kind == 1:  # random bytes over a span
        i = int(rng.integers(0, len(b)))
        n = int(rng.integers(1, 33))
        b[i : i + n] = rng.integers(0, 256, n, dtype=np.uint8).tobytes()
    elif kind == 2:  # truncate
        b = b[: int(rng.integers(0, len(b)))]
    elif kind == 3:  # delete a span
        i = int(rng.integers(0, len(b)))
        del b[i : i + int(rng.integers(1, 65))]
    elif kind == 4:  # duplicate a span
        i = int(rng.integers(0, len(b)))
        b[i:i] = b[i : i + int(rng.integers(1, 129))]
    else:  # extreme values in the bytes of a 4- or 8-byte word
        i = int(rng.integers(0, max(1, len(b) - 8)))
        b[i : i + 8] = rng.choice([b"\xff" * 8, b"\x7f" * 8, b"\x00" * 8, b"\x00\x00\xf8\x7f" * 2])
    return bytes(b)


@pytest.fixture(scope="module")
def seeds(tmp_path_factory) -> dict:
    import h5py
    from scipy.io import savemat

    from porosense import ident

    d = tmp_path_factory.mktemp("hostile")
    t = np.arange(60) * 0.02
    u = -40 * (1 - np.exp(-t / 0.3))
    y = 0.3 * u + 0.1 * np.sin(t)
    model = ident.Linear(n_poles=1, n_zeros=0).fit(u=[u[:, None]], y=[y], ts=0.02, inputs=["dR_0"], output="strain_0")
    model.save(d / "model.json")
    (d / "rec.csv").write_text("t,dR_0,strain_0\n" + "".join(f"{a:.2f},{b:.3f},{c:.4f}\n" for a, b, c in zip(t, u, y)))
    savemat(d / "rec_v5.mat", {"t": t, "dR_0": u, "strain_0": y, "Ts": 0.02})
    with h5py.File(d / "rec_v73.mat", "w", userblock_size=512) as fh:
        for name, v in (("t", t), ("dR_0", u), ("strain_0", y)):
            ds = fh.create_dataset(name, data=v[None, :])
            ds.attrs["MATLAB_class"] = np.bytes_(b"double")
    with open(d / "rec_v73.mat", "r+b") as fh:
        fh.write(b"MATLAB 7.3 MAT-file".ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02IM")
    assert _run(d / "model.json", d / "rec.csv")[0] == 0
    assert _run(d / "model.json", d / "rec_v5.mat")[0] == 0
    assert _run(d / "model.json", d / "rec_v73.mat")[0] == 0
    return {"dir": d, "model": d / "model.json", "csv": d / "rec.csv", "v5": d / "rec_v5.mat", "v73": d / "rec_v73.mat"}


CASES = 1000  # per test; ten tests: 10,000 cases
# v5 reads fork a child each (the isolation of scipy's reader): the costliest, so fewer of them.
PARTS = [*(("csv", k) for k in range(4)), *(("model", k) for k in range(3)), ("v5", 0), ("v5", 1), ("v73", 0)]


@pytest.mark.parametrize(("kind", "part"), PARTS)
def test_fuzzed_files_end_in_one_line(seeds, kind, part, tmp_path):
    rng = np.random.default_rng([SEED, ["csv", "v5", "v73", "model"].index(kind), part])
    base = seeds["model" if kind == "model" else kind].read_bytes()
    target = tmp_path / ("m.json" if kind == "model" else f"r{seeds[kind].suffix}")
    outcomes: Counter = Counter()
    rss0 = _maxrss_mb()
    for i in range(CASES):
        _overwrite(target, _mutate(rng, base))
        model, data = (target, seeds["csv"]) if kind == "model" else (seeds["model"], target)
        code, err = _run(model, data)
        _check(outcomes, code, err, f"{kind} case {i}")
    grown = _maxrss_mb() - rss0
    print(
        f"fuzz {kind} part {part}: {CASES} mutated files: exit {dict(sorted(outcomes.items()))}; peak memory +{grown:.0f} MB"
    )
    assert grown < MEMORY_SLACK_MB
    assert outcomes[0] < CASES  # the mutations do damage files


def _hdf5(path: Path, build) -> Path:
    import h5py

    with h5py.File(path, "w") as fh:
        build(fh)
    return path


def test_files_made_to_hurt_end_in_one_line(seeds, tmp_path):
    import h5py

    d = tmp_path
    cases = {}

    def huge(fh):
        fh.create_dataset("dR_0", shape=(100_000, 100_000), dtype="f8", chunks=(1000, 1000))

    cases["dataset declared 1e5 x 1e5"] = _hdf5(d / "huge.mat", huge)

    def loop(fh):
        g = fh.create_group("s")
        g["a"] = h5py.SoftLink("/s/b")
        g["b"] = h5py.SoftLink("/s/a")
        fh["dR_0"] = h5py.SoftLink("/dR_0")

    cases["soft-link loop"] = _hdf5(d / "loop.mat", loop)

    def external(fh):
        fh["dR_0"] = h5py.ExternalLink(str(d / "elsewhere.h5"), "/x")
        fh["t"] = h5py.ExternalLink("/etc/passwd", "/x")

    cases["external links"] = _hdf5(d / "external.mat", external)

    def external_beside_data(fh):
        fh["t"] = np.arange(60)[None, :] * 0.02
        fh["dR_0"] = h5py.ExternalLink(str(seeds["v73"]), "/dR_0")  # a readable target, still not followed

    cases["an external link beside data"] = _hdf5(d / "external_beside_data.mat", external_beside_data)

    def deep(fh):
        g = fh
        for k in range(200):
            g = g.create_group(f"s{k}")
        g.create_dataset("dR_0", data=np.zeros(10))

    cases["structs nested 200 deep"] = _hdf5(d / "deep.mat", deep)
    (d / "nested.json").write_text("[" * 200_000 + "]" * 200_000)
    doc = json.loads(seeds["model"].read_text())
    doc["models"][0]["ts"] = "0.02"
    (d / "ts_string.json").write_text(json.dumps(doc))
    doc["models"][0]["ts"] = 0.02
    doc["models"][0]["theta"][0] = float("nan")
    (d / "theta_nan.json").write_text(json.dumps(doc))
    doc["models"][0]["theta"][0] = float("inf")
    (d / "theta_inf.json").write_text(json.dumps(doc))
    (d / "wide.csv").write_text(",".join(f"c{i}" for i in range(100_000)) + "\n" + ",".join(["1"] * 100_000) + "\n")
    (d / "long_line.csv").write_text("t,dR_0\n" + "1" * 10_000_000 + "\n")
    (d / "binary.csv").write_bytes(bytes(range(256)) * 100)
    expected = {
        "loop.mat": "'dR_0' is a link to /dR_0, not followed (2 more links)",  # and s.a, s.b
        "external.mat": "elsewhere.h5:/x in another file, not followed",
        "external_beside_data.mat": "variable 'dR_0' is a link to",
        "nested.json": "nested 200,000 levels",
        "ts_string.json": 'a string ("0.02")',
        "theta_nan.json": "NaN",
        "theta_inf.json": "Infinity",
    }
    rss0 = _maxrss_mb()
    outcomes: Counter = Counter()
    for what, path in [*cases.items(), *((p.name, p) for p in sorted(d.glob("*.json")) + sorted(d.glob("*.csv")))]:
        is_model = path.suffix == ".json"
        code, err = _run(path if is_model else seeds["model"], seeds["csv"] if is_model else path)
        print(f"{what}: exit {code}: {err.strip()}")
        _check(outcomes, code, err, what)
        assert code != 0, what
        if path.name in expected:
            assert expected[path.name] in err, (what, err)
    assert _maxrss_mb() - rss0 < MEMORY_SLACK_MB
