/* Virtual TI ADS1115 16-bit delta-sigma ADC (I2C 0x48 with ADDR to GND). */
#ifndef SIMBOARD_ADS1115_H
#define SIMBOARD_ADS1115_H

#include <stdint.h>
#include "board.h"
#include "twi_bus.h"

enum { ADS_REG_CONVERSION = 0, ADS_REG_CONFIG = 1, ADS_REG_LO_THRESH = 2, ADS_REG_HI_THRESH = 3 };

typedef struct ads1115_t {
  twi_device_t dev;
  const plant_inputs_t* inputs;
  uint8_t pointer;
  uint16_t reg[4];   /* config holds bits 14..0; OS is computed on read */
  int converting;    /* a conversion is under way (OS reads 0) */
  uint64_t conv_end; /* board cycle at which it completes */
  uint8_t wbytes;    /* bytes written in this transaction */
  uint8_t wbuf[2];
  uint16_t rlatch; /* register value latched for the read in progress */
  uint8_t rbytes;
  uint32_t conversions; /* completed conversions (statistics) */
} ads1115_t;

void ads1115_init(ads1115_t* a, const plant_inputs_t* inputs);
void ads1115_power_on(ads1115_t* a);
/* Completes due conversions; called before every register access. */
void ads1115_update(ads1115_t* a, uint64_t now);
/* Full-scale range (volts) for the PGA bits; conversion time (cycles) for the DR bits. */
double ads1115_fsr_V(uint16_t config);
uint64_t ads1115_conversion_cycles(uint16_t config);

#endif
