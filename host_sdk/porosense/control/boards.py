"""Open a board for a control run: an in-process emulator or simboard (which know the true
strain) or any pyserial URL (a real board: no truth).

Port forms: ``emulator`` or ``emulator:ACTUATOR`` (the firmware core on this computer over the
simulator, in real time sped up ``EMULATOR_SPEED`` times: the board's clock, not the host's
reading, paces the run, so commands land when the host sends them), ``simboard`` or ``simboard:ACTUATOR`` (the
real firmware in simavr), anything else is a pyserial URL (``/dev/ttyACM0``,
``socket://127.0.0.1:5000``).
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable

import numpy as np

from porosense.errors import InputError

#: Truth by device time: device times (us) -> {name: values}.
TruthSource = Callable[[np.ndarray], dict]

SIM_BACKENDS = ("emulator", "simboard")
#: Device time runs this many times faster than wall time on the emulator. 5 keeps the board's
#: longest link watchdog (10 s) at 2 s of wall time: a busy computer pausing this process for
#: a second must not vent a run.
EMULATOR_SPEED = 5.0


def parse_port(port: str, default_actuator: str = "contractor") -> tuple[str, str | None]:
    """("emulator" | "simboard" | "url", actuator or None)."""
    if not port:
        raise InputError("--port is empty: give emulator, simboard or a serial URL such as /dev/ttyACM0")
    head, _, tail = port.partition(":")
    if head in SIM_BACKENDS:
        from porosense.sim.plant import ACTUATORS

        actuator = tail or default_actuator
        if actuator not in ACTUATORS:
            raise InputError(f"--port {port}: unknown actuator '{actuator}' (known: {', '.join(ACTUATORS)})")
        return head, actuator
    return "url", None


@contextlib.contextmanager
def open_control_board(port: str, *, load_g: float = 0.0, seed: int = 0, porosity=None):
    """Yield ``(Device, truth or None)`` for ``port`` (see the module docstring); ``load_g`` (g)
    and ``porosity`` (%) set the simulated actuator (ignored for a real board)."""
    from porosense.device import Device

    kind, actuator = parse_port(port)
    if kind == "emulator":
        from porosense.emulator import Emulator

        # A busy host computer delays samples but never skips them: the run stays regular.
        with Emulator(
            actuator,
            load_g=load_g,
            seed=seed,
            porosity=porosity,
            truth_log=True,
            realtime=True,
            speed=EMULATOR_SPEED,
            max_catch_up_s=3600.0,
        ) as emu:
            with Device.open(emu.url, timeout_scale=4.0) as dev:
                yield dev, emu.truth
    elif kind == "simboard":
        from porosense.demo import _simboard_truth
        from porosense.simboard import DEFAULT_ELF, SimBoard

        with SimBoard(DEFAULT_ELF, actuator=actuator, seed=seed, load_g=load_g, porosity=porosity) as sb:
            with Device.open(sb.url, timeout_scale=4.0) as dev:
                yield dev, _simboard_truth(sb)
    else:
        with Device.open(port) as dev:
            yield dev, None
