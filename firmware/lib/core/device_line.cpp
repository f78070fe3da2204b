// The CSV line mode: its header and one line per sample instead of SAMPLE frames.
#include "device.h"

#include <string.h>

#include "device_util.h"
#include "f32_bits.h"
#include "standalone_out.h"

namespace dev {

namespace r = proto::result;
namespace f = proto::flag;

uint8_t Device::line_estimates(proto::ModelInfoReply* info, uint8_t mask) {
  model_.info(info);
  return (mask & proto::chan::ESTIMATES) && model_.estimator_loaded() ? info->n_outputs : 0;
}

void Device::set_line_mode(bool on) {
  line_state_ = on ? kLineOn : 0;
  if (!on) return;
  char text[kHeaderMax];
  proto::ModelInfoReply info;
  const uint8_t mask = streaming_ ? stream_mask_ : config_.channel_mask;
  hal_.serial_write((const uint8_t*)text, format_header(text, (uint8_t)(mask & 0x07), line_estimates(&info, mask)));
}

// Kept out of line: its text buffer must not share a stack frame with a SAMPLE frame's.
__attribute__((noinline)) void Device::send_line(const proto::Sample& s, bool estimating) {
  char text[kLineMax];
  const uint8_t dr_mask = (uint8_t)(s.channel_mask & 0x07);
  proto::ModelInfoReply info;
  const uint8_t n_est = estimating ? line_estimates(&info, s.channel_mask) : 0;
  int32_t est_milli[kChannels];
  for (uint8_t j = 0; j < n_est; ++j) {
    // Output units with three decimals, exact (rounded half away from zero), saturated
    // at +-2e9.
    uint32_t scale;
    memcpy(&scale, &info.out_scale[j], 4);
    f32_scaled(scale, (int32_t)s.estimate[j] * 1000, 2000000000L, &est_milli[j]);
  }
  const uint8_t n = format_line(text, s.t_us / 1000UL, dr_mask, s.dr_centi, n_est, est_milli);
  // Like a SAMPLE frame, a line that does not fit the transmit buffer is dropped whole; one
  // longer than the whole buffer (63 bytes) goes out when the buffer is empty.
  const uint8_t room = hal_.serial_tx_free();
  if (room < n && room < kTxBufferFree) {
    counters_.dropped_telemetry = sat_add16(counters_.dropped_telemetry, 1);
    return;
  }
  hal_.serial_write((const uint8_t*)text, n);
}

}  // namespace dev
