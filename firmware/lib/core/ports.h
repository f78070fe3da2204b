// The core's ports (Hal, ModelPort, est::Eeprom, est::FlashRom) are interfaces for the host
// builds, where the emulator and the tests plug in their own implementations. The Uno image
// has exactly one implementation of each, so its build (POROSENSE_STATIC_PORTS=1) declares
// them as plain member functions that the board's code defines by forwarding to its class:
// direct calls that link-time optimisation inlines, no vtables (which the AVR copies to RAM).
// Measured on the Uno image: see firmware/Makefile.
#pragma once

#if defined(POROSENSE_STATIC_PORTS) && POROSENSE_STATIC_PORTS
#define PORTS_STATIC 1
#define PORT_FN
#define PORT_ABSTRACT
#define PORT_OVERRIDE
#else
#define PORTS_STATIC 0
#define PORT_FN virtual
#define PORT_ABSTRACT = 0
#define PORT_OVERRIDE override
#endif
