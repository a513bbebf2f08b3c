#include "robot/mjpeg_client.h"

#include <cmath>

#include <algorithm>
#include <cctype>
#include <stdexcept>
#include <thread>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "io/strict_number.h"

namespace owlcal::robot {
namespace {

using Clock = std::chrono::steady_clock;

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

// Value of header `name` (lower case) in a header block, or "".
std::string HeaderValue(const std::string& block, const std::string& name) {
  const std::string lower = Lower(block);
  size_t pos = 0;
  while ((pos = lower.find(name + ":", pos)) != std::string::npos) {
    if (pos == 0 || lower[pos - 1] == '\n') {
      const size_t start = pos + name.size() + 1;
      size_t end = block.find("\r\n", start);
      if (end == std::string::npos) end = block.find('\n', start);
      std::string v = block.substr(start, end == std::string::npos ? std::string::npos : end - start);
      const size_t a = v.find_first_not_of(" \t");
      const size_t b = v.find_last_not_of(" \t\r");
      return a == std::string::npos ? "" : v.substr(a, b - a + 1);
    }
    ++pos;
  }
  return "";
}

int64_t NowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
}

}  // namespace

bool MjpegClientOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "mjpeg client: " + m;
    return false;
  };
  if (host.empty()) return fail("host is empty");
  if (port < 1 || port > 65535) return fail("port = " + std::to_string(port) + " is not 1..65535");
  if (path.empty() || path[0] != '/') return fail("path '" + path + "' must start with /");
  if (read_timeout.count() <= 0 || connect_timeout.count() <= 0) return fail("timeouts must be positive");
  if (reconnect_delay.count() < 0 || max_reconnect_delay < reconnect_delay)
    return fail("reconnect delays must satisfy 0 <= reconnect_delay <= max_reconnect_delay");
  if (expected_width < 0 || expected_height < 0 || expected_width > 65535 || expected_height > 65535)
    return fail("expected frame size " + std::to_string(expected_width) + "x" + std::to_string(expected_height) +
                " is not within 0..65535");
  if (max_frame_pixels < 1) return fail("max_frame_pixels must be positive");
  return true;
}

void SplitStereo(const cv::Mat& frame, bool mirror_stream, bool swap_eyes, cv::Mat* left, cv::Mat* right) {
  cv::Mat f;  // a fresh Mat: flipping into a header shared with `frame` would flip it in place
  if (mirror_stream) {
    cv::flip(frame, f, 1);
  } else {
    f = frame;
  }
  const int half = f.cols / 2;
  cv::Mat a = f(cv::Rect(0, 0, half, f.rows)).clone();
  cv::Mat b = f(cv::Rect(half, 0, f.cols - half, f.rows)).clone();
  if (swap_eyes) std::swap(a, b);
  *left = a;
  *right = b;
}

std::optional<JpegSize> JpegDeclaredSize(const uint8_t* data, size_t size) {
  if (size < 4 || data[0] != 0xFF || data[1] != 0xD8) return std::nullopt;
  size_t i = 2;
  while (i < size) {
    if (data[i] != 0xFF) return std::nullopt;
    while (i < size && data[i] == 0xFF) ++i;  // fill bytes
    if (i >= size) return std::nullopt;
    const uint8_t m = data[i++];
    if (m == 0x01 || (m >= 0xD0 && m <= 0xD8)) continue;  // markers without a length
    if (m == 0xD9 || m == 0xDA) return std::nullopt;      // end of image or scan before any SOF
    if (i + 2 > size) return std::nullopt;
    const size_t length = (static_cast<size_t>(data[i]) << 8) | data[i + 1];
    if (length < 2 || i + length > size) return std::nullopt;
    const bool sof = m >= 0xC0 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC;
    if (sof) {
      if (length < 7) return std::nullopt;
      JpegSize s;
      s.height = (data[i + 3] << 8) | data[i + 4];
      s.width = (data[i + 5] << 8) | data[i + 6];
      return s;
    }
    i += length;
  }
  return std::nullopt;
}

bool LooksLikeCompleteJpeg(const std::vector<uint8_t>& jpeg) {
  size_t n = jpeg.size();
  while (n > 0 && (jpeg[n - 1] == '\r' || jpeg[n - 1] == '\n')) --n;
  return n >= 4 && jpeg[0] == 0xFF && jpeg[1] == 0xD8 && jpeg[n - 2] == 0xFF && jpeg[n - 1] == 0xD9;
}

MjpegClient::MjpegClient(MjpegClientOptions options) : options_(std::move(options)) {
  std::string why;
  if (!options_.Check(&why)) throw std::invalid_argument(why);
  backoff_ = options_.reconnect_delay;
}

void MjpegClient::Close() {
  socket_.Close();
  buf_.clear();
}

