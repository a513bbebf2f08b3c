// owlcal jog --robot sim|HOST --out DIR: find each servo's maximal range by hand (arrow keys),
// write it as a robot file and as the Pi server's clamp constants, then re-validate it with the
// limits protocol (protocols/jog.h, robot/server_clamp_constants.h, protocols/limits_revalidation.h).
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include "apps/command_registry.h"
#include "apps/robot_factory.h"
#include "apps/robot_options.h"
#include "protocols/jog.h"
#include "protocols/limits_revalidation.h"
#include "protocols/protocol.h"
#include "reports/table.h"
#include "robot/link_commands.h"
#include "robot/robot_file.h"
#include "robot/server_clamp_constants.h"

namespace owlcal::apps {
namespace {
namespace fs = std::filesystem;

struct JogCmdOptions {
  RobotOptions robot;
  std::string out;
  protocols::JogOptions jog;
  std::vector<std::string> revalidate_servos{"Rx", "Ry", "Lx", "Ly", "Neck"};
  bool no_revalidate = false;
  int tolerance_us = 10;
};

const char* kKeys =
    "keys: 1-5 select Rx Ry Lx Ly Neck (Tab: next) | arrows or +/-: step | [ ]: go to the min/max limit\n"
    "      w: widen the limit on this side by one small step (beyond the file's limit: explicit)\n"
    "      a: widen step by step until the images show the end-stop or the socket rim\n"
    "      Enter or c: confirm the current pulse as this side's limit | x: centre\n"
    "      s: save (robot file, server constants) and re-validate | q: quit without saving | ?: keys\n";

// Terminal input: raw keys (no echo, no line buffering) on a tty, else lines of key characters
// after a prompt. Restores the terminal on destruction.
class KeyInput {
 public:
  KeyInput() : tty_(::isatty(STDIN_FILENO)) {
    if (!tty_) return;
    if (::tcgetattr(STDIN_FILENO, &saved_) != 0) {
      tty_ = false;
      return;
    }
    termios raw = saved_;
    raw.c_lflag &= ~tcflag_t(ICANON | ECHO | ISIG);
    raw.c_cc[VMIN] = 1;
    raw.c_cc[VTIME] = 0;
    ::tcsetattr(STDIN_FILENO, TCSANOW, &raw);
  }
  ~KeyInput() {
    if (tty_) ::tcsetattr(STDIN_FILENO, TCSANOW, &saved_);
  }
  bool Tty() const { return tty_; }

  // The next key as a token: one character, or "up" "down" "left" "right" "enter"; "" at the end
  // of input.
  std::string Next() {
    if (!tty_) {
      while (pending_.empty()) {
        std::cout << "jog> " << std::flush;
        std::string line;
        if (!std::getline(std::cin, line)) return "";
        for (char c : line)
          if (c != ' ' && c != '\r') pending_ += c;
      }
      const char c = pending_.front();
      pending_.erase(0, 1);
      return std::string(1, c);
    }
    char c = 0;
    if (::read(STDIN_FILENO, &c, 1) != 1) return "";
    if (c == '\r' || c == '\n') return "enter";
    if (c == 27) {
      char seq[2] = {0, 0};
      for (char& s : seq) {
        pollfd p{STDIN_FILENO, POLLIN, 0};
        if (::poll(&p, 1, 50) <= 0 || ::read(STDIN_FILENO, &s, 1) != 1) return "escape";
      }
      if (seq[0] == '[' || seq[0] == 'O') {
        switch (seq[1]) {
          case 'A':
            return "up";
          case 'B':
            return "down";
          case 'C':
            return "right";
          case 'D':
            return "left";
          default:
            break;
        }
      }
      return "escape";
    }
    return std::string(1, c);
  }

