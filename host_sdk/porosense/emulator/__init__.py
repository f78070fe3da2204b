"""The porosense board without hardware: the firmware's own core (firmware/lib/core, built
for this computer) driven through a C interface, over the simulator plant.

>>> from porosense.emulator import Emulator, Faults
>>> with Emulator(actuator="contractor") as emu:          # doctest: +SKIP
...     print(emu.url)                                    # socket://127.0.0.1:PORT

The Python side is the hardware only (porosense.sim for pressures, foam, piezoresistance and
sensor voltages; a clock; a serial line); faults are injected there (:class:`Faults`).
"""

from porosense.emulator.board import BoardCore, BoardStats
from porosense.emulator.emulator import Emulator, EmulatorStats
from porosense.emulator.faults import Faults, FaultyLink, LinkDamage

__all__ = ["BoardCore", "BoardStats", "Emulator", "EmulatorStats", "Faults", "FaultyLink", "LinkDamage"]
