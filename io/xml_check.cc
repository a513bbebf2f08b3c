#include "io/xml_check.h"

#include <cctype>
#include <vector>

namespace owlcal::io {
namespace {

class Scanner {
 public:
  explicit Scanner(std::string_view t) : t_(t) {}

  std::string Check() {
    if (t_.substr(0, 3) == "\xEF\xBB\xBF") i_ = 3;  // UTF-8 byte order mark
    for (size_t k = 0; k < t_.size(); ++k) {
      const unsigned char c = static_cast<unsigned char>(t_[k]);
      if (c < 0x20 && c != '\t' && c != '\n' && c != '\r') {
        i_ = k;
        return Fail("control character " + std::to_string(c) + " in the text");
      }
    }
    if (Starts("<?xml")) {
      i_ += 5;
      if (std::string e = Attributes("?>"); !e.empty()) return e;
    }
    std::vector<std::string> open;
    bool had_root = false;
    while (i_ < t_.size()) {
      if (t_[i_] != '<') {
        if (open.empty() && !std::isspace(static_cast<unsigned char>(t_[i_])))
          return Fail("text outside the root element");
        ++i_;
        continue;
      }
      if (Starts("<!--")) {
        const size_t end = t_.find("-->", i_ + 4);
        if (end == std::string_view::npos) return Fail("comment not closed ('-->' missing)");
        i_ = end + 3;
      } else if (Starts("<?")) {
        const size_t end = t_.find("?>", i_ + 2);
        if (end == std::string_view::npos) return Fail("processing instruction not closed ('?>' missing)");
        i_ = end + 2;
      } else if (Starts("</")) {
        i_ += 2;
        const std::string name = Name();
        if (name.empty()) return Fail("closing tag without a name");
        SkipSpace();
        if (!Starts(">")) return Fail("closing tag </" + name + " not closed with '>'");
        ++i_;
        if (open.empty() || open.back() != name)
          return Fail("</" + name + "> closes " + (open.empty() ? std::string("nothing") : "<" + open.back() + ">"));
        open.pop_back();
      } else {
        ++i_;
        const std::string name = Name();
        if (name.empty()) return Fail("'<' not followed by a tag name");
        if (open.empty() && had_root) return Fail("a second root element <" + name + ">");
        if (std::string e = Attributes(">"); !e.empty()) return e;
        if (t_[i_ - 2] == '/') {
          if (open.empty()) had_root = true;
        } else {
          open.push_back(name);
          had_root = true;
        }
      }
    }
    if (!open.empty()) return Fail("the text ends inside <" + open.back() + "> (truncated?)");
    if (!had_root) return Fail("no root element");
    return "";
  }

 private:
  bool Starts(std::string_view s) const { return t_.substr(i_, s.size()) == s; }
  void SkipSpace() {
    while (i_ < t_.size() && std::isspace(static_cast<unsigned char>(t_[i_]))) ++i_;
  }
  static bool NameChar(char c, bool first) {
    const unsigned char u = static_cast<unsigned char>(c);
    return std::isalpha(u) || c == '_' || c == ':' || u >= 0x80 ||
           (!first && (std::isdigit(u) || c == '-' || c == '.'));
  }
  std::string Name() {
    const size_t start = i_;
    while (i_ < t_.size() && NameChar(t_[i_], i_ == start)) ++i_;
    return std::string(t_.substr(start, i_ - start));
  }
  // name="value" pairs up to `end` ("?>" for the declaration, ">" or "/>" for a tag).
  std::string Attributes(std::string_view end) {
    while (true) {
      SkipSpace();
      if (i_ >= t_.size()) return Fail("tag not closed (the text ends inside it)");
      if (Starts(end)) {
        i_ += end.size();
        return "";
      }
      if (end == ">" && Starts("/>")) {
        i_ += 2;
        return "";
      }
      const std::string name = Name();
      if (name.empty()) return Fail("unexpected '" + std::string(1, t_[i_]) + "' inside a tag");
      SkipSpace();
      if (!Starts("=")) return Fail("attribute '" + name + "' without '=\"value\"'");
      ++i_;
      SkipSpace();
      if (i_ >= t_.size() || (t_[i_] != '"' && t_[i_] != '\''))
        return Fail("attribute '" + name + "' value not quoted");
      const size_t close = t_.find(t_[i_], i_ + 1);
      if (close == std::string_view::npos) return Fail("attribute '" + name + "' value not closed");
      if (t_.substr(i_ + 1, close - i_ - 1).find('<') != std::string_view::npos)
        return Fail("'<' inside attribute '" + name + "'");
      i_ = close + 1;
    }
  }
  std::string Fail(const std::string& what) const {
    int line = 1;
    for (size_t k = 0; k < i_ && k < t_.size(); ++k) line += t_[k] == '\n';
    return std::to_string(line) + ": " + what;
  }

  std::string_view t_;
  size_t i_ = 0;
};

}  // namespace

std::string XmlWellFormedError(std::string_view text) { return Scanner(text).Check(); }

}  // namespace owlcal::io
