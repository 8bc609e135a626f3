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

void commitTemporary(const std::filesystem::path& tmp, const std::filesystem::path& path) {
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    throw FileError("cannot write " + path.string() + ": rename failed: " + ec.message());
  }
}

void writeFileAtomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write) {
  if (path.has_parent_path() && !std::filesystem::is_directory(path.parent_path()))
    throw FileError("cannot write " + path.string() + ": folder " + path.parent_path().string() +
                    " does not exist");
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
