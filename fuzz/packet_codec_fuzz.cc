// Servo packets: DecodePacket on any bytes never throws; a decoded packet of values 1000..9999
// re-encodes to the same 24 bytes; the stream assembler cuts any byte stream into 24-byte packets; the limits
// guard keeps every decoded command within the robot's limits.
#include <cstdint>
#include <string_view>

#include "fuzz/fuzz_util.h"
#include "robot/limits_guard.h"
#include "robot/packet_assembler.h"
#include "robot/packet_codec.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace owlcal;
  const std::string bytes = fuzz::Text(data, size);
  static const robot::LimitsGuard guard(models::DefaultRobotConfig());
  auto check = [&](std::string_view packet) {
    const robot::DecodeResult r = robot::DecodePacket(packet);
    OWLCAL_FUZZ_ASSERT(r.pwm_us.has_value() != !r.error.empty());
    if (!r.pwm_us) return;
    // "0590" is four digits (the server decodes it as 590 and clamps it); the encoder writes
    // only 1000..9999, so the round trip holds for those.
    bool encodable = true;
    for (const int v : *r.pwm_us) encodable = encodable && v >= 1000 && v <= 9999;
    if (encodable) OWLCAL_FUZZ_ASSERT(robot::EncodePacket(*r.pwm_us) == packet);
    const robot::ClampResult c = guard.Clamp(*r.pwm_us);
    OWLCAL_FUZZ_ASSERT(guard.WithinLimits(c.pwm_us));
  };
  check(bytes);
  robot::PacketAssembler a;
  size_t packets = 0;
  a.Feed(bytes, [&](std::string_view p) {
    OWLCAL_FUZZ_ASSERT(p.size() == size_t(robot::kPacketBytes));
    ++packets;
    check(p);
  });
  OWLCAL_FUZZ_ASSERT(packets == size / robot::kPacketBytes && a.Pending() == size % robot::kPacketBytes);
  return 0;
}
