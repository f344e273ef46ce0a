// Files are written under a temporary name in the same folder and renamed when complete, so a
// reader (or a resumed run) never sees a half-written file.
#pragma once
#include <filesystem>
#include <functional>
#include <string>

namespace dg {

// Calls write(tmpPath) and renames tmpPath to path when it returns. On exception the temporary is
// removed and the exception propagates. The temporary keeps the extension so that writers which
// pick a format from the name still work.
void writeAtomically(const std::filesystem::path& path,
                     const std::function<void(const std::filesystem::path&)>& write);
void writeTextAtomically(const std::filesystem::path& path, const std::string& text);
std::string readTextFile(const std::filesystem::path& path);  // throws InputError if unreadable

}  // namespace dg
