/* Virtual Bosch BNO055 absolute orientation sensor (I2C 0x28, COM3 low). */
#ifndef SIMBOARD_BNO055_H
#define SIMBOARD_BNO055_H

#include <stdint.h>
#include "board.h"
#include "twi_bus.h"

enum {
  BNO_CHIP_ID = 0x00,
  BNO_PAGE_ID = 0x07,
  BNO_EUL_DATA = 0x1A,
  BNO_TEMP = 0x34,
  BNO_CALIB_STAT = 0x35,
  BNO_ST_RESULT = 0x36,
  BNO_SYS_STATUS = 0x39,
  BNO_SYS_ERR = 0x3A,
  BNO_UNIT_SEL = 0x3B,
  BNO_OPR_MODE = 0x3D,
  BNO_PWR_MODE = 0x3E,
  BNO_SYS_TRIGGER = 0x3F
};

typedef struct bno055_t {
  twi_device_t dev;
  const plant_inputs_t* inputs;
  uint8_t page0[128], page1[128];
  uint8_t page;
  uint8_t pointer;
  int first_byte;         /* next written byte is the register address */
  uint8_t mode;           /* operating mode in effect */
  uint8_t mode_requested; /* last value written to OPR_MODE */
  uint64_t mode_ready_at; /* board cycle when mode_requested takes effect */
  uint64_t booted_at;     /* board cycle when the device answers after a reset */
  uint64_t fusion_since;  /* board cycle when fusion started (calibration ramps from it) */
  uint8_t calib_level;    /* 0..3, reached so far */
  uint64_t boot_cycles;   /* POR / RST_SYS time */
  uint64_t to_config_cycles, to_operation_cycles;
  uint64_t calib_step_cycles;
} bno055_t;

/* boot_ms: the time after a reset during which the device NACKs (650 ms on the datasheet). */
void bno055_init(bno055_t* b, const plant_inputs_t* inputs, double boot_ms);
void bno055_power_on(bno055_t* b, uint64_t now, double boot_ms);
void bno055_update(bno055_t* b, uint64_t now);

#endif
