/* simboard: the porosense firmware ELF on a simulated Arduino Uno (atmega328p, 16 MHz).
 *
 * The AVR runs in simavr with a virtual ADS1115 and BNO055 on its TWI bus and UART0 bridged
 * to TCP. With --cosim, a plant process on stdin/stdout is stepped in lock-step with AVR
 * time (see cosim.h); without it, the sensor inputs are the constants given by --vin and
 * --euler. On exit it prints the AVR time simulated and its ratio to wall time. */
#include <errno.h>
#include <getopt.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "sim_avr.h"
#include "sim_elf.h"
#include "sim_regbit.h"
#include "avr_eeprom.h"
#include "avr_extint.h"

#include "ads1115.h"
#include "board.h"
#include "bno055.h"
#include "cosim.h"
#include "pins.h"
#include "twi_bus.h"
#include "uart_bridge.h"

#define EEPROM_SIZE 1024
#define R_EECR 0x3F
#define EECR_EEPE 0x02

typedef struct options_t {
  const char* elf;
  const char* bootloader; /* Intel HEX at the top of the flash; the reset vector points to it */
  const char* eeprom;
  const char* flash_pages;
  int port;
  int cosim;
  double period_us;
  double seconds;   /* stop after this much AVR time (0: run until told) */
  double max_speed; /* at most this many times real time (0: unlimited) */
  double bno_boot_ms;
  unsigned baud;
  int absent_mask;
  int reset_on_connect;
  plant_inputs_t inputs;
} options_t;

static avr_t* avr;
static uint64_t last_cycle;
static plant_inputs_t plant_in;
static ads1115_t ads;
static bno055_t bno;
static twi_bus_t bus;
static uart_bridge_t uart;
static options_t opt;
static uint32_t eeprom_writes, resets;
static int reset_after_ee; /* >0: reset once this many more EEPROM writes started */
static int reset_pending;
static uint8_t pending_events;
static int cosim_fd = -1; /* the plant link; stdout itself goes to stderr */

static double wall_s(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec + ts.tv_nsec * 1e-9;
}

/* INT0/INT1 sit on D2/D3 (a pump output here). simavr polls a low level-triggered pin on
 * every cycle even with the interrupt disabled, which stops a sleeping AVR from skipping
 * ahead; edge semantics are enough for this board. Every reset turns the polling back on. */
static void quiet_level_interrupts(void) {
  avr_extint_set_strict_lvl_trig(avr, 0, 0);
  avr_extint_set_strict_lvl_trig(avr, 1, 0);
}

/* Idle loops must not sleep in real time: time advances, the host does not wait. */
static void no_sleep(avr_t* a, avr_cycle_count_t how_long) {
  (void)a;
  (void)how_long;
}

/* A sleeping AVR jumps to its next cycle timer: this one keeps ticks on time. */
static avr_cycle_count_t on_tick_timer(avr_t* a, avr_cycle_count_t when, void* param) {
  (void)a;
  (void)param;
  return 0;
}

static void arm_tick_timer(uint64_t next_tick) {
  uint64_t now = board_cycles();
  avr_cycle_timer_register(avr, next_tick > now ? next_tick - now : 1, on_tick_timer, NULL);
}

static void on_eecr_write(avr_t* a, avr_io_addr_t addr, uint8_t v, void* param) {
  (void)a;
  (void)addr;
  (void)param;
  if (!(v & EECR_EEPE)) return;
  eeprom_writes++;
  if (reset_after_ee > 0 && --reset_after_ee == 0) reset_pending = 1;
}

static void eeprom_get(uint8_t* buf) {
  avr_eeprom_desc_t d = {.ee = NULL, .offset = 0, .size = EEPROM_SIZE};
  avr_ioctl(avr, AVR_IOCTL_EEPROM_GET, &d);
  memcpy(buf, d.ee, EEPROM_SIZE);
}

