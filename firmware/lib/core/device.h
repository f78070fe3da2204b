// The device core: command handling per protocol/messages.toml, duplicate detection with a
// cached reply, output limits, the host-link watchdog, fixed-rate sampling and telemetry.
// Pure C++: all hardware access goes through dev::Hal, the model through dev::ModelPort.
// One class, its parts in one file each (as grbl cuts its main loop): device.cpp (boot, flags,
// outputs and the link watchdog, the receive path), device_dispatch.cpp (commands),
// device_replies.cpp (replies, SAMPLE and ERROR frames), device_stream.cpp (sampling),
// device_line.cpp (CSV line mode), device_calibration.cpp (R0), device_control.cpp (strain
// control supervision); device_util.h holds the helpers they share.
#pragma once
#include <stdint.h>

#include "control.h"
#include "control_store.h"
#include "device_config.h"
#include "frame_codec.h"
#include "hal.h"
#include "link_watchdog.h"
#include "model_port.h"
#include "protocol_messages.h"
#include "sync_blink.h"

namespace dev {

constexpr uint8_t kFwMajor = 1, kFwMinor = 0, kFwPatch = 0;
constexpr uint8_t kR0BootSamples = 16;  // averaged at boot when R0_MODE is 0

struct Counters {
  uint16_t overruns;           // sample ticks missed because the previous sample ran late
  uint16_t dropped_telemetry;  // SAMPLE frames not sent: transmit buffer full
  uint16_t watchdog_trips;
  uint16_t sensor_faults;
  uint32_t rx_frames;
  uint32_t tx_frames;
};

// The device's plain state, all zero at construction: value-initialising it as one block
// costs one clearing loop instead of a store per field (flash).
struct DeviceState {
  Outputs outputs_;
  Counters counters_;

  // The last command and its encoded reply, resent verbatim for a duplicate.
  uint8_t cached_[proto::kMaxFrameLen];
  uint8_t cached_len_;
  uint8_t last_type_;
  uint8_t last_seq_;
  uint8_t cmd_seq_;  // sequence number of the command being handled
  // SET_OUTPUTS that turns an output on must carry session_ (new at each HELLO) and a
  // counter ahead of out_counter_, the last one accepted: a replayed old frame is refused.
  uint16_t session_;
  uint16_t out_counter_;

  bool frame_ready_;
  bool streaming_;
  bool reset_requested_;
  uint8_t stream_mask_;
  uint16_t rate_hz_;
  uint8_t telemetry_seq_;    // SAMPLE frames, from 0 at each START_STREAM
  uint8_t error_seq_;        // ERROR frames
  uint16_t sticky_flags_;    // flags that persist until cleared (watchdog, config, R0, ...)
  uint16_t sample_flags_;    // sensor flags of the latest sample
  uint8_t pending_overrun_;  // an overrun happened since the previous SAMPLE
  uint8_t trip_unreported_;  // the watchdog cut the outputs; poll() sends the ERROR
  uint32_t trip_us_;         // when it did: the ERROR carries this time, however late it leaves
  // CSV line mode of this session: on at boot when LINE_MODE is stored as 1, off after any
  // valid frame from a host, switched by CONFIG_SET LINE_MODE.
  uint8_t line_state_;
  uint8_t analog_pin_;  // pin of the analogue estimate output now driven, 0 when off

  // Strain control: the gains in use and the trajectory's clock (start tick, current
  // segment).
  ctl::Gains gains_;
  uint32_t traj_start_us_;
  uint8_t traj_seg_;
  uint8_t control_mode_;
};

class Device : private DeviceState {
 public:
  Device(Hal& hal, ModelPort& model);

  // Outputs off, configuration from EEPROM (defaults when corrupt), R0 per R0_MODE,
  // autostart when configured and a model is loaded.
  void begin();
  // Feed received bytes to the decoder until a frame is complete, and cut the outputs when
  // the host-link watchdog expires; safe to call from a driver's wait loop (commands are
  // executed, and a watchdog trip reported, later by poll()), so no wait holds the outputs.
  void poll_rx();
  // Execute a received command, check the host-link watchdog. Call every loop pass.
  void poll();
  // Sample ticks from the timer: n ticks since the previous call (n > 1: n - 1 overruns),
  // tick_us the time of the latest. Samples, estimates and sends one SAMPLE.
  void on_sample_ticks(uint8_t n, uint32_t tick_us);

