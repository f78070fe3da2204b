"""The Python twin of the porosense board: the firmware's protocol semantics over the simulator.

>>> from porosense.emulator import Emulator, Faults
>>> with Emulator(actuator="contractor") as emu:          # doctest: +SKIP
...     print(emu.url)                                    # socket://127.0.0.1:PORT

Backed by porosense.sim (plant: pressures, foam, piezoresistance, sensor voltages) and the
bit-exact fixed-point estimator of porosense.quant; fault injection through :class:`Faults`.
"""

from porosense.emulator.core import BoardCore, BoardStats
from porosense.emulator.emulator import Emulator, EmulatorStats
from porosense.emulator.faults import Faults, FaultyLink, LinkDamage

__all__ = ["BoardCore", "BoardStats", "Emulator", "EmulatorStats", "Faults", "FaultyLink", "LinkDamage"]
