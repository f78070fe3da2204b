/* The I2C bus seen from simavr's TWI master: dispatches its messages to virtual devices. */
#ifndef SIMBOARD_TWI_BUS_H
#define SIMBOARD_TWI_BUS_H

#include <stdint.h>
#include "sim_avr.h"

typedef struct twi_device_t {
  const char* name;
  uint8_t addr7; /* 7-bit address */
  int absent;    /* 1: never acknowledges (disconnected sensor) */
  void* ctx;
  /* 0 to NACK the address (for example while booting), 1 to ACK */
  int (*start)(void* ctx, int read);
  void (*write)(void* ctx, uint8_t byte);
  uint8_t (*read)(void* ctx);
  void (*stop)(void* ctx);
} twi_device_t;

#define TWI_BUS_MAX_DEVICES 4

typedef struct twi_bus_t {
  avr_t* avr;
  avr_irq_t* irq_in; /* into the AVR's TWI */
  twi_device_t* devices[TWI_BUS_MAX_DEVICES];
  int n_devices;
  twi_device_t* active;
  uint8_t active_addr8;
  uint32_t nacks;            /* address phases nobody acknowledged */
  int write_address_pending; /* SLA+W sent, its status not yet reported */
} twi_bus_t;

int twi_bus_attach(twi_bus_t* bus, avr_t* avr);
void twi_bus_add(twi_bus_t* bus, twi_device_t* dev);
twi_device_t* twi_bus_find(twi_bus_t* bus, const char* name);

#endif