static int eeprom_load(const char* path) {
  FILE* f = fopen(path, "rb");
  if (!f) return errno == ENOENT ? 0 : -1; /* a new board starts blank (0xFF) */
  uint8_t buf[EEPROM_SIZE];
  size_t n = fread(buf, 1, sizeof buf, f);
  fclose(f);
  if (n == 0) return 0;
  /* simavr 1.6's EEPROM_SET reports -1 even when it copied: check the copy instead */
  avr_eeprom_desc_t d = {.ee = buf, .offset = 0, .size = (uint32_t)n};
  avr_ioctl(avr, AVR_IOCTL_EEPROM_SET, &d);
  uint8_t now[EEPROM_SIZE];
  eeprom_get(now);
  if (memcmp(now, buf, n) != 0) {
    errno = EIO;
    return -1;
  }
  return 0;
}

static int eeprom_save(const char* path) {
  if (!path) return 0;
  uint8_t buf[EEPROM_SIZE];
  eeprom_get(buf);
  char tmp[4096];
  snprintf(tmp, sizeof tmp, "%s.tmp", path);
  FILE* f = fopen(tmp, "wb");
  if (!f) return -1;
  size_t n = fwrite(buf, 1, sizeof buf, f);
  if (fclose(f) != 0 || n != sizeof buf) return -1;
  return rename(tmp, path); /* readers never see a half-written image */
}

/* An upload through the bootloader (avrdude -D): each page of the file, in order, erased and
 * written, the first `limit` of them only (a torn upload), never the bootloader's. */
#define FLASH_PAGE 128
#define BOOTLOADER_BASE 32256
static int program_flash(const char* path, unsigned limit) {
  FILE* f = path ? fopen(path, "rb") : NULL;
  if (!f) return -1;
  uint8_t rec[4 + FLASH_PAGE];
  unsigned done = 0;
  int rc = 0;
  while (done < limit && fread(rec, 1, sizeof rec, f) == sizeof rec) {
    uint32_t addr = rec[0] | rec[1] << 8 | (uint32_t)rec[2] << 16 | (uint32_t)rec[3] << 24;
    if (addr % FLASH_PAGE || addr + FLASH_PAGE > BOOTLOADER_BASE || addr + FLASH_PAGE > avr->flashend + 1u) {
      rc = -1;
      break;
    }
    memcpy(avr->flash + addr, rec + 4, FLASH_PAGE);
    done++;
  }
  fclose(f);
  return rc;
}

/* MCUSR after a reset from outside: the reset button (and the Uno's DTR line) is an external
 * reset (EXTRF), a power cycle a power-on reset (PORF). A bootloader such as Optiboot waits
 * for an upload only after an external reset. */
static void set_reset_flag(int power_cycle) {
  avr_regbit_setto(avr, power_cycle ? avr->reset_flags.porf : avr->reset_flags.extrf, 1);
}

/* Optiboot (or any bootloader) from an Intel HEX; the BOOTRST fuse's reset vector at its start.
 * The HEX is read here: libsimavr's reader refuses the start-address record (type 03) that
 * arduino-core-avr's optiboot_atmega328.hex carries. */
static int hex_byte(const char* s) {
  unsigned v;
  return sscanf(s, "%2x", &v) == 1 ? (int)v : -1;
}

static int load_bootloader(const char* path) {
  FILE* f = fopen(path, "r");
  if (!f) return -1;
  char line[600];
  uint32_t base = 0, start = UINT32_MAX;
  int rc = -1;
  while (fgets(line, sizeof line, f)) {
    if (line[0] != ':') continue;
    int n = hex_byte(line + 1), hi = hex_byte(line + 3), lo = hex_byte(line + 5), type = hex_byte(line + 7);
    if (n < 0 || hi < 0 || lo < 0 || type < 0 || strlen(line) < (size_t)(11 + 2 * n)) break;
    if (type == 1) {
      rc = start == UINT32_MAX ? -1 : 0;
      break;
    }
    if (type == 2 || type == 4) { /* extended segment / linear address */
      int a = hex_byte(line + 9), b = hex_byte(line + 11);
      if (a < 0 || b < 0) break;
      base = (uint32_t)(a << 8 | b) << (type == 2 ? 4 : 16);
      continue;
    }
    if (type != 0) continue; /* start addresses (03, 05): the reset vector decides */
    uint32_t addr = base + (uint32_t)(hi << 8 | lo);
    if (addr + (uint32_t)n > avr->flashend + 1u) break;
    for (int i = 0; i < n; i++) {
      int v = hex_byte(line + 9 + 2 * i);
      if (v < 0) goto done;
      avr->flash[addr + i] = (uint8_t)v;
    }
    if (n && addr < start) start = addr;
  }
done:
  fclose(f);
  if (rc < 0) return -1;
  avr->reset_pc = start;
  avr->pc = start;
  avr->codeend = avr->flashend;
  return 0;
}

