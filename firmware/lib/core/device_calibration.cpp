// R0 calibration: measured at rest (CALIBRATE_R0, and at boot) or set by the host (SET_R0).
#include "device.h"

#include <string.h>

#include "device_util.h"
#include "f32_bits.h"
#include "sensing.h"

namespace dev {

namespace r = proto::result;
namespace f = proto::flag;

bool Device::calibrate_r0(uint8_t n_samples, uint8_t mask) {
  int32_t sum[kChannels] = {0, 0, 0};
  for (uint8_t k = 0; k < n_samples; ++k) {
    for (uint8_t ch = 0; ch < kChannels; ++ch) {
      if (!(mask & (1u << ch))) continue;
      int16_t c;
      if (!hal_.adc_start(ch) || !hal_.adc_finish(&c)) {
        counters_.sensor_faults = sat_add16(counters_.sensor_faults, 1);
        return false;
      }
      sum[ch] += c;
    }
  }
  bool any = false;
  for (uint8_t ch = 0; ch < kChannels; ++ch) {
    if (!(mask & (1u << ch))) continue;
    const int32_t mohm = counts_to_mohm(sum[ch], n_samples, config_.adc_pga);
    proto::config::KeyInfo lim;
    proto::config::key_info((uint8_t)(proto::config::R0_CH0_MOHM + ch), &lim);
    // An open (unwired) or shorted input gives no usable R0: keep the previous one.
    if (mohm < lim.min || mohm > lim.max) continue;
    config_.r0_mohm[ch] = mohm;
    any = true;
  }
  if (any) sticky_flags_ &= (uint16_t)~f::R0_UNCALIBRATED;
  return true;
}

void Device::cmd_calibrate_r0(const uint8_t* p) {
  const uint8_t n = p[0], mask = p[1];
  if (n < 1 || n > 64) return nak(r::OUT_OF_RANGE, 0);
  if (mask == 0 || (mask & ~0x07)) return nak(r::OUT_OF_RANGE, 1);
  // Calibration blocks (up to 24 s at 8 SPS): never while an output needs the link watchdog.
  if (streaming_ || outputs_active()) return nak(r::BUSY, 0);
  if (!calibrate_r0(n, mask)) return nak(r::SENSOR_FAULT, 0);
  proto::R0Reply rep;
  for (uint8_t ch = 0; ch < kChannels; ++ch) {
    const uint32_t bits = f32_from_ratio((uint32_t)config_.r0_mohm[ch], 1000);  // R0 >= 1000 mohm
    memcpy(&rep.r0_ohm[ch], &bits, 4);
  }
  uint8_t buf[proto::R0Reply::kMaxLen];
  reply(proto::R0Reply::kType, buf, rep.encode(buf));
}

void Device::cmd_set_r0(const uint8_t* p) {
  proto::SetR0 s;
  s.decode(p, proto::SetR0::kMinLen);
  if (s.channel_mask == 0 || (s.channel_mask & ~0x07)) return nak(r::OUT_OF_RANGE, 0);
  int32_t mohm[kChannels];
  for (uint8_t ch = 0; ch < kChannels; ++ch) {
    if (!(s.channel_mask & (1u << ch))) continue;
    uint32_t bits;
    memcpy(&bits, &s.r0_ohm[ch], 4);
    proto::config::KeyInfo lim;
    proto::config::key_info((uint8_t)(proto::config::R0_CH0_MOHM + ch), &lim);
    // R0 rounded to the milliohm; NaN and infinities fail too.
    if (!f32_scaled(bits, 1000, lim.max + 1, &mohm[ch]) || mohm[ch] < lim.min || mohm[ch] > lim.max)
      return nak(r::OUT_OF_RANGE, 1);
  }
  for (uint8_t ch = 0; ch < kChannels; ++ch)
    if (s.channel_mask & (1u << ch)) config_.r0_mohm[ch] = mohm[ch];
  sticky_flags_ &= (uint16_t)~f::R0_UNCALIBRATED;
  ack();
}

}  // namespace dev
