/* Register behaviour from the BNO055 datasheet (BST-BNO055-DS000): page 0 holds the chip
 * id (0xA0), Euler angles at 0x1A..0x1F (heading, roll, pitch; 16 LSB/degree or 900 LSB/rad
 * per UNIT_SEL bit 2), CALIB_STAT (sys|gyr|acc|mag, two bits each), SYS_STATUS (0 idle,
 * 5 fusion running, 6 running without fusion) and OPR_MODE. Mode switches take effect after
 * 7 ms from CONFIGMODE to an operating mode and 19 ms from an operating mode back to
 * CONFIGMODE; OPR_MODE, SYS_STATUS and the data registers show the mode in effect.
 * PAGE_ID (0x07) selects register page 0 or 1. Writes auto-increment the register
 * pointer; the first byte of a write sets it. */
#include <math.h>
#include <string.h>
#include "bno055.h"

#define MODE_CONFIG 0x00

static int is_fusion(uint8_t mode) { return mode >= 0x08 && mode <= 0x0C; }

static void reset_registers(bno055_t* b) {
  memset(b->page0, 0, sizeof b->page0);
  memset(b->page1, 0, sizeof b->page1);
  b->page0[0x00] = 0xA0; /* CHIP_ID */
  b->page0[0x01] = 0xFB; /* ACC_ID */
  b->page0[0x02] = 0x32; /* MAG_ID */
  b->page0[0x03] = 0x0F; /* GYR_ID */
  b->page0[0x04] = 0x11; /* SW_REV_ID LSB */
  b->page0[0x05] = 0x03; /* SW_REV_ID MSB */
  b->page0[0x06] = 0x15; /* BL_REV_ID */
  b->page0[BNO_TEMP] = 25;
  b->page0[BNO_ST_RESULT] = 0x0F;
  b->page0[BNO_UNIT_SEL] = 0x80;
  b->page0[0x41] = 0x24; /* AXIS_MAP_CONFIG */
  b->page1[0x07] = 0x01;
  b->page1[0x08] = 0x0D; /* ACC_Config */
  b->page1[0x09] = 0x6D; /* MAG_Config */
  b->page1[0x0A] = 0x38; /* GYR_Config_0 */
  b->page = 0;
  b->pointer = 0;
  b->first_byte = 1;
  b->mode = b->mode_requested = MODE_CONFIG;
  b->mode_ready_at = 0;
  b->calib_level = 0;
}

void bno055_power_on(bno055_t* b, uint64_t now, double boot_ms) {
  reset_registers(b);
  b->booted_at = now + board_us_to_cycles(boot_ms * 1000.0);
}

void bno055_update(bno055_t* b, uint64_t now) {
  if (b->mode != b->mode_requested && now >= b->mode_ready_at) {
    b->mode = b->mode_requested;
    if (is_fusion(b->mode)) b->fusion_since = b->mode_ready_at;
  }
  if (is_fusion(b->mode) && b->calib_level < 3) {
    uint64_t level = (now - b->fusion_since) / b->calib_step_cycles;
    if (level > b->calib_level) b->calib_level = level > 3 ? 3 : (uint8_t)level;
  }
}

static void put_angle(uint8_t* dst, double deg, int radians) {
  double lsb = radians ? deg * M_PI / 180.0 * 900.0 : deg * 16.0;
  long v = lround(lsb);
  if (v > 32767) v = 32767;
  if (v < -32768) v = -32768;
  uint16_t u = (uint16_t)(int16_t)v;
  dst[0] = (uint8_t)u;
  dst[1] = (uint8_t)(u >> 8);
}

