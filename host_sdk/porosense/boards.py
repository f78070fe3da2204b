"""Open a board by name: the emulator, the simboard or a real board's serial URL.

Names (``--port`` of ``control``, ``--board`` of ``demo``):

- ``emulator`` or ``emulator:ACTUATOR``: the firmware core on this computer over the simulator,
  in real time sped up ``EMULATOR_SPEED`` times (the board's clock, not the host's reading,
  paces the run, so commands land when the host sends them);
- ``simboard`` or ``simboard:ACTUATOR``: the real firmware ELF in simavr;
- anything else: a pyserial URL of a real board (``/dev/ttyACM0``, ``socket://127.0.0.1:5000``).

The simulated boards know the true outputs of their actuator (:attr:`OpenBoard.truth`) and can
be programmed like avrdude -D does (:attr:`OpenBoard.upload`); a real board has neither.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from porosense.device import Device
from porosense.emulator import Emulator
from porosense.errors import InputError
from porosense.experiment import TruthSource
from porosense.sim import ACTUATORS
from porosense.simboard import DEFAULT_ELF, SimBoard

#: ``upload(pages)`` programs flash pages and resets the board, as avrdude -D does.
Uploader = Callable[..., object]

SIM_BACKENDS = ("emulator", "simboard")
#: Device time runs this many times faster than wall time on the emulator. 5 keeps the board's
#: longest host-link watchdog (SIM_WATCHDOG_MS, 10 s) at 2 s of wall time: a busy computer
#: pausing this process for a second must not vent a run (10 halved that margin; the demo's
#: 729 s of board time take 146 s of wall time instead of 73).
EMULATOR_SPEED = 5.0
#: Host-link watchdog of a simulated board (ms of board time; the firmware's largest), set when
#: the board opens (and again after anything that resets it): its clock runs ahead of the host's,
#: and at the default 1 s a pause of 0.2 s of this computer vented a demo recording at load 17.
SIM_WATCHDOG_MS = 10000
#: Reply timeouts of a simulated board, times the real board's: a loaded computer answers late.
SIM_TIMEOUT_SCALE = 4.0
DEFAULT_ACTUATOR = "contractor"


@dataclass
class OpenBoard:
    """A board opened by :func:`open_board`.

    Attributes
    ----------
    device : Device
        The protocol client (on a simulated board with the link watchdog at SIM_WATCHDOG_MS).
    kind : str
        ``"emulator"``, ``"simboard"`` or ``"url"`` (a real board).
    actuator : str or None
        The simulated actuator (None for a real board).
    truth : TruthSource or None
        Device times (us) -> true outputs of a simulated board; None for a real board.
    upload : Uploader or None
        ``upload(pages)`` writes flash pages (the flash model store) and resets the board; None
        for a real board (``porosense flash --store flash`` uploads there).
    """

    device: Device
    kind: str
    actuator: str | None
    truth: TruthSource | None = None
    upload: Uploader | None = None

    @property
    def simulated(self) -> bool:
        """True for the emulator and the simboard."""
        return self.kind != "url"


def parse_port(port: str, default_actuator: str = DEFAULT_ACTUATOR) -> tuple[str, str | None]:
    """Split a board name.

    Parameters
    ----------
    port : str
        ``emulator[:ACTUATOR]``, ``simboard[:ACTUATOR]`` or a pyserial URL.
    default_actuator : str
        The actuator of a simulated board whose name gives none.

    Returns
    -------
    tuple of (str, str or None)
        (``"emulator"`` | ``"simboard"`` | ``"url"``, the actuator or None for a URL).
    """
    if not port:
        raise InputError("the board is empty: give emulator, simboard or a serial URL such as /dev/ttyACM0")
    head, _, tail = port.partition(":")
    if head in SIM_BACKENDS:
        actuator = tail or default_actuator
        if actuator not in ACTUATORS:
            raise InputError(f"board {port}: unknown actuator '{actuator}' (known: {', '.join(ACTUATORS)})")
        return head, actuator
    return "url", None


@contextlib.contextmanager
def open_board(
    port: str,
    *,
    actuator: str | None = None,
    load_g: float = 0.0,
    seed: int = 0,
    porosity: float | None = None,
    physics=None,
) -> Iterator[OpenBoard]:
    """Open the board that ``port`` names (see the module docstring) and close it afterwards.

    Parameters
    ----------
    port : str
        ``emulator[:ACTUATOR]``, ``simboard[:ACTUATOR]`` or a pyserial URL.
    actuator : str, optional
        The simulated actuator when ``port`` names none (default ``contractor``); an actuator
        that disagrees with the one ``port`` names is refused.
    load_g : float
        Hanging load of the simulated actuator (g).
    seed : int
        Noise seed of the simulated actuator.
    porosity : float, optional
        Porosity of the simulated actuator (%; default the actuator's).
    physics : porosense.sim.Physics, optional
        Parameters of the simulated actuator (``porosense calibrate``; default the built-in ones).

    Yields
    ------
    OpenBoard
        The device with its truth and upload functions (None for a real board).
    """
    kind, named = parse_port(port, actuator or DEFAULT_ACTUATOR)
    if actuator is not None and named is not None and named != actuator:
        raise InputError(f"board {port} names actuator '{named}' but '{actuator}' was asked for")
    plant = None
    if physics is not None and kind in ("emulator", "simboard"):
        from porosense.sim import make_plant

        plant = make_plant(named, porosity=porosity, load_g=load_g, seed=seed, physics=physics)
    if kind == "emulator":
        # A busy host computer delays samples but never skips them: the recordings stay regular.
        with Emulator(
            named,
            load_g=load_g,
            seed=seed,
            porosity=porosity,
            truth_log=True,
            realtime=True,
            speed=EMULATOR_SPEED,
            max_catch_up_s=3600.0,
            plant=plant,
        ) as emu:
            with Device.open(emu.url, timeout_scale=SIM_TIMEOUT_SCALE) as dev:
                dev.set_watchdog(SIM_WATCHDOG_MS)
                yield OpenBoard(dev, kind, named, emu.truth, emu.program_flash)
    elif kind == "simboard":
        with SimBoard(DEFAULT_ELF, actuator=named, seed=seed, load_g=load_g, porosity=porosity, plant=plant) as sb:
            with Device.open(sb.url, timeout_scale=SIM_TIMEOUT_SCALE) as dev:
                dev.set_watchdog(SIM_WATCHDOG_MS)
                yield OpenBoard(dev, kind, named, simboard_truth(sb), sb.program_flash)
    else:
        with Device.open(port) as dev:
            yield OpenBoard(dev, kind, None)


def simboard_truth(sb) -> TruthSource:
    """The true outputs of a running :class:`porosense.simboard.SimBoard` by device time.

    Parameters
    ----------
    sb : SimBoard
        The running simboard (its ground-truth log in AVR time since power-on).

    Returns
    -------
    TruthSource
        Device times (us, the firmware's clock since its latest reset) -> {name: values}.
    """

    def truth(t_us: np.ndarray) -> dict:
        cols = sb.truth_columns()
        t = cols.pop("t")
        # The firmware's microsecond clock counts AVR time since the latest reset (an upload
        # resets the board); the truth log counts it since power-on.
        return {k: np.interp(t_us * 1e-6 + sb.last_reset_s, t, v) for k, v in cols.items() if v.dtype.kind == "f"}

    return truth
