"""The simboard: the firmware ELF in simavr (tools/simboard) with the simulator as its plant."""

from porosense.simboard.board import DEFAULT_ELF, PinState, SimBoard, harness_path
from porosense.simboard.plants import BringupPlant, ConstantPlant, Reading, default_plant

__all__ = ["DEFAULT_ELF", "PinState", "SimBoard", "harness_path", "BringupPlant", "ConstantPlant",
           "Reading", "default_plant"]