  bool streaming() const { return streaming_; }
  uint16_t rate_hz() const { return rate_hz_; }  // the timer's sample rate, 0 when stopped
  uint16_t flags() const;
  const Counters& counters() const { return counters_; }
  const Config& config() const { return config_; }
  const Outputs& outputs() const { return outputs_; }
  bool reset_requested() const { return reset_requested_; }
  // A received frame waits for poll(): the main loop must not sleep.
  bool frame_pending() const { return frame_ready_; }
  bool line_mode() const { return line_state_ & kLineOn; }

 private:
  void handle_frame();
  void dispatch(uint8_t type, const uint8_t* p, uint8_t len);
  void reply(uint8_t type, const uint8_t* payload, uint8_t len);
  void ack();
  void nak(uint8_t code, int16_t detail);
  void send_unsolicited(uint8_t type, const uint8_t* payload, uint8_t len);
  void send_error(uint8_t code, int16_t detail, uint32_t t_us);
  void guard_link();  // cuts the outputs when the host-link watchdog has expired

  void cmd_hello();
  void cmd_set_outputs(const uint8_t* p);
  void cmd_start_stream(const uint8_t* p);
  void cmd_replay(const uint8_t* p, uint8_t len);
  void cmd_calibrate_r0(const uint8_t* p);
  void cmd_set_r0(const uint8_t* p);
  void cmd_status();
  void cmd_config_set(const uint8_t* p);
  void cmd_model(uint8_t type, const uint8_t* p, uint8_t len);
  void cmd_control_gains(const uint8_t* p);
  void cmd_control_gains_get();
  void cmd_control_start(const uint8_t* p);

  // A command that turns outputs on must carry this session and a counter ahead of the last.
  bool fresh(uint16_t session, uint16_t counter);
  // Gains made for the running model and the stream's rate.
  bool gains_fit(const ctl::Gains& g);
  bool control_mask_ok(uint8_t mask);  // every masked channel has a model output
  // Starts control of `mask` (mode kCtlConstant or kCtlTrajectory, | kCtlStandalone).
  void control_begin(uint8_t mode, uint8_t mask);
  void control_stop();  // outputs vent
  // One sample of control after the estimator; returns the sample flags with CONTROL_SATURATED,
  // or stops control and vents (returns with *aborted set) on a sensor fault, a saturated
  // estimator or no estimate.
  uint16_t control_step(uint16_t fl, bool estimating, const int16_t est[kChannels], uint32_t tick_us, bool* aborted);
  void trajectory_targets(uint32_t tick_us);

  void apply_config();
  // Switches this session's line mode; switching on prints the CSV header at once (blocking
  // write: at boot, or after a command's reply, when the transmit buffer has room).
  void set_line_mode(bool on);
  uint8_t line_estimates(proto::ModelInfoReply* info, uint8_t mask);
  void send_line(const proto::Sample& s, bool estimating);
  void analog_out(int16_t estimate0);
  void outputs_off();
  bool outputs_active() const;
  void start_stream(uint16_t rate_hz, uint8_t mask);
  void stop_stream();
  // Averages n samples per masked channel; channels with a usable R0 take it. False only
  // when the ADC did not answer.
  bool calibrate_r0(uint8_t n_samples, uint8_t mask);

  static constexpr uint8_t kLineOn = 1;  // line_state_ bit
  static constexpr uint8_t kCtlConstant = 1, kCtlTrajectory = 2, kCtlStandalone = 0x80;
  Hal& hal_;
  ModelPort& model_;
  proto::FrameDecoder decoder_;
  Config config_;
  ConfigStore store_;
  LinkWatchdog link_;
  SyncBlink sync_;  // camera sync indicator (sync_blink.h)
  // Strain control (control.h): the controller and its stored gains and trajectory.
  ctl::Controller control_;
  ControlStore cstore_;
};

}  // namespace dev
