#pragma once
// The Owl servo packet (guide, Annex 2 and code snippets 3-5; docs/conventions.md, Facts):
// exactly 24 ASCII bytes, five four-digit pulse widths in microseconds separated by single
// spaces, in the order Rx Ry Lx Ly Neck, e.g. "1545 1530 1545 1580 1530" (24 bytes, no
// terminator). The course server reads 24 bytes per recv and treats fewer as the end of the
// session. A client closes with an empty packet (it just closes the socket after sending
// nothing / a short write).
#include <array>
#include <optional>
#include <string>
#include <string_view>

#include "models/robot_config.h"

namespace owlcal::robot {

inline constexpr int kPacketBytes = 24;

// Encodes five values; each must be within 1000..9999 (four digits) or this throws
// std::invalid_argument naming the servo and value. Callers clamp first (LimitsGuard).
std::string EncodePacket(const models::PwmVector& pwm_us);

struct DecodeResult {
  std::optional<models::PwmVector> pwm_us;  // set when the packet is well formed
  std::string error;                        // why not, naming the field ("field 3 (Lx): 'x12' is not 4 digits")
};

// Decodes one packet. Well formed = exactly 24 bytes, 5 fields of exactly 4 ASCII digits
// separated by single spaces. Anything else is rejected with a reason (never throws).
DecodeResult DecodePacket(std::string_view bytes);

}  // namespace owlcal::robot
