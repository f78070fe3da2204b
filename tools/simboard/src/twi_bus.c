/* simavr's TWI master raises one OUTPUT irq per bus event (START+address, WRITE byte,
 * READ request, STOP) and expects the addressed slave to answer synchronously on the
 * INPUT irq: an ACK for the address and written bytes, the data byte for a read.
 * simavr 1.6 keeps the last ACK state between bus events, so a NACK (an absent device, or
 * one that is booting) is sent explicitly as an ACK message with data 0. It also reports
 * the outcome of an SLA+W with the data-phase codes (0x28/0x30); the datasheet's codes are
 * 0x18 (SLA+W, ACK) and 0x20 (SLA+W, NACK), which Wire maps to endTransmission() = 2 for an
 * absent device, so the status register is corrected as it is set. */
#include <string.h>
#include "avr_twi.h"
#include "twi_bus.h"

#define R_TWSR 0xB9
#define TW_MT_SLA_ACK 0x18
#define TW_MT_SLA_NACK 0x20
#define TW_MT_DATA_ACK 0x28
#define TW_MT_DATA_NACK 0x30

static void twi_bus_status(struct avr_irq_t* irq, uint32_t value, void* param) {
  (void)irq;
  twi_bus_t* bus = (twi_bus_t*)param;
  if (!bus->write_address_pending) return;
  bus->write_address_pending = 0;
  uint8_t fixed = value == TW_MT_DATA_ACK ? TW_MT_SLA_ACK : value == TW_MT_DATA_NACK ? TW_MT_SLA_NACK : 0;
  if (fixed) bus->avr->data[R_TWSR] = (uint8_t)((bus->avr->data[R_TWSR] & 0x07) | fixed);
}

static void twi_bus_output(struct avr_irq_t* irq, uint32_t value, void* param) {
  (void)irq;
  twi_bus_t* bus = (twi_bus_t*)param;
  avr_twi_msg_irq_t m;
  m.u.v = value;
  uint8_t msg = m.u.twi.msg;
  uint8_t addr8 = m.u.twi.addr;

  if (msg & TWI_COND_STOP) {
    if (bus->active && bus->active->stop) bus->active->stop(bus->active->ctx);
    bus->active = NULL;
  }
  if (msg & TWI_COND_START) {
    bus->write_address_pending = !(addr8 & 1);
    /* a (repeated) start: whoever was addressed lets go of the bus */
    if (bus->active && bus->active->stop) bus->active->stop(bus->active->ctx);
    bus->active = NULL;
    for (int i = 0; i < bus->n_devices; i++) {
      twi_device_t* d = bus->devices[i];
      if (d->addr7 != (addr8 >> 1) || d->absent) continue;
      if (d->start && !d->start(d->ctx, addr8 & 1)) break;
      bus->active = d;
      bus->active_addr8 = addr8;
      avr_raise_irq(bus->irq_in, avr_twi_irq_msg(TWI_COND_ACK, addr8, 1));
      return;
    }
    bus->nacks++;
    avr_raise_irq(bus->irq_in, avr_twi_irq_msg(TWI_COND_ACK, addr8, 0));
    return;
  }
  if (!bus->active || (addr8 >> 1) != (bus->active_addr8 >> 1)) {
    if (msg & TWI_COND_WRITE) avr_raise_irq(bus->irq_in, avr_twi_irq_msg(TWI_COND_ACK, addr8, 0));
    return;
  }
  if (msg & TWI_COND_WRITE) {
    bus->active->write(bus->active->ctx, m.u.twi.data);
    avr_raise_irq(bus->irq_in, avr_twi_irq_msg(TWI_COND_ACK, addr8, 1));
  } else if (msg & TWI_COND_READ) {
    uint8_t byte = bus->active->read(bus->active->ctx);
    avr_raise_irq(bus->irq_in, avr_twi_irq_msg(TWI_COND_READ, addr8, byte));
  }
}

int twi_bus_attach(twi_bus_t* bus, avr_t* avr) {
  memset(bus, 0, sizeof(*bus));
  bus->avr = avr;
  avr_irq_t* out = avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_OUTPUT);
  bus->irq_in = avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_INPUT);
  if (!out || !bus->irq_in) return -1;
  avr_irq_t* status = avr_io_getirq(avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_STATUS);
  if (!status) return -1;
  avr_irq_register_notify(out, twi_bus_output, bus);
  avr_irq_register_notify(status, twi_bus_status, bus);
  return 0;
}

void twi_bus_add(twi_bus_t* bus, twi_device_t* dev) {
  if (bus->n_devices < TWI_BUS_MAX_DEVICES) bus->devices[bus->n_devices++] = dev;
}

twi_device_t* twi_bus_find(twi_bus_t* bus, const char* name) {
  for (int i = 0; i < bus->n_devices; i++)
    if (strcmp(bus->devices[i]->name, name) == 0) return bus->devices[i];
  return NULL;
}
