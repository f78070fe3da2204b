/* Register behaviour from the ADS1115 datasheet (SBAS444): a pointer register selects
 * conversion (0), config (1), Lo_thresh (2) or Hi_thresh (3); writes are pointer + MSB + LSB,
 * reads return MSB then LSB of the pointed register. Config bit 15 (OS): writing 1 in
 * power-down (single-shot) mode starts a conversion; it reads 0 while converting and 1
 * otherwise. A conversion takes 1/DR and its result is the input difference selected by MUX
 * over the PGA full scale, two's complement, clipped to [-32768, 32767]. */
#include <math.h>
#include <string.h>
#include "ads1115.h"

#define CFG_OS 0x8000u
#define CFG_MODE_SINGLE 0x0100u
#define CFG_DEFAULT 0x8583u

static const double fsr_table[8] = {6.144, 4.096, 2.048, 1.024, 0.512, 0.256, 0.256, 0.256};
static const unsigned dr_table[8] = {8, 16, 32, 64, 128, 250, 475, 860};

double ads1115_fsr_V(uint16_t config) { return fsr_table[(config >> 9) & 7]; }

uint64_t ads1115_conversion_cycles(uint16_t config) {
  return (uint64_t)BOARD_FREQUENCY_HZ / dr_table[(config >> 5) & 7];
}

static double mux_voltage(const ads1115_t* a, uint16_t config) {
  const float* v = a->inputs->ain_V;
  switch ((config >> 12) & 7) {
    case 0:
      return v[0] - v[1];
    case 1:
      return v[0] - v[3];
    case 2:
      return v[1] - v[3];
    case 3:
      return v[2] - v[3];
    default:
      return v[((config >> 12) & 7) - 4];
  }
}

static uint16_t convert(const ads1115_t* a) {
  uint16_t cfg = a->reg[ADS_REG_CONFIG];
  double code = floor(mux_voltage(a, cfg) / ads1115_fsr_V(cfg) * 32768.0);
  if (code > 32767.0) code = 32767.0;
  if (code < -32768.0) code = -32768.0;
  return (uint16_t)(int16_t)code;
}

void ads1115_update(ads1115_t* a, uint64_t now) {
  while (a->converting && now >= a->conv_end) {
    a->reg[ADS_REG_CONVERSION] = convert(a);
    a->conversions++;
    if (a->reg[ADS_REG_CONFIG] & CFG_MODE_SINGLE) {
      a->converting = 0;
    } else {
      /* continuous mode: the next conversion starts right away */
      a->conv_end += ads1115_conversion_cycles(a->reg[ADS_REG_CONFIG]);
    }
  }
}

static void write_config(ads1115_t* a, uint16_t value, uint64_t now) {
  a->reg[ADS_REG_CONFIG] = value & 0x7FFF;
  if (!(value & CFG_MODE_SINGLE)) {
    a->converting = 1; /* continuous: (re)start with the new settings */
    a->conv_end = now + ads1115_conversion_cycles(value);
  } else if ((value & CFG_OS) && !a->converting) {
    a->converting = 1;
    a->conv_end = now + ads1115_conversion_cycles(value);
  }
}

static int ads_start(void* ctx, int read) {
  ads1115_t* a = (ads1115_t*)ctx;
  uint64_t now = board_cycles();
  ads1115_update(a, now);
  a->wbytes = 0;
  a->rbytes = 0;
  if (read) {
    uint16_t v = a->reg[a->pointer];
    if (a->pointer == ADS_REG_CONFIG && !a->converting) v |= CFG_OS;
    a->rlatch = v;
  }
  return 1;
}

static void ads_write(void* ctx, uint8_t byte) {
  ads1115_t* a = (ads1115_t*)ctx;
  if (a->wbytes == 0) {
    a->pointer = byte & 3;
  } else if (a->wbytes <= 2) {
    a->wbuf[a->wbytes - 1] = byte;
    if (a->wbytes == 2 && a->pointer != ADS_REG_CONVERSION) {
      uint16_t v = (uint16_t)(a->wbuf[0] << 8 | a->wbuf[1]);
      uint64_t now = board_cycles();
      ads1115_update(a, now);
      if (a->pointer == ADS_REG_CONFIG)
        write_config(a, v, now);
      else
        a->reg[a->pointer] = v;
    }
  }
  a->wbytes++;
}

static uint8_t ads_read(void* ctx) {
  ads1115_t* a = (ads1115_t*)ctx;
  uint8_t b = a->rbytes == 0 ? (uint8_t)(a->rlatch >> 8) : a->rbytes == 1 ? (uint8_t)a->rlatch : 0xFF;
  a->rbytes++;
  return b;
}

void ads1115_power_on(ads1115_t* a) {
  a->pointer = 0;
  a->reg[ADS_REG_CONVERSION] = 0;
  a->reg[ADS_REG_CONFIG] = CFG_DEFAULT & 0x7FFF;
  a->reg[ADS_REG_LO_THRESH] = 0x8000;
  a->reg[ADS_REG_HI_THRESH] = 0x7FFF;
  a->converting = 0;
  a->wbytes = a->rbytes = 0;
}

void ads1115_init(ads1115_t* a, const plant_inputs_t* inputs) {
  memset(a, 0, sizeof(*a));
  a->inputs = inputs;
  a->dev.name = "ads1115";
  a->dev.addr7 = 0x48;
  a->dev.ctx = a;
  a->dev.start = ads_start;
  a->dev.write = ads_write;
  a->dev.read = ads_read;
  a->dev.stop = NULL;
  ads1115_power_on(a);
}
