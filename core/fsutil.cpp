#include "core/fsutil.h"

#include <cctype>
#include <cstdio>
#include <fcntl.h>
#include <fstream>
#include <sstream>
#include <unistd.h>

#include "core/error.h"

namespace dg {

namespace fs = std::filesystem;

void writeAtomically(const fs::path& path, const std::function<void(const fs::path&)>& write) {
  fs::path tmp = path.parent_path() /
                 (".tmp-" + std::to_string(::getpid()) + "-" + path.filename().string());
  try {
    write(tmp);
  } catch (...) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw;
  }
  fs::rename(tmp, path);
}

void writeTextAtomically(const fs::path& path, const std::string& text) {
  writeAtomically(path, [&](const fs::path& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    f << text;
    f.close();
    if (!f) throw std::runtime_error("cannot write " + tmp.string());
  });
}

std::string readTextFile(const fs::path& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw InputError(path.string(), "cannot open file for reading");
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

std::string lowerExtension(const fs::path& path) {
  std::string ext = path.extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

QuietStderr::QuietStderr() {
  std::fflush(stderr);
  saved_ = ::dup(2);
  const int null = ::open("/dev/null", O_WRONLY);
  if (saved_ >= 0 && null >= 0) ::dup2(null, 2);
  if (null >= 0) ::close(null);
}

QuietStderr::~QuietStderr() {
  if (saved_ < 0) return;
  std::fflush(stderr);
  ::dup2(saved_, 2);
  ::close(saved_);
}

std::string oneLineError(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '\r') continue;
    if (c == '\n')
      out += "; ";
    else
      out += c;
  }
  while (!out.empty() && (out.back() == ' ' || out.back() == ';')) out.pop_back();
  while (!out.empty() && (out.front() == ' ' || out.front() == ';')) out.erase(out.begin());
  return out;
}

}  // namespace dg
