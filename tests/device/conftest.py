"""Back-ends of the device conformance suite: the emulator always, the simboard (the real
firmware in simavr) when it is built, a real board with ``--port URL``.

Every conformance test takes ``dev`` (an open Device on a freshly reset board) and
``backend`` (its name, URL and, for the emulator, the Emulator object).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))  # tests/device/models.py

from porosense.device import Device  # noqa: E402
from porosense.protocol._messages import CONFIG_SPECS, ConfigKey  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
ELF = ROOT / "firmware" / "build" / "porosense.elf"
ACTUATOR = "contractor"


@dataclass
class Backend:
    name: str
    url: str
    emulator: object = None  # the Emulator for name == "emulator"
    timeout_scale: float = 1.0

    @property
    def is_emulator(self) -> bool:
        return self.emulator is not None


@pytest.fixture(scope="session")
def simboard_backend():
    """One simboard per test session (per xdist worker); skipped until it and the ELF exist."""
    try:
        from porosense.simboard import SimBoard
    except ImportError as exc:
        pytest.skip(f"porosense.simboard is not available ({exc})")
    if not ELF.is_file():
        pytest.skip(f"firmware ELF {ELF.relative_to(ROOT)} not built (make -C firmware)")
    board = SimBoard(elf=str(ELF), actuator=ACTUATOR)
    with board:
        # The simboard is usually faster than real time; allow for a loaded machine.
        yield Backend("simboard", board.url, None, float(getattr(board, "timeout_scale", 5.0)))


def pytest_generate_tests(metafunc):
    """Every conformance test runs on each back-end; the real board only with --port."""
    if "backend" in metafunc.fixturenames:
        params = ["emulator", pytest.param("simboard", marks=pytest.mark.simboard)]
        if metafunc.config.getoption("--port", default=None):
            params.append(pytest.param("hardware", marks=pytest.mark.hardware))
        metafunc.parametrize("backend", params, indirect=True)


@pytest.fixture
def backend(request):
    if request.param == "emulator":
        from porosense.emulator import Emulator

        with Emulator(actuator=ACTUATOR, seed=1) as emu:
            yield Backend("emulator", emu.url, emu)
            assert emu.error is None, f"emulator thread failed: {emu.error!r}"
    elif request.param == "simboard":
        yield request.getfixturevalue("simboard_backend")
    else:
        yield Backend("hardware", request.config.getoption("--port"), None, 1.0)


@pytest.fixture
def dev(backend):
    """An open Device on a board in its idle state: not streaming, outputs off, watchdog at
    its default (a fresh emulator per test; the simboard and a real board are shared, so
    tests compare counters before and after rather than with zero)."""
    with Device.open(backend.url, timeout_scale=backend.timeout_scale, seed=7) as d:
        if not backend.is_emulator:
            d.stop_stream()
            d.set_outputs()
            d.set_watchdog(CONFIG_SPECS[ConfigKey.WATCHDOG_MS].default)
        yield d


@pytest.fixture(scope="session")
def blob() -> bytes:
    """A one-output Wiener-Hammerstein model blob."""
    from models import make_blob

    return make_blob(1)


@pytest.fixture(scope="session")
def blob3() -> bytes:
    """A three-output model blob (different from ``blob``)."""
    from models import make_blob

    return make_blob(3, model_id=0x5EED0003, poles=0.8)
