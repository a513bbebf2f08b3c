#include "io/atomic_file.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>

namespace owlcal::io {
namespace {

namespace fs = std::filesystem;

// Writes, flushes and closes `f`; returns errno of the first failing step, 0 when all succeed.
int WriteAndClose(FILE* f, std::string_view data) {
  int err = 0;
  if (!data.empty() && std::fwrite(data.data(), 1, data.size(), f) != data.size()) err = errno;
  if (err == 0 && std::fflush(f) != 0) err = errno;
  if (err == 0 && std::ferror(f)) err = EIO;
  if (std::fclose(f) != 0 && err == 0) err = errno;
  return err;
}

[[noreturn]] void Fail(const std::string& path, const char* what, int err) {
  throw std::runtime_error(path + ": " + what + ": " + std::strerror(err != 0 ? err : EIO));
}

}  // namespace

void WriteFileAtomic(const std::string& path, std::string_view data) {
  std::error_code ec;
  fs::path target(path);
  if (fs::is_symlink(fs::symlink_status(target, ec))) {
    const fs::path resolved = fs::weakly_canonical(target, ec);
    if (!ec) target = resolved;
  }
  const fs::file_status st = fs::status(target, ec);
  if (fs::exists(st) && !fs::is_regular_file(st)) {
    if (fs::is_directory(st)) throw std::runtime_error(path + ": cannot write: it is a directory");
    FILE* f = std::fopen(target.c_str(), "wb");
    if (!f) Fail(path, "cannot open for writing", errno);
    if (const int err = WriteAndClose(f, data); err != 0) Fail(path, "write failed", err);
    return;
  }
  const std::string tmp = target.string() + ".tmp-" + std::to_string(::getpid());
  FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) Fail(path, ("cannot create " + tmp).c_str(), errno);
  if (const int err = WriteAndClose(f, data); err != 0) {
    std::remove(tmp.c_str());
    Fail(path, "write failed", err);
  }
  if (std::rename(tmp.c_str(), target.c_str()) != 0) {
    const int err = errno;
    std::remove(tmp.c_str());
    Fail(path, ("cannot rename " + tmp + " into place").c_str(), err);
  }
}

bool IsAtomicTemporary(const std::string& file_name) {
  const size_t p = file_name.rfind(".tmp");
  if (p == std::string::npos || p == 0) return false;
  const std::string rest = file_name.substr(p + 4);
  if (rest.empty()) return true;
  return rest.size() > 1 && rest[0] == '-' && rest.find_first_not_of("0123456789", 1) == std::string::npos;
}

}  // namespace owlcal::io