bool MjpegClient::Fill(Clock::time_point deadline) {
  const auto now = Clock::now();
  if (now >= deadline) return false;
  const auto wait =
      std::min(options_.read_timeout,
               std::chrono::duration_cast<std::chrono::milliseconds>(deadline - now) + std::chrono::milliseconds(1));
  char chunk[65536];
  const int64_t got = RecvSome(socket_.fd(), chunk, sizeof(chunk), wait);
  if (got <= 0) return false;
  buf_.append(chunk, static_cast<size_t>(got));
  return true;
}

bool MjpegClient::Connect(Clock::time_point deadline) {
  Close();
  try {
    // Never past the caller's deadline.
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
    if (left.count() <= 0) return false;
    socket_ = ConnectTcp(options_.host, options_.port, std::min(options_.connect_timeout, left));
  } catch (const std::exception& e) {
    stats_.last_problem = e.what();
    return false;
  }
  const std::string request =
      "GET " + options_.path + " HTTP/1.1\r\nHost: " + options_.host + ":" + std::to_string(options_.port) +
      "\r\nUser-Agent: owlcal\r\nAccept: multipart/x-mixed-replace\r\nConnection: close\r\n\r\n";
  if (!SendAll(socket_.fd(), request)) return false;
  return ReadResponseHead(deadline);
}

bool MjpegClient::Adopt(Socket connected, std::chrono::milliseconds timeout) {
  Close();
  socket_ = std::move(connected);
  if (ReadResponseHead(Clock::now() + timeout)) return true;
  Close();
  return false;
}

bool MjpegClient::ReadResponseHead(Clock::time_point deadline) {
  size_t end;
  while ((end = buf_.find("\r\n\r\n")) == std::string::npos) {
    if (buf_.size() > 65536 || !Fill(deadline)) return false;
  }
  const std::string head = buf_.substr(0, end + 2);
  buf_.erase(0, end + 4);
  const size_t sp = head.find(' ');
  if (sp == std::string::npos || head.compare(sp + 1, 3, "200") != 0) return false;
  const std::string type = HeaderValue(head, "content-type");
  const size_t b = Lower(type).find("boundary=");
  if (Lower(type).find("multipart/") == std::string::npos || b == std::string::npos) return false;
  std::string boundary = type.substr(b + 9);
  const size_t semi = boundary.find(';');
  if (semi != std::string::npos) boundary.resize(semi);
  while (!boundary.empty() && (boundary.back() == ' ' || boundary.back() == '"')) boundary.pop_back();
  while (!boundary.empty() && boundary.front() == '"') boundary.erase(0, 1);
  if (boundary.rfind("--", 0) == 0) boundary.erase(0, 2);
  if (boundary.empty()) return false;
  boundary_ = boundary;
  ++stats_.num_connects;
  return true;
}

std::optional<std::vector<uint8_t>> MjpegClient::ReadPart(Clock::time_point deadline,
                                                          std::optional<int64_t>* server_stamp_us) {
  const std::string marker = "--" + boundary_;
  // 1. Find the boundary line.
  size_t pos;
  while ((pos = buf_.find(marker)) == std::string::npos) {
    if (buf_.size() > marker.size()) buf_.erase(0, buf_.size() - marker.size());  // keep a possible prefix
    if (!Fill(deadline)) return std::nullopt;
  }
  buf_.erase(0, pos + marker.size());
  // 2. Part headers up to the blank line.
  size_t end;
  while ((end = buf_.find("\r\n\r\n")) == std::string::npos) {
    if (buf_.size() > 16384 || !Fill(deadline)) return std::nullopt;
  }
  const std::string head = buf_.substr(0, end + 2);
  buf_.erase(0, end + 4);
  server_stamp_us->reset();
  const std::string stamp = HeaderValue(head, "x-timestamp");
  if (!stamp.empty()) {
    // Seconds; a value that is not a finite number within +-1e12 s is ignored (a hostile
    // "1e300" overflowed the conversion to microseconds: undefined behaviour).
    const std::optional<double> s = io::ParseFiniteDouble(stamp);
    if (s && std::abs(*s) < 1e12) *server_stamp_us = static_cast<int64_t>(std::llround(*s * 1e6));
  }
  const std::string length_text = HeaderValue(head, "content-length");
  long long length = -1;
  if (!length_text.empty()) {
    try {
      length = std::stoll(length_text);
    } catch (...) {
      length = -1;
    }
  }
  if (length > static_cast<long long>(options_.max_frame_bytes)) return std::nullopt;
  std::vector<uint8_t> jpeg;
  if (length >= 0) {
    while (buf_.size() < static_cast<size_t>(length)) {
      if (!Fill(deadline)) return std::nullopt;
    }
    jpeg.assign(buf_.begin(), buf_.begin() + length);
    buf_.erase(0, static_cast<size_t>(length));
    return jpeg;
  }
  // 3. No Content-Length: up to the JPEG EOI (FF D9) or the next boundary, whichever first.
  size_t scanned = 0;
  while (true) {
    const size_t next_boundary = buf_.find("\r\n" + marker, scanned);
    size_t eoi = std::string::npos;
    for (size_t i = scanned; i + 1 < buf_.size(); ++i) {
      if (static_cast<uint8_t>(buf_[i]) == 0xFF && static_cast<uint8_t>(buf_[i + 1]) == 0xD9) {
        eoi = i + 2;
        break;
      }
    }
    size_t cut = std::min(eoi, next_boundary);
    if (cut != std::string::npos) {
      jpeg.assign(buf_.begin(), buf_.begin() + cut);
      buf_.erase(0, cut);
      return jpeg;
    }
    if (buf_.size() > options_.max_frame_bytes) return std::nullopt;
    scanned = buf_.size() > marker.size() + 2 ? buf_.size() - marker.size() - 2 : 0;
    if (!Fill(deadline)) return std::nullopt;
  }
}