static void avr_board_reset(int power_cycle) {
  /* the EEPROM keeps its contents through a reset whatever simavr does with it */
  uint8_t ee[EEPROM_SIZE];
  eeprom_get(ee);
  uint64_t now = board_cycles();
  avr_reset(avr);
  set_reset_flag(power_cycle);
  if (avr->cycle < last_cycle) board_cycle_base = now - avr->cycle;
  last_cycle = avr->cycle;
  avr_eeprom_desc_t d = {.ee = ee, .offset = 0, .size = EEPROM_SIZE};
  avr_ioctl(avr, AVR_IOCTL_EEPROM_SET, &d);
  avr->frequency = BOARD_FREQUENCY_HZ;
  uart_bridge_configure(&uart);
  quiet_level_interrupts();
  if (power_cycle) {
    ads1115_power_on(&ads);
    bno055_power_on(&bno, board_cycles(), bno.boot_cycles / (BOARD_FREQUENCY_HZ / 1000.0));
  }
  resets++;
  pending_events |= EV_RESET;
}

static void set_absent(int mask) {
  ads.dev.absent = mask & 1;
  bno.dev.absent = (mask >> 1) & 1;
}

static int read_full(int fd, void* buf, size_t n) {
  uint8_t* p = buf;
  while (n) {
    ssize_t k = read(fd, p, n);
    if (k <= 0) {
      if (k < 0 && errno == EINTR) continue;
      return -1;
    }
    p += k;
    n -= (size_t)k;
  }
  return 0;
}

static int write_full(int fd, const void* buf, size_t n) {
  const uint8_t* p = buf;
  while (n) {
    ssize_t k = write(fd, p, n);
    if (k <= 0) {
      if (k < 0 && errno == EINTR) continue;
      return -1;
    }
    p += k;
    n -= (size_t)k;
  }
  return 0;
}

/* One lock-step exchange with the plant; returns 0 to go on, 1 to quit. */
static int cosim_tick(uint32_t seq, int halted) {
  tick_record_t t;
  memset(&t, 0, sizeof t);
  pins_state_t ps;
  pins_read(avr, &ps);
  t.magic = TICK_MAGIC;
  t.seq = seq;
  t.cycles = board_cycles();
  t.pins = ps.level;
  memcpy(t.duty, ps.duty, sizeof t.duty);
  t.events = pending_events | (halted ? EV_HALTED : 0);
  pending_events = 0;
  t.resets = (uint8_t)resets;
  t.twi_nacks = (uint16_t)bus.nacks;
  t.uart_rx = (uint32_t)uart.rx_bytes;
  t.uart_tx = (uint32_t)uart.tx_bytes;
  t.eeprom_writes = eeprom_writes;
  t.uart_dropped = (uint32_t)uart.dropped_bytes;
  t.adc_conversions = ads.conversions;
  reply_record_t r;
  if (write_full(cosim_fd, &t, sizeof t) < 0 || read_full(0, &r, sizeof r) < 0)
    return 1; /* the plant process went away */
  memcpy(plant_in.ain_V, r.ain_V, sizeof plant_in.ain_V);
  memcpy(plant_in.euler_deg, r.euler_deg, sizeof plant_in.euler_deg);
  switch (r.cmd) {
    case CMD_RESET:
      reset_pending = 1;
      break;
    case CMD_POWER_CYCLE:
      reset_pending = 2;
      break;
    case CMD_SAVE_EEPROM:
      pending_events |= eeprom_save(opt.eeprom) == 0 ? EV_EEPROM_SAVED : EV_FAULT;
      break;
    case CMD_SET_ABSENT:
      set_absent(r.arg8);
      break;
    case CMD_RESET_AFTER_EE:
      reset_after_ee = r.arg16;
      break;
    case CMD_PROGRAM_FLASH:
      if (program_flash(opt.flash_pages, r.arg16) == 0) {
        pending_events |= EV_FLASHED;
        reset_pending = 1; /* the bootloader starts the sketch after an upload */
      } else {
        pending_events |= EV_FAULT;
      }
      break;
    case CMD_QUIT:
      return 1;
    default:
      break;
  }
  return 0;
}

