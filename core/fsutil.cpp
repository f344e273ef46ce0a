#include "core/fsutil.h"

#include <cctype>
#include <cerrno>
#include <cstring>
#include <cstdio>
#include <fcntl.h>
#include <fstream>
#include <sstream>
#include <unistd.h>

#include "core/error.h"

namespace dg {

namespace fs = std::filesystem;

void throwWriteError(const fs::path& path, const std::string& reason) {
  std::string msg = "cannot write the file (" + oneLineError(reason) + ")";
  std::error_code ec;
  const fs::space_info sp = fs::space(path.parent_path().empty() ? fs::path(".") : path.parent_path(), ec);
  if (!ec && sp.available < (1u << 20))
    msg += "; the file system holding it is full (" + std::to_string(sp.available / 1024) + " KiB free)";
  throw WriteError(path.string(), msg);
}

void writeAtomically(const fs::path& path, const std::function<void(const fs::path&)>& write) {
  fs::path tmp = path.parent_path() /
                 (".tmp-" + std::to_string(::getpid()) + "-" + path.filename().string());
  std::error_code ec;
  try {
    write(tmp);
  } catch (const InputError&) {
    fs::remove(tmp, ec);
    throw;
  } catch (const std::runtime_error& e) {  // the writers' I/O failures (std::logic_error is a bug)
    fs::remove(tmp, ec);
    throwWriteError(path, e.what());
  } catch (...) {
    fs::remove(tmp, ec);
    throw;
  }
  fs::rename(tmp, path, ec);
  if (ec) {
    const std::string reason = ec.message();
    fs::remove(tmp, ec);
    throwWriteError(path, reason);
  }
}

void writeStreamAtomically(const fs::path& path, const std::function<void(std::ostream&)>& write) {
  writeAtomically(path, [&](const fs::path& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    if (!f) throw std::runtime_error(std::string("cannot open it: ") + std::strerror(errno));
    write(f);
    f.close();
    if (!f) throw std::runtime_error(std::string(std::strerror(errno)));
  });
}

void writeTextAtomically(const fs::path& path, const std::string& text) {
  writeStreamAtomically(path, [&](std::ostream& f) { f << text; });
}

std::string readTextFile(const fs::path& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw InputError(path.string(), "is a folder, expected a file");
  std::ifstream f(path, std::ios::binary);
  if (!f) throw InputError(path.string(), std::string("cannot open the file for reading (") + std::strerror(errno) + ")");
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

std::string readFileHead(const fs::path& path, size_t bytes) {
  std::ifstream in(path, std::ios::binary);
  std::string head(bytes, '\0');
  in.read(&head[0], std::streamsize(head.size()));
  head.resize(size_t(in.gcount()));
  return head;
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

void refuseDamagedJpeg(const std::string& path, const std::string& format, const std::string& reader_error,
                       const std::string& what, const std::string& advice) {
  if (format != "jpeg") return;
  const std::string warning = oneLineError(reader_error);
  if (!warning.empty()) throw InputError(path, what + " is damaged (" + warning + "); " + advice);
}

}  // namespace dg