std::optional<MjpegFrame> MjpegClient::Next(std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  // Waits the current back-off (never past the deadline) and doubles it.
  auto back_off = [&] {
    const auto left = deadline - Clock::now();
    if (left <= Clock::duration::zero()) return;
    std::this_thread::sleep_for(std::min<Clock::duration>(backoff_, left));
    backoff_ = std::min(options_.max_reconnect_delay, std::max(backoff_ * 2, std::chrono::milliseconds(1)));
  };
  while (Clock::now() < deadline) {
    if (!socket_.valid()) {
      if (!options_.reconnect && stats_.num_connects + stats_.num_failures > 0) break;
      if (!Connect(deadline)) {
        ++stats_.num_failures;
        Close();
        back_off();
        continue;
      }
    }
    MjpegFrame out;
    std::optional<std::vector<uint8_t>> jpeg = ReadPart(deadline, &out.server_stamp_us);
    if (!jpeg) {
      if (Clock::now() < deadline) {  // the stream failed (not just our deadline): reconnect
        ++stats_.num_failures;
        Close();
        if (!options_.reconnect) break;
        back_off();
      }
      continue;
    }
    const int64_t stamp_ns = NowNs();
    ++seq_;
    if (!LooksLikeCompleteJpeg(*jpeg)) {
      ++stats_.num_corrupt;
      stats_.last_problem = "part " + std::to_string(seq_) + " is not a complete JPEG (no SOI/EOI marker)";
      continue;
    }
    // Size from the SOF header before any decoding (bounded memory).
    const std::optional<JpegSize> size = JpegDeclaredSize(jpeg->data(), jpeg->size());
    std::string size_problem;
    if (!size) {
      size_problem = "has no readable SOF header";
    } else if (options_.expected_width > 0 || options_.expected_height > 0) {
      if ((options_.expected_width > 0 && size->width != options_.expected_width) ||
          (options_.expected_height > 0 && size->height != options_.expected_height))
        size_problem = "declares " + std::to_string(size->width) + "x" + std::to_string(size->height) +
                       ", the robot file says " + std::to_string(options_.expected_width) + "x" +
                       std::to_string(options_.expected_height);
    } else if (size->width < 2 || size->height < 1 ||
               static_cast<int64_t>(size->width) * size->height > options_.max_frame_pixels) {
      size_problem = "declares " + std::to_string(size->width) + "x" + std::to_string(size->height) + " (at most " +
                     std::to_string(options_.max_frame_pixels) + " pixels)";
    }
    if (!size_problem.empty()) {
      ++stats_.num_wrong_size;
      stats_.last_problem = "JPEG part " + std::to_string(seq_) + " " + size_problem + "; not decoded";
      continue;
    }
    out.stereo.seq = seq_;
    out.stereo.stamp_ns = stamp_ns;
    if (options_.decode) {
      cv::Mat frame;
      try {
        frame = cv::imdecode(*jpeg, cv::IMREAD_COLOR);
      } catch (const cv::Exception&) {
        frame.release();
      }
      if (frame.empty() || frame.cols < 2) {
        ++stats_.num_corrupt;
        stats_.last_problem = "JPEG part " + std::to_string(seq_) + " does not decode";
        continue;
      }
      SplitStereo(frame, options_.mirror_stream, options_.swap_eyes, &out.stereo.left, &out.stereo.right);
    }
    out.stereo.jpeg = std::move(*jpeg);
    ++stats_.num_frames;
    backoff_ = options_.reconnect_delay;
    return out;
  }
  return std::nullopt;
}

}  // namespace owlcal::robot
