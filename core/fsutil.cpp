#include "core/fsutil.h"

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

}  // namespace dg
