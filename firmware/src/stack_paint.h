// Stack headroom: the RAM between the end of .bss (no heap is used) and the stack is painted
// with a pattern before main(); the bytes still holding it were never touched by the stack.
// Also keeps MCUSR (the reset cause) and disables a watchdog left running by a reset.
#pragma once
#include <stdint.h>

namespace stack_paint {
uint16_t untouched_bytes();  // contiguous painted bytes above .bss
uint8_t reset_cause();       // MCUSR as found at boot
}  // namespace stack_paint
