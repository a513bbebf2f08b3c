#pragma once
// Joins a TCP byte stream into 24-byte servo packets (robot/packet_codec.h), whatever the
// split of the reads: the course server's recv(24) loop without its short-read bug. Used by
// ServoServer; fuzzed with DecodePacket and LimitsGuard in tests/robot/limits_guard_test.cc.
//
// Usage:
//   PacketAssembler a;
//   a.Feed(bytes_from_recv, [](std::string_view packet) { DecodePacket(packet); ... });
//   if (a.Pending() > 0) ...  // a partial packet is waiting for more bytes
#include <cstddef>
#include <string>
#include <string_view>

#include "robot/packet_codec.h"

namespace owlcal::robot {

class PacketAssembler {
 public:
  // Appends bytes; calls on_packet(packet) for every completed 24-byte packet, in order.
  template <typename F>
  void Feed(std::string_view bytes, F&& on_packet) {
    while (!bytes.empty()) {
      const size_t take = std::min(bytes.size(), size_t(kPacketBytes) - pending_.size());
      pending_.append(bytes.substr(0, take));
      bytes.remove_prefix(take);
      if (pending_.size() == size_t(kPacketBytes)) {
        on_packet(std::string_view(pending_));
        pending_.clear();
      }
    }
  }
  // Bytes of an incomplete packet held back.
  size_t Pending() const { return pending_.size(); }
  void Clear() { pending_.clear(); }

 private:
  std::string pending_;
};

}  // namespace owlcal::robot
