#include "robot/shell_script.h"

#include <cmath>
#include <cstdio>
#include <ostream>
#include <sstream>
#include <stdexcept>

namespace owlcal::robot {
namespace {

std::vector<std::string> Words(const std::string& s) {
  std::istringstream in(s);
  std::vector<std::string> w;
  for (std::string x; in >> x;) w.push_back(x);
  return w;
}

std::string ShellPwmText(const PwmVector& p) {
  std::string s;
  for (int i = 0; i < models::kNumServos; ++i) {
    if (i) s += ' ';
    s += std::to_string(p[i]);
  }
  return s;
}

}  // namespace

std::string PrintableReply(const std::string& reply) {
  std::string out;
  for (size_t i = 0; i < reply.size() && i < 64; ++i) {
    const unsigned char c = static_cast<unsigned char>(reply[i]);
    if (c == '\n') {
      out += "\\n";
    } else if (c == '\r') {
      out += "\\r";
    } else if (c < 0x20 || c >= 0x7f || c == '\\') {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02x", c);
      out += hex;
    } else {
      out += char(c);
    }
  }
  if (reply.size() > 64) out += "...";
  return out;
}

std::optional<ShellCommand> ParseShellLine(const std::string& raw, int line_number, const std::string& source) {
  const std::string where = source + ":" + std::to_string(line_number) + ": ";
  std::string line = raw.substr(0, raw.find('#'));
  const std::vector<std::string> w = Words(line);
  if (w.empty()) return std::nullopt;
  ShellCommand c;
  c.line = line_number;
  for (size_t i = 0; i < w.size(); ++i) {
    if (i) c.text += ' ';
    c.text += w[i];
  }
  const std::string& verb = w[0];
  auto expect_args = [&](size_t n, const char* usage) {
    if (w.size() - 1 != n) {
      throw std::invalid_argument(where + "'" + verb + "' takes " + std::to_string(n) + " argument" +
                                  (n == 1 ? "" : "s") + " (" + usage + "), got " + std::to_string(w.size() - 1));
    }
  };
  if (verb == "move") {
    expect_args(models::kNumServos, "move Rx Ry Lx Ly Neck");
    c.kind = ShellCommand::Kind::kMove;
    for (int i = 0; i < models::kNumServos; ++i) {
      const std::string& v = w[size_t(i) + 1];
      if (v.empty() || v.size() > 5 || v.find_first_not_of("0123456789") != std::string::npos) {
        throw std::invalid_argument(where + models::kServoNames[i] + " = '" + v +
                                    "' is not a pulse width in us (decimal digits, e.g. 1545)");
      }
      c.pwm_us[i] = std::stoi(v);
    }
  } else if (verb == "centre" || verb == "center") {
    expect_args(0, "centre");
    c.kind = ShellCommand::Kind::kCentre;
  } else if (verb == "wait" || verb == "sleep") {
    expect_args(1, "wait SECONDS");
    c.kind = ShellCommand::Kind::kWait;
    const std::string& v = w[1];
    size_t used = 0;
    double s = 0;
    const bool digits_only = v.find_first_not_of("0123456789.") == std::string::npos;
    try {
      s = std::stod(v, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (!digits_only || used != v.size() || !std::isfinite(s) || s <= 0 || s > 3600) {
      throw std::invalid_argument(where + "wait '" + v + "' is not a number of seconds in (0, 3600]");
    }
    c.seconds = s;
  } else if (verb == "quit" || verb == "exit") {
    expect_args(0, "quit");
    c.kind = ShellCommand::Kind::kQuit;
  } else {
    throw std::invalid_argument(where + "unknown command '" + verb + "' (move, centre, wait, quit)");
  }
  return c;
}

std::vector<ShellCommand> ParseShellScript(const std::string& text, const std::string& source) {
  std::vector<ShellCommand> out;
  std::istringstream in(text);
  int n = 0;
  for (std::string line; std::getline(in, line);) {
    if (auto c = ParseShellLine(line, ++n, source)) out.push_back(*c);
  }
  return out;
}

ShellResult RunShellScript(const std::vector<ShellCommand>& script, RobotInterface& robot, std::ostream& out) {
  ShellResult r;
  for (const ShellCommand& c : script) {
    out << "line " << c.line << ": " << c.text;
    if (c.kind == ShellCommand::Kind::kQuit) {
      out << "\n";
      r.quit = true;
      break;
    }
    if (c.kind == ShellCommand::Kind::kWait) {
      robot.SleepNs(static_cast<int64_t>(std::llround(c.seconds * 1e9)));
      r.waited_s += c.seconds;
      out << "   (waited)\n";
      continue;
    }
    const PwmVector requested = c.kind == ShellCommand::Kind::kCentre ? robot.Config().Centre() : c.pwm_us;
    ServoReply reply;
    try {
      reply = robot.SendServos(requested);
    } catch (const std::exception& e) {
      out << "\n";
      throw std::runtime_error("line " + std::to_string(c.line) + " (" + c.text + "): " + e.what());
    }
    ++r.num_moves;
    out << "   sent " << ShellPwmText(reply.sent);
    if (reply.clamped) {
      ++r.num_clamped;
      out << " (clamped from " << ShellPwmText(requested) << " to the robot file's limits)";
    }
    out << ", reply \"" << PrintableReply(reply.text) << "\"\n";
  }
  return r;
}

}  // namespace owlcal::robot