static void usage(FILE* f) {
  fprintf(f,
          "usage: simboard --elf FIRMWARE.elf [options]\n"
          "       simboard --bootloader OPTIBOOT.hex [--elf FIRMWARE.elf] [options]\n"
          "  --bootloader HEX  a bootloader at the top of the flash, started at every reset (as with\n"
          "                    the Uno's BOOTRST fuse); without --elf the application flash is blank\n"
          "  --port N          TCP port for UART0 on 127.0.0.1 (0: chosen by the OS, printed)\n"
          "  --cosim           lock-step plant on stdin/stdout (binary records, see cosim.h)\n"
          "  --period-us US    plant exchange period in AVR time (default 1000 us)\n"
          "  --eeprom FILE     EEPROM image: loaded if present, saved on exit and on request\n"
          "  --flash-pages FILE  pages CMD_PROGRAM_FLASH uploads (u32 address + 128 bytes each)\n"
          "  --vin A,B,C,D     constant ADS1115 inputs in volts without --cosim\n"
          "  --euler H,R,P     constant BNO055 angles in degrees without --cosim\n"
          "  --seconds S       stop after S seconds of AVR time (default: run until stopped)\n"
          "  --max-speed X     run at most X times faster than real time (0: unlimited)\n"
          "  --absent LIST     sensors that never acknowledge: ads,bno\n"
          "  --bno-boot-ms MS  BNO055 start-up time after power-on (default 0: the Uno's\n"
          "                    bootloader delay covers it on a real board; 650 after RST_SYS)\n"
          "  --baud B          UART line rate used to pace input (default 115200)\n"
          "  --reset-on-connect  reset the AVR when a client connects, as the Uno's DTR does\n");
}

static void parse_floats(const char* s, float* dst, int n) {
  for (int i = 0; i < n && s && *s; i++) {
    char* end;
    dst[i] = strtof(s, &end);
    s = *end == ',' ? end + 1 : NULL;
  }
}

static int parse_options(int argc, char** argv) {
  static const struct option longopts[] = {{"elf", required_argument, 0, 'e'},
                                           {"port", required_argument, 0, 'p'},
                                           {"cosim", no_argument, 0, 'c'},
                                           {"period-us", required_argument, 0, 'P'},
                                           {"eeprom", required_argument, 0, 'E'},
                                           {"flash-pages", required_argument, 0, 'F'},
                                           {"vin", required_argument, 0, 'v'},
                                           {"euler", required_argument, 0, 'u'},
                                           {"seconds", required_argument, 0, 's'},
                                           {"max-speed", required_argument, 0, 'm'},
                                           {"absent", required_argument, 0, 'a'},
                                           {"bno-boot-ms", required_argument, 0, 'b'},
                                           {"baud", required_argument, 0, 'B'},
                                           {"reset-on-connect", no_argument, 0, 'R'},
                                           {"bootloader", required_argument, 0, 'L'},
                                           {"help", no_argument, 0, 'h'},
                                           {0, 0, 0, 0}};
  opt.period_us = 1000.0;
  opt.baud = 115200;
  int c;
  while ((c = getopt_long(argc, argv, "", longopts, NULL)) != -1) {
    switch (c) {
      case 'e':
        opt.elf = optarg;
        break;
      case 'p':
        opt.port = atoi(optarg);
        break;
      case 'c':
        opt.cosim = 1;
        break;
      case 'P':
        opt.period_us = atof(optarg);
        break;
      case 'E':
        opt.eeprom = optarg;
        break;
      case 'F':
        opt.flash_pages = optarg;
        break;
      case 'v':
        parse_floats(optarg, opt.inputs.ain_V, 4);
        break;
      case 'u':
        parse_floats(optarg, opt.inputs.euler_deg, 3);
        break;
      case 's':
        opt.seconds = atof(optarg);
        break;
      case 'm':
        opt.max_speed = atof(optarg);
        break;
      case 'a':
        if (strstr(optarg, "ads")) opt.absent_mask |= 1;
        if (strstr(optarg, "bno")) opt.absent_mask |= 2;
        break;
      case 'b':
        opt.bno_boot_ms = atof(optarg);
        break;
      case 'B':
        opt.baud = (unsigned)atoi(optarg);
        break;
      case 'R':
        opt.reset_on_connect = 1;
        break;
      case 'L':
        opt.bootloader = optarg;
        break;
      case 'h':
        usage(stdout);
        exit(0);
      default:
        usage(stderr);
        return -1;
    }
  }
  if (!opt.elf && !opt.bootloader) {
    usage(stderr);
    return -1;
  }
  if (opt.period_us < 10.0 || opt.baud == 0 || opt.port < 0 || opt.port > 65535) {
    fprintf(stderr, "simboard: bad --period-us, --baud or --port\n");
    return -1;
  }
  return 0;
}

