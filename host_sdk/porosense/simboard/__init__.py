"""The simboard: the firmware ELF in simavr (tools/simboard) with the simulator as its plant."""

from porosense.simboard.board import DEFAULT_ELF, PinState, SimBoard, SpeedReport, harness_path, measure_speed
from porosense.simboard.plants import BringupPlant, ConstantPlant, Reading, default_plant

__all__ = [
    "DEFAULT_ELF",
    "PinState",
    "SimBoard",
    "SpeedReport",
    "harness_path",
    "measure_speed",
    "BringupPlant",
    "ConstantPlant",
    "Reading",
    "default_plant",
]
