#include "robot/packet_codec.h"

#include <stdexcept>

namespace owlcal::robot {

std::string EncodePacket(const models::PwmVector& pwm_us) {
  std::string out;
  out.reserve(kPacketBytes);
  for (int i = 0; i < models::kNumServos; ++i) {
    const int v = pwm_us[i];
    if (v < 1000 || v > 9999) {
      throw std::invalid_argument(std::string("servo packet: ") + models::kServoNames[i] + " = " + std::to_string(v) +
                                  " us is not a four-digit pulse width");
    }
    if (i) out.push_back(' ');
    out += std::to_string(v);
  }
  return out;
}

DecodeResult DecodePacket(std::string_view bytes) {
  DecodeResult r;
  if (bytes.size() != kPacketBytes) {
    r.error = "packet is " + std::to_string(bytes.size()) + " bytes, expected " + std::to_string(kPacketBytes);
    return r;
  }
  models::PwmVector v{};
  for (int i = 0; i < models::kNumServos; ++i) {
    const size_t start = size_t(i) * 5;
    int value = 0;
    for (size_t k = 0; k < 4; ++k) {
      const char c = bytes[start + k];
      if (c < '0' || c > '9') {
        r.error = "field " + std::to_string(i + 1) + " (" + models::kServoNames[i] + "): '" +
                  std::string(bytes.substr(start, 4)) + "' is not 4 digits";
        return r;
      }
      value = value * 10 + (c - '0');
    }
    if (i < models::kNumServos - 1 && bytes[start + 4] != ' ') {
      r.error = "field " + std::to_string(i + 1) + " (" + models::kServoNames[i] + ") is not followed by a space";
      return r;
    }
    v[i] = value;
  }
  r.pwm_us = v;
  return r;
}

}  // namespace owlcal::robot