static volatile sig_atomic_t stop_requested;
static void on_signal(int sig) {
  (void)sig;
  stop_requested = 1;
}

int main(int argc, char** argv) {
  if (parse_options(argc, argv) < 0) return 2;
  /* libsimavr prints to stdout: keep the plant link clean by sending that to stderr */
  cosim_fd = dup(1);
  dup2(2, 1);
  elf_firmware_t fw;
  memset(&fw, 0, sizeof fw);
  if (opt.elf && access(opt.elf, R_OK) != 0) {
    fprintf(stderr, "simboard: cannot read firmware %s: %s\n", opt.elf, strerror(errno));
    return 2;
  }
  if (opt.elf && elf_read_firmware(opt.elf, &fw) != 0) {
    fprintf(stderr, "simboard: %s is not a loadable AVR ELF\n", opt.elf);
    return 2;
  }
  avr = avr_make_mcu_by_name("atmega328p");
  if (!avr) {
    fprintf(stderr, "simboard: libsimavr has no atmega328p core\n");
    return 2;
  }
  board_clock_attach(avr);
  avr_init(avr);
  if (opt.elf) avr_load_firmware(avr, &fw);
  if (opt.bootloader && load_bootloader(opt.bootloader) < 0) {
    fprintf(stderr, "simboard: cannot load bootloader %s (an Intel HEX within the flash)\n", opt.bootloader);
    return 2;
  }
  set_reset_flag(1);
  /* simavr 1.6 takes the frequency from the ELF when present: the Uno's is fixed */
  avr->frequency = BOARD_FREQUENCY_HZ;
  avr->sleep = no_sleep;
  avr->log = 1;
  quiet_level_interrupts();
  if (opt.eeprom && eeprom_load(opt.eeprom) < 0) {
    fprintf(stderr, "simboard: cannot read EEPROM image %s: %s\n", opt.eeprom, strerror(errno));
    return 2;
  }
  avr_register_io_write(avr, R_EECR, on_eecr_write, NULL);

  plant_in = opt.inputs;
  ads1115_init(&ads, &plant_in);
  bno055_init(&bno, &plant_in, opt.bno_boot_ms);
  if (twi_bus_attach(&bus, avr) < 0) {
    fprintf(stderr, "simboard: no TWI in this simavr core\n");
    return 2;
  }
  twi_bus_add(&bus, &ads.dev);
  twi_bus_add(&bus, &bno.dev);
  set_absent(opt.absent_mask);
  if (uart_bridge_init(&uart, avr, (uint16_t)opt.port, opt.baud) < 0) {
    fprintf(stderr, "simboard: cannot listen on 127.0.0.1:%d: %s\n", opt.port, strerror(errno));
    return 2;
  }
  signal(SIGINT, on_signal);
  signal(SIGTERM, on_signal);
  signal(SIGPIPE, SIG_IGN);

  uint64_t period = board_us_to_cycles(opt.period_us);
  if (opt.cosim) {
    char hello[128];
    int n = snprintf(hello, sizeof hello, "SIMBOARD 1 PORT %u FREQ %u PERIOD_US %.3f\n", uart.port, BOARD_FREQUENCY_HZ,
                     opt.period_us);
    write_full(cosim_fd, hello, (size_t)n);
  }
  fprintf(stderr, "simboard: %s%s%s on atmega328p at 16 MHz, UART0 at socket://127.0.0.1:%u\n",
          opt.elf ? opt.elf : "blank flash", opt.bootloader ? " + bootloader " : "",
          opt.bootloader ? opt.bootloader : "", uart.port);

  uint64_t stop_at = opt.seconds > 0 ? board_us_to_cycles(opt.seconds * 1e6) : UINT64_MAX;
  uint64_t next_tick = period;
  uint32_t seq = 0;
  int halted = 0;
  arm_tick_timer(next_tick);
  double t0 = wall_s();
  while (!stop_requested) {
    if (!halted) {
      int st = avr_run(avr);
      if (avr->cycle < last_cycle || (avr->pc == avr->reset_pc && st == cpu_Running && last_cycle)) {
        /* reset from inside (watchdog, jump to 0): simavr may have zeroed the
         * cycle counter and dropped its timers and UART flags */
        if (avr->cycle < last_cycle) board_cycle_base += last_cycle;
        uart_bridge_configure(&uart);
        quiet_level_interrupts();
        arm_tick_timer(next_tick);
        resets++;
        pending_events |= EV_RESET;
      }
      last_cycle = avr->cycle;
      if (st == cpu_Done || st == cpu_Crashed) {
        halted = 1;
        fprintf(stderr, "simboard: AVR %s at pc 0x%04x after %.6f s\n", st == cpu_Crashed ? "crashed" : "stopped",
                avr->pc, board_cycles() / (double)BOARD_FREQUENCY_HZ);
      }
    }
    uint64_t now = board_cycles();
    if (halted && now < next_tick) {
      /* a halted AVR still lives in time: the plant and the host go on */
      board_cycle_base += next_tick - now;
      now = next_tick;
    }
    if (now >= next_tick) {
      next_tick += period;
      arm_tick_timer(next_tick);
      /* the plant side sees the board state before the host sees the bytes sent
       * up to now: counters read after a reply already include what caused it */
      if (opt.cosim && cosim_tick(seq++, halted)) break;
      uart_bridge_poll(&uart, now);
      if (opt.reset_on_connect && uart.connected_since_poll) reset_pending = 1;
      if (now >= stop_at) break;
      if (opt.max_speed > 0) {
        double ahead = now / (double)BOARD_FREQUENCY_HZ / opt.max_speed - (wall_s() - t0);
        if (ahead > 0) usleep((useconds_t)(ahead * 1e6));
      }
    }
    if (reset_pending) {
      avr_board_reset(reset_pending == 2);
      arm_tick_timer(next_tick);
      reset_pending = 0;
      halted = 0;
    }
  }
  double wall = wall_s() - t0;
  double sim = board_cycles() / (double)BOARD_FREQUENCY_HZ;
  uart_bridge_close(&uart);
  int rc = 0;
  if (opt.eeprom && eeprom_save(opt.eeprom) < 0) {
    fprintf(stderr, "simboard: cannot write EEPROM image %s: %s\n", opt.eeprom, strerror(errno));
    rc = 1;
  }
  fprintf(stderr,
          "simboard: %.3f s of AVR time (%llu cycles) in %.3f s wall: %.2f x real time; "
          "%u resets, %llu UART bytes in, %llu out\n",
          sim, (unsigned long long)board_cycles(), wall, wall > 0 ? sim / wall : 0.0, resets,
          (unsigned long long)uart.rx_bytes, (unsigned long long)uart.tx_bytes);
  avr_terminate(avr);
  return rc;
}
