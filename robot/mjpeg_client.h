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
// Frame size is checked BEFORE decoding, from the JPEG's SOF header: a part whose declared size
// is not options.expected_width x expected_height (the robot file's side-by-side frame; 0 = any
// size up to max_frame_pixels), or that has no SOF header, is skipped and counted in
// num_wrong_size, and Stats().last_problem says why. A 631-byte JPEG declaring 30000x30000 is
// never decoded.
// When the connection fails, ends or stalls for options.read_timeout, the client reconnects
// until the caller's timeout; reconnects are counted. Consecutive failures back off: the delay
// starts at options.reconnect_delay and doubles per failure up to options.max_reconnect_delay,
// and a good frame resets it (a stream whose parts keep failing is not hammered).
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
  std::chrono::milliseconds read_timeout{2000};         // a stream silent this long is reconnected
  std::chrono::milliseconds reconnect_delay{100};       // first back-off after a failure
  std::chrono::milliseconds max_reconnect_delay{2000};  // back-off doubles up to this
  bool swap_eyes = false;
  bool mirror_stream = false;
  bool decode = true;     // false: only the raw JPEG (no left/right)
  bool reconnect = true;  // false: Next gives up once the stream fails or ends
  size_t max_frame_bytes = 8u << 20;
  int expected_width = 0;                  // side-by-side frame width; 0 = any
  int expected_height = 0;                 // 0 = any
  int64_t max_frame_pixels = 4096 * 4096;  // limit when no expected size is given
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
  int64_t num_wrong_size = 0;  // parts not decoded: SOF size is not the expected one (or no SOF)
  std::string last_problem;    // the latest skipped part or failure, printable ("" if none)
};

// Width and height declared by the first SOF marker of a JPEG (baseline, progressive, ...),
// read without decoding; nullopt if the markers end or break before a SOF.
struct JpegSize {
  int width = 0, height = 0;
};
std::optional<JpegSize> JpegDeclaredSize(const uint8_t* data, size_t size);

// Splits a decoded side-by-side frame per the options above (exposed for tests and the sim).
void SplitStereo(const cv::Mat& frame, bool mirror_stream, bool swap_eyes, cv::Mat* left, cv::Mat* right);

// True if `jpeg` starts with SOI (FF D8) and ends with EOI (FF D9), ignoring trailing CR/LF.
bool LooksLikeCompleteJpeg(const std::vector<uint8_t>& jpeg);

class MjpegClient {
 public:
  explicit MjpegClient(MjpegClientOptions options);
  // Reads the next good frame, (re)connecting as needed; nullopt when `timeout` passes first.
  std::optional<MjpegFrame> Next(std::chrono::milliseconds timeout);
  // Takes an already connected stream (the request sent) and reads its HTTP response head;
  // false if it is not a multipart stream. Next then reads from it (tests, fuzzing: a
  // socketpair fed with hostile bytes).
  bool Adopt(Socket connected, std::chrono::milliseconds timeout);
  void Close();
  bool Connected() const { return socket_.valid(); }
  const MjpegClientStats& Stats() const { return stats_; }
  const MjpegClientOptions& Options() const { return options_; }

 private:
  // One part's raw bytes; nullopt on a failed stream (caller reconnects) or deadline.
  bool Connect(std::chrono::steady_clock::time_point deadline);
  // Reads the response head from socket_; sets boundary_.
  bool ReadResponseHead(std::chrono::steady_clock::time_point deadline);
  std::optional<std::vector<uint8_t>> ReadPart(std::chrono::steady_clock::time_point deadline,
                                               std::optional<int64_t>* server_stamp_us);
  // Appends more bytes to buf_; false on EOF, error, read timeout or deadline.
  bool Fill(std::chrono::steady_clock::time_point deadline);

  MjpegClientOptions options_;
  Socket socket_;
  std::string buf_;
  std::string boundary_;  // without the leading "--"
  int64_t seq_ = 0;
  std::chrono::milliseconds backoff_{0};  // current reconnect delay (see the header comment)
  MjpegClientStats stats_;
};

}  // namespace owlcal::robot
