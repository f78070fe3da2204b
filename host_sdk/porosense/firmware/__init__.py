"""The firmware as package data: the core's C++ sources, the AVR build (ELF, HEX) and the
simboard harness, wherever porosense is installed.

In a source checkout ``core``, ``avr`` and ``simboard`` are links to firmware/lib/core,
firmware/build and tools/simboard/build; a wheel carries copies made when it was built.

>>> from porosense.firmware import files
>>> files.core_dir().joinpath("device.cpp").is_file()    # doctest: +SKIP
True
"""

from porosense.firmware.files import core_dir, elf_path, harness_path, hex_path

__all__ = ["core_dir", "elf_path", "harness_path", "hex_path"]
