#pragma once
// MJPEG-over-HTTP client for the Owl's camera stream (guide: http://10.0.0.10:8080/stream/video.mjpeg),
// over raw sockets (no OpenCV VideoCapture / ffmpeg), so it can time-stamp frames on arrival,
// count corrupt frames and reconnect.
//
// Stream: an HTTP response with Content-Type multipart/x-mixed-replace; the boundary is taken
// from that header (quotes and a leading "--" tolerated). Each part's JPEG is delimited by its
// Content-Length when present, otherwise by the JPEG end-of-image marker (FF D9) or the next
// boundary, whichever comes first.
// Corrupt parts (no SOI/EOI marker, or cv::imdecode fails) are skipped and counted; the sequence
// number still advances, so a corrupt part shows as a gap in StereoFrame::seq.
// When the connection fails, ends or stalls for options.read_timeout, the client reconnects
// (every options.reconnect_delay) until the caller's timeout; reconnects are counted.
//
// Splitting (the guide's code snippet 6): the decoded side-by-side frame of width W is split at
// W/2: left = columns [0, W/2), right = [W/2, W) (for the Owl: 0-639 and 640-1279). Options:
//   mirror_stream  first flip the whole frame horizontally (cv::flip code 1), as some course
//                  code does; this mirrors each eye image AND exchanges the halves;
//   swap_eyes      then exchange the halves: left = [W/2, W), right = [0, W/2).
// Both default to false and come from the robot file (RobotConfig::swap_eyes, mirror_stream).
//
// Time stamps: StereoFrame::stamp_ns is the steady clock (ns since its epoch) when the last
// byte of the frame arrived; the server's X-Timestamp header, if any, is kept too.
//
// Usage:
//   MjpegClient client({.host = "127.0.0.1", .port = port});
//   if (std::optional<MjpegFrame> f = client.Next(std::chrono::seconds(2))) use(f->stereo.left);
#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "robot/robot_interface.h"
#include "robot/socket_util.h"

namespace owlcal::robot {

struct MjpegClientOptions {
  std::string host = "127.0.0.1";
  int port = 8080;
  std::string path = "/stream/video.mjpeg";
  std::chrono::milliseconds connect_timeout{2000};
  std::chrono::milliseconds read_timeout{2000};     // a stream silent this long is reconnected
  std::chrono::milliseconds reconnect_delay{100};
  bool swap_eyes = false;
  bool mirror_stream = false;
  bool decode = true;                               // false: only the raw JPEG (no left/right)
  size_t max_frame_bytes = 8u << 20;
  bool Check(std::string* why) const;
};

struct MjpegFrame {
  StereoFrame stereo;
  std::optional<int64_t> server_stamp_us;  // X-Timestamp of the part, if the server sent one
};

struct MjpegClientStats {
  int64_t num_frames = 0;      // good frames returned
  int64_t num_corrupt = 0;     // parts skipped because the JPEG was bad
  int64_t num_connects = 0;    // successful connections (1 + reconnects)
  int64_t num_failures = 0;    // connection attempts or streams that failed
};

// Splits a decoded side-by-side frame per the options above (exposed for tests and the sim).
void SplitStereo(const cv::Mat& frame, bool mirror_stream, bool swap_eyes, cv::Mat* left, cv::Mat* right);

// True if `jpeg` starts with SOI (FF D8) and ends with EOI (FF D9), ignoring trailing CR/LF.
bool LooksLikeCompleteJpeg(const std::vector<uint8_t>& jpeg);

class MjpegClient {
 public:
  explicit MjpegClient(MjpegClientOptions options);
  // Reads the next good frame, (re)connecting as needed; nullopt when `timeout` passes first.
  std::optional<MjpegFrame> Next(std::chrono::milliseconds timeout);
  void Close();
  bool Connected() const { return socket_.valid(); }
  const MjpegClientStats& Stats() const { return stats_; }
  const MjpegClientOptions& Options() const { return options_; }

 private:
  // One part's raw bytes; nullopt on a failed stream (caller reconnects) or deadline.
  bool Connect(std::chrono::steady_clock::time_point deadline);
  std::optional<std::vector<uint8_t>> ReadPart(std::chrono::steady_clock::time_point deadline,
                                               std::optional<int64_t>* server_stamp_us);
  // Appends more bytes to buf_; false on EOF, error, read timeout or deadline.
  bool Fill(std::chrono::steady_clock::time_point deadline);

  MjpegClientOptions options_;
  Socket socket_;
  std::string buf_;
  std::string boundary_;  // without the leading "--"
  int64_t seq_ = 0;
  MjpegClientStats stats_;
};

}  // namespace owlcal::robot