 private:
  bool tty_;
  termios saved_{};
  std::string pending_;
};

std::string JogCsv(const protocols::JogSession& s) {
  std::ostringstream o;
  o << "servo,end,file_us,new_us,how,in_file,message\n";
  for (int i = 0; i < models::kNumServos; ++i)
    for (int d : {-1, 1}) {
      const protocols::JogEnd& e = s.End(i, d);
      std::string msg = e.message;
      for (char& c : msg)
        if (c == ',' || c == '"' || c == '\n') c = ';';
      o << models::kServoNames[i] << "," << (d > 0 ? "max" : "min") << "," << e.file_us << "," << e.limit_us << ","
        << e.how << "," << (e.Final() ? e.limit_us : e.file_us) << "," << msg << "\n";
    }
  return o.str();
}

int Save(const JogCmdOptions& o, const protocols::JogSession& s) {
  std::vector<std::string> notes;
  const models::RobotConfig result = s.Result(&notes);
  fs::create_directories(o.out);
  const std::string robot_path = o.out + "/robot.yaml";
  robot::SaveRobotFile(result, robot_path);
  reports::WriteTextFile(o.out + "/server_limits.py", robot::PythonServerClamp(result));
  reports::WriteTextFile(o.out + "/server_limits.h", robot::CServerRanges(result));
  reports::WriteTextFile(o.out + "/jog.csv", JogCsv(s));
  std::cout << "wrote " << robot_path << ", " << o.out << "/server_limits.py (Python server), " << o.out
            << "/server_limits.h (C server), " << o.out << "/jog.csv\n";
  for (const std::string& n : notes) std::cout << "note: " << n << "\n";
  for (int i = 0; i < models::kNumServos; ++i)
    std::cout << "  " << models::kServoNames[i] << ": " << result.servos[i].min_us << " .. " << result.servos[i].max_us
              << " us (" << s.End(i, -1).how << ", " << s.End(i, 1).how << ")\n";
  if (o.no_revalidate) return kExitOk;

  // Re-validation: the limits protocol on a robot configured with the new file.
  protocols::RevalidationOptions ro;
  ro.servos.clear();
  for (const std::string& n : o.revalidate_servos) {
    const int i = protocols::ServoIndexFromName(n);
    if (i < 0) throw UsageError("--revalidate-servos: no servo '" + n + "'");
    ro.servos.push_back(i);
  }
  ro.tolerance_us = o.tolerance_us;
  ro.progress = &std::cout;
  RobotFactoryOptions fo = o.robot.Factory();
  fo.robot_config = robot::LoadRobotFile(robot_path);  // what was written, read back
  std::cout << "re-validating " << robot_path << " with the limits protocol...\n";
  std::unique_ptr<robot::RobotInterface> check = MakeRobot(o.robot.robot, fo);
  const std::string dataset = o.out + "/revalidation";
  fs::remove_all(dataset);
  const std::vector<protocols::ServoRevalidation> rv = protocols::RevalidateLimits(*check, dataset, ro);
  std::ostringstream csv;
  csv << "servo,result,min_us,max_us,measured_min_us,measured_max_us,cause_min,cause_max,message\n";
  int failed = 0;
  std::cout << "re-validation (limits protocol, dataset " << dataset << "):\n";
  for (const auto& r : rv) {
    failed += !r.pass;
    std::string msg = r.message;
    for (char& c : msg)
      if (c == ',' || c == '"' || c == '\n') c = ';';
    csv << models::kServoNames[r.servo] << "," << (r.pass ? "pass" : "fail") << "," << r.limit_us[0] << ","
        << r.limit_us[1] << "," << r.measured_us[0] << "," << r.measured_us[1] << "," << r.cause[0] << "," << r.cause[1]
        << "," << msg << "\n";
    std::cout << "  " << models::kServoNames[r.servo] << ": " << (r.pass ? "PASS" : "FAIL") << "  " << r.limit_us[0]
              << " .. " << r.limit_us[1] << " us, measured " << r.measured_us[0] << " (" << r.cause[0] << ") .. "
              << r.measured_us[1] << " (" << r.cause[1] << "): " << r.message << "\n";
  }
  reports::WriteTextFile(o.out + "/revalidation.csv", csv.str());
  std::cout << (failed ? std::to_string(failed) + " servo(s) failed the re-validation" : "every servo passed") << " ("
            << o.out << "/revalidation.csv)\n";
  return failed ? 3 : kExitOk;
}

int RunJog(const JogCmdOptions& o) {
  std::string why;
  if (!o.jog.Check(&why)) throw UsageError(why);
  // The current file: its limits are what the jog never passes without an explicit key.
  const models::RobotConfig file = !o.robot.robot_file.empty() ? robot::LoadRobotFile(o.robot.robot_file)
                                   : o.robot.IsSim()           ? MakeRobot("sim", o.robot.Factory())->Config()
                                                               : models::DefaultRobotConfig();
  RobotFactoryOptions fo = o.robot.Factory();
  fo.robot_config = protocols::MakeJogRobotConfig(file, o.jog);
  int code = kExitOk;
  bool save = false;
  std::unique_ptr<protocols::JogSession> session;
  {
    std::unique_ptr<robot::RobotInterface> robot = MakeRobot(o.robot.robot, fo);
    {
      // The scene the image checks need, as the limits protocol sets it up (its placement
      // steps: a plain textured wall; on a real robot a person is asked), recorded in
      // DIR/jog-setup. The re-validation then sees the same scene.
      protocols::RunOptions ro;
      ro.out_dir = o.out + "/jog-setup";
      fs::remove_all(ro.out_dir);
      ro.interactive = !o.robot.IsSim() && ::isatty(STDIN_FILENO);
      ro.progress = &std::cout;
      o.robot.FillRunOptions(&ro);
      const protocols::RunSummary rs = protocols::SetUpLimitsScene(*robot, ro);
      if (rs.status != "complete") {
        std::cerr << "owlcal jog: scene set-up " << rs.status << ": " << rs.message << "\n";
        return kExitFailed;
      }
    }
    // The session prints each event (every widening step too); the loop adds the status line.
    session = std::make_unique<protocols::JogSession>(*robot, file, o.jog, &std::cout);
    KeyInput keys;
    const char* nl = "\n";
    std::cout << "owlcal jog on " << robot->Describe() << " (limits of " << file.name << "; the Pi server clamps to\n"
              << "its own table: to look beyond it, raise it for the session)" << std::endl;
    session->Start();
    std::cout << kKeys << (keys.Tty() ? "raw keys ready" : "prompt mode: type keys, then Enter") << nl
              << session->StatusLine() << std::endl;
    auto side = [&] {
      const int p = session->Pose()[session->Selected()];
      const int c = file.servos[session->Selected()].centre_us;
      return p > c ? 1 : (p < c ? -1 : 0);
    };
    for (;;) {
      const std::string k = keys.Next();
      std::string line;
      bool own_line = false;  // the line is the command's own (the session printed its events)
      if (k.empty() || k == "q" || k == "\x03" || k == "\x04") {
        std::cout << (k.empty() ? "end of input: " : "") << "quit without saving" << std::endl;
        code = k.empty() ? kExitFailed : kExitOk;
        break;
      }
      if (k == "s") {
        save = true;
        break;
      }
      if (k.size() == 1 && k[0] >= '1' && k[0] <= '5') {
        session->Select(k[0] - '1');
        line = std::string("selected ") + models::kServoNames[session->Selected()];
        own_line = true;
      } else if (k == "\t") {
        session->Select((session->Selected() + 1) % models::kNumServos);
        line = std::string("selected ") + models::kServoNames[session->Selected()];
        own_line = true;
      } else if (k == "right" || k == "up" || k == "+" || k == "=") {
        line = session->Step(+1);
      } else if (k == "left" || k == "down" || k == "-") {
        line = session->Step(-1);
      } else if (k == "]") {
        line = session->GoToLimit(+1);
      } else if (k == "[") {
        line = session->GoToLimit(-1);
      } else if (k == "w" || k == "a") {
        const int d = side();
        if (d == 0) {
          line = "at the centre: step toward the end to widen first";
          own_line = true;
        } else {
          line = k == "w" ? session->Widen(d) : session->WidenAuto(d);
        }
      } else if (k == ">") {
        line = session->Widen(+1);
      } else if (k == "<") {
        line = session->Widen(-1);
      } else if (k == "enter" || k == "c") {
        line = session->Confirm();
      } else if (k == "x") {
        line = session->Centre();
      } else if (k == "?" || k == "h") {
        line = kKeys;
        own_line = true;
      } else {
        line = "unknown key '" + k + "' (? for the keys)";
        own_line = true;
      }
      if (own_line) std::cout << line << nl;
      std::cout << session->StatusLine() << std::endl;
    }
    session->Centre();  // park the head before anything else
  }
  if (save) code = Save(o, *session);
  return code;
}

const bool kJogRegistered = RegisterCommand(
    "jog",
    "Find each servo's maximal range by hand (arrow keys, live position and image feedback; a\n"
    "prompt when stdin is not a terminal). A limit is widened only by an explicit key, in small\n"
    "steps, until you confirm it or the images show the end-stop or the socket rim. Writes\n"
    "DIR/robot.yaml (a robot file), DIR/server_limits.py and DIR/server_limits.h (the Pi server's\n"
    "clamp constants in the Python and C forms of the Owl guide) and DIR/jog.csv, then runs the\n"
    "limits protocol on the new file (DIR/revalidation/, DIR/revalidation.csv: pass or fail per\n"
    "servo; exit code 3 when a servo fails).",
    [](CLI::App* cmd) {
      auto o = std::make_shared<JogCmdOptions>();
      AddRobotOptions(cmd, &o->robot);
      cmd->add_option("--out", o->out, "output folder")->required();
      cmd->add_option("--step-us", o->jog.step_us, "one arrow key [us]");
      cmd->add_option("--widen-step-us", o->jog.widen_step_us, "one widening step beyond a limit [us]");
      cmd->add_option("--settle-ms", o->jog.settle_ms, "wait after each move before an image [ms]");
      cmd->add_option("--envelope-min-us", o->jog.envelope_min_us, "never command below [us]");
      cmd->add_option("--envelope-max-us", o->jog.envelope_max_us, "never command above [us]");
      cmd->add_option("--revalidate-servos", o->revalidate_servos, "servos the re-validation checks (default all)");
      cmd->add_flag("--no-revalidate", o->no_revalidate, "write the files only");
      cmd->add_option("--tolerance-us", o->tolerance_us, "re-validation: how far inside a limit an end may be [us]");
      return [o] { return RunJog(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
