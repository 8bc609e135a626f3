#include "vdbmap/atomic_file.hpp"

#include "vdbmap/file_error.hpp"

#include <atomic>
#include <fstream>
#include <stdexcept>
#include <string>
#include <unistd.h>

namespace vdbmap {

std::filesystem::path temporaryPathFor(const std::filesystem::path& path) {
  static std::atomic<unsigned> counter{0};
  std::filesystem::path tmp = path;
  tmp += ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
  return tmp;
}

namespace {

const char* const kIsFolder = "it is a folder (give a file name)";

}  // namespace

void commitTemporary(const std::filesystem::path& tmp, const std::filesystem::path& path) {
  std::error_code ec;
  std::string reason;
  if (std::filesystem::is_directory(path, ec)) {
    reason = kIsFolder;
  } else {
    std::filesystem::rename(tmp, path, ec);
    // The reason is taken before remove() below resets the error (it once read "Success").
    if (ec) reason = "rename from " + tmp.filename().string() + " failed: " + ec.message();
  }
  if (!reason.empty()) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    throw FileError("cannot write " + path.string() + ": " + reason);
  }
}

void writeFileAtomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write) {
  if (path.has_parent_path() && !std::filesystem::is_directory(path.parent_path()))
    throw FileError("cannot write " + path.string() + ": folder " + path.parent_path().string() +
                    " does not exist");
  // Writing over a folder would fail only at the rename, after all the work: refused up front.
  if (std::error_code ec; std::filesystem::is_directory(path, ec))
    throw FileError("cannot write " + path.string() + ": " + kIsFolder);
  const std::filesystem::path tmp = temporaryPathFor(path);
  try {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw FileError("cannot open " + tmp.string() + " for writing");
    write(out);
    out.flush();
    if (!out) throw FileError("write error on " + tmp.string() + " (disk full?)");
    out.close();
  } catch (...) {
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    throw;
  }
  commitTemporary(tmp, path);
}

}  // namespace vdbmap
