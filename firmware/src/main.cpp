// The porosense sketch: wires the board (drivers), the model store and the device core.
// setup(): outputs off first, watchdog on, sensors up, configuration and model loaded.
// loop(): feed the watchdog, handle commands, run the link watchdog, take sample ticks.
// The core's headers come before any avr-libc header: avr/io.h defines a macro named ADC,
// which would clash with proto::cap::ADC.
#include "device.h"
#include "model_link.h"

#include <avr/wdt.h>

#include "avr_eeprom.h"
#include "avr_flash.h"
#include "board.h"
#include "idle.h"
#include "sample_clock.h"

// Declared extern "C" by Arduino.h, which this file does not include.
extern "C" void setup();
extern "C" void loop();
extern "C" void init();  // the Arduino core's timer and ADC set-up (wiring.c)

namespace {
Board g_board;
AvrEeprom g_eeprom;
AvrFlash g_flash;
dev::ModelLink g_model(g_eeprom, &g_flash);
dev::Device g_device(g_board, g_model);
uint16_t g_clock_rate = 0;

// The image's end in flash: avr-libc's linker script puts the initial values of .data last,
// so the byte after them is the first one the image does not use.
extern "C" char __data_load_end[];

void drain_serial() { g_device.poll_rx(); }

bool work_pending() { return g_device.frame_pending() || sample_clock::pending(); }

void sync_sample_clock() {
  if (g_device.rate_hz() != g_clock_rate) {
    g_clock_rate = g_device.rate_hz();
    sample_clock::set_rate(g_clock_rate);
  }
}
}  // namespace

void setup() {
  Board::outputs_safe();
  wdt_enable(WDTO_1S);
  idle::set_hook(drain_serial);
  g_board.begin();
  g_model.boot((uint16_t)(uintptr_t)__data_load_end);
  g_device.begin();
  sample_clock::begin();
  sync_sample_clock();
}

void loop() {
  wdt_reset();
  g_device.poll();
  sync_sample_clock();
  uint32_t tick_us;
  const uint8_t n = sample_clock::take(&tick_us);
  if (n)
    g_device.on_sample_ticks(n, tick_us);
  else
    idle::sleep(work_pending);
}

// In place of the Arduino core's main(): without serialEventRun() polling HardwareSerial,
// which the firmware does not use (src/uart.h).
int main() {
  init();
  setup();
  for (;;) loop();
}