static uint8_t read_register(bno055_t* b, uint8_t reg) {
  if (reg == BNO_PAGE_ID) return b->page;
  if (b->page == 1) return b->page1[reg & 0x7F];
  if (reg >= BNO_EUL_DATA && reg < BNO_EUL_DATA + 6) {
    uint8_t eul[6] = {0};
    if (is_fusion(b->mode)) {
      const float* e = b->inputs->euler_deg;
      int rad = (b->page0[BNO_UNIT_SEL] >> 2) & 1;
      double heading = fmod(e[0], 360.0);
      if (heading < 0) heading += 360.0;
      put_angle(eul + 0, heading, rad);
      put_angle(eul + 2, e[1], rad);
      put_angle(eul + 4, e[2], rad);
    }
    return eul[reg - BNO_EUL_DATA];
  }
  switch (reg) {
    case BNO_CALIB_STAT:
      return (uint8_t)(b->calib_level * 0x55);
    case BNO_SYS_STATUS:
      return b->mode == MODE_CONFIG ? 0 : is_fusion(b->mode) ? 5 : 6;
    case BNO_OPR_MODE:
      return b->mode; /* the mode in effect: a switch shows once it has completed */
    default:
      return b->page0[reg & 0x7F];
  }
}

static void write_register(bno055_t* b, uint8_t reg, uint8_t v, uint64_t now) {
  if (reg == BNO_PAGE_ID) {
    b->page = v & 1;
    return;
  }
  if (b->page == 1) {
    if (reg >= 0x08 && reg <= 0x1F) b->page1[reg] = v;
    return;
  }
  switch (reg) {
    case BNO_OPR_MODE: {
      uint8_t m = v & 0x0F;
      if (m == b->mode_requested) return;
      b->mode_requested = m;
      if (m == b->mode) return; /* a pending switch cancelled */
      b->mode_ready_at = now + (m == MODE_CONFIG ? b->to_config_cycles : b->to_operation_cycles);
      return;
    }
    case BNO_SYS_TRIGGER:
      if (v & 0x20) { /* RST_SYS */
        bno055_power_on(b, now, (double)b->boot_cycles / (BOARD_FREQUENCY_HZ / 1000.0));
        return;
      }
      b->page0[reg] = v & 0xC1;
      return;
    case BNO_PWR_MODE:
    case 0x40:
    case 0x41:
    case 0x42: /* TEMP_SOURCE, AXIS_MAP_CONFIG, AXIS_MAP_SIGN */
    case BNO_UNIT_SEL:
      if (b->mode == MODE_CONFIG) /* writable in CONFIGMODE only */
        b->page0[reg] = v;
      return;
    default:
      if (reg >= 0x55 && reg <= 0x6A && b->mode == MODE_CONFIG) /* calibration offsets */
        b->page0[reg] = v;
      return;
  }
}

static int bno_start(void* ctx, int read) {
  bno055_t* b = (bno055_t*)ctx;
  (void)read;
  uint64_t now = board_cycles();
  if (now < b->booted_at) return 0; /* still booting: no acknowledge */
  bno055_update(b, now);
  b->first_byte = 1;
  return 1;
}

static void bno_write(void* ctx, uint8_t byte) {
  bno055_t* b = (bno055_t*)ctx;
  if (b->first_byte) {
    b->pointer = byte & 0x7F;
    b->first_byte = 0;
    return;
  }
  write_register(b, b->pointer, byte, board_cycles());
  b->pointer = (b->pointer + 1) & 0x7F;
}

static uint8_t bno_read(void* ctx) {
  bno055_t* b = (bno055_t*)ctx;
  uint8_t v = read_register(b, b->pointer);
  b->pointer = (b->pointer + 1) & 0x7F;
  return v;
}

void bno055_init(bno055_t* b, const plant_inputs_t* inputs, double boot_ms) {
  memset(b, 0, sizeof(*b));
  b->inputs = inputs;
  b->dev.name = "bno055";
  b->dev.addr7 = 0x28;
  b->dev.ctx = b;
  b->dev.start = bno_start;
  b->dev.write = bno_write;
  b->dev.read = bno_read;
  b->to_config_cycles = board_us_to_cycles(19000);
  b->to_operation_cycles = board_us_to_cycles(7000);
  b->calib_step_cycles = board_us_to_cycles(250000);
  b->boot_cycles = board_us_to_cycles(650000);
  bno055_power_on(b, 0, boot_ms);
}
