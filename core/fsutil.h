// Files are written under a temporary name in the same folder and renamed when complete, so a
// reader (or a resumed run) never sees a half-written file.
#pragma once
#include <filesystem>
#include <functional>
#include <iosfwd>
#include <string>

namespace dg {

// Calls write(tmpPath) and renames tmpPath to path when it returns. On exception the temporary is
// removed and the exception propagates. The temporary keeps the extension so that writers which
// pick a format from the name still work.
void writeAtomically(const std::filesystem::path& path,
                     const std::function<void(const std::filesystem::path&)>& write);
void writeTextAtomically(const std::filesystem::path& path, const std::string& text);
// The same for text written piece by piece into a binary stream (a file too large to hold whole).
void writeStreamAtomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write);
// Throws WriteError for `path`: "cannot write the file (reason)", and where the file system holding
// it is (nearly) full, that. writeAtomically reports the writers' I/O failures through it.
[[noreturn]] void throwWriteError(const std::filesystem::path& path, const std::string& reason);
std::string readTextFile(const std::filesystem::path& path);  // throws InputError if unreadable
// At most the first `bytes` bytes of a file: all of it when it is shorter, "" when it cannot be
// opened (for a look at a header before a library parses the file, which reports what is wrong).
std::string readFileHead(const std::filesystem::path& path, size_t bytes);

// A file name's extension in lower case, with its dot (".png"); "" if it has none.
std::string lowerExtension(const std::filesystem::path& path);

// While it lives, what is written to the standard error stream (file descriptor 2) is discarded.
// For reading a file with a library that prints its own complaint before it returns the error we
// report (libpng's default handler, under OpenImageIO, prints "libpng error: ..."), so that bad
// input gives one message. Only around single-threaded reads: the descriptor is the process's.
class QuietStderr {
 public:
  QuietStderr();
  ~QuietStderr();
  QuietStderr(const QuietStderr&) = delete;
  QuietStderr& operator=(const QuietStderr&) = delete;

 private:
  int saved_ = -1;
};

// A library's error text as part of one line: line breaks become "; ", the ends trimmed.
std::string oneLineError(const std::string& text);

// After a read that succeeded: libjpeg decodes a damaged JPEG (a file cut short, say) and only
// warns, its missing part filled grey, and an image reader keeps that warning as its error text.
// With `format` "jpeg" and a non-empty `reader_error`, throws an InputError for `path`:
// "<what> is damaged (<warning>); <advice>".
void refuseDamagedJpeg(const std::string& path, const std::string& format, const std::string& reader_error,
                       const std::string& what, const std::string& advice);

}  // namespace dg
