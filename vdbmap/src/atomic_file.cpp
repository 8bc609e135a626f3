#include "vdbmap/atomic_file.hpp"

#include "vdbmap/file_error.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <random>
#include <stdexcept>
#include <string>
#include <sys/types.h>
#include <unistd.h>

namespace vdbmap {
namespace {

const char* const kIsFolder = "it is a folder (give a file name)";

// ---- temporaries known to the signal handlers ---------------------------------------------------
// A fixed table of C strings, so the handler reads it without allocating or locking: a slot is
// claimed (kWriting), filled, then published (kReady); the handler unlinks published slots only.
// Slots are released when their temporary is committed or found gone; a full table only means a
// temporary would not be removed on a signal.
enum SlotState : int { kFree = 0, kWriting = 1, kReady = 2 };
struct Slot {
  std::atomic<int> state{kFree};
  char path[4096];
};
std::array<Slot, 64> g_slots;

void registerTemporary(const std::filesystem::path& tmp) {
  const std::string s = tmp.string();
  if (s.size() >= sizeof(Slot::path)) return;
  for (int pass = 0; pass < 2; ++pass) {
    for (Slot& slot : g_slots) {
      int expected = kFree;
      if (!slot.state.compare_exchange_strong(expected, kWriting)) continue;
      std::memcpy(slot.path, s.c_str(), s.size() + 1);
      slot.state.store(kReady);
      return;
    }
    // Full: release slots whose temporary is gone (removed by a writer's failure path).
    for (Slot& slot : g_slots) {
      int expected = kReady;
      if (!slot.state.compare_exchange_strong(expected, kWriting)) continue;
      slot.state.store(::access(slot.path, F_OK) == 0 ? kReady : kFree);
    }
  }
}

void unregisterTemporary(const std::filesystem::path& tmp) {
  const std::string s = tmp.string();
  for (Slot& slot : g_slots) {
    int expected = kReady;
    if (!slot.state.compare_exchange_strong(expected, kWriting)) continue;
    slot.state.store(s == slot.path ? kFree : kReady);
  }
}

extern "C" void removeTemporariesAndStop(int sig) {
  for (Slot& slot : g_slots)
    if (slot.state.load() == kReady) ::unlink(slot.path);
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

// ---- durability --------------------------------------------------------------------------------
void syncPath(const std::filesystem::path& path, bool folder) {
  const int fd = ::open(path.c_str(), folder ? O_RDONLY | O_DIRECTORY : O_RDONLY);
  if (fd < 0) {
    if (folder) return;  // some file systems do not open folders; the rename is still atomic
    throw FileError("cannot write " + path.string() + ": cannot reopen it to flush: " + std::strerror(errno));
  }
  const int rc = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  if (rc != 0 && !folder) throw FileError("cannot write " + path.string() + ": flush to disk failed: " + std::strerror(err));
}

std::filesystem::path folderOf(const std::filesystem::path& path) {
  return path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
}

void checkWritable(const std::filesystem::path& path) {
  if (path.has_parent_path() && !std::filesystem::is_directory(path.parent_path()))
    throw FileError("cannot write " + path.string() + ": folder " + path.parent_path().string() + " does not exist");
  // Writing over a folder would fail only at the rename, after all the work: refused up front.
  if (std::error_code ec; std::filesystem::is_directory(path, ec))
    throw FileError("cannot write " + path.string() + ": " + kIsFolder);
}

void writeStream(const std::filesystem::path& tmp, const std::function<void(std::ostream&)>& write) {
  std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
  if (!out) throw FileError("cannot open " + tmp.string() + " for writing");
  write(out);
  out.flush();
  if (!out) throw FileError("write error on " + tmp.string() + " (disk full?)");
  out.close();
}

void removeQuietly(const std::filesystem::path& tmp) {
  std::error_code ec;
  std::filesystem::remove(tmp, ec);
  unregisterTemporary(tmp);
}

/// Renames a flushed temporary over `path`; on failure removes the temporary and throws.
void renameOver(const std::filesystem::path& tmp, const std::filesystem::path& path) {
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
    removeQuietly(tmp);
    throw FileError("cannot write " + path.string() + ": " + reason);
  }
  unregisterTemporary(tmp);
}

/// Removes `path`'s temporaries left by processes that no longer run (a SIGKILL during a save):
/// files named `<name>.tmp.<pid>.<n>` beside it whose pid is not alive. Others are left alone.
void removeStaleTemporaries(const std::filesystem::path& path) {
  const std::string prefix = path.filename().string() + ".tmp.";
  std::error_code ec;
  for (std::filesystem::directory_iterator it(folderOf(path), ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string rest = name.substr(prefix.size());
    const std::size_t dot = rest.find('.');
    if (dot == 0 || dot == std::string::npos || rest.find_first_not_of("0123456789.") != std::string::npos) continue;
    const long pid = std::strtol(rest.substr(0, dot).c_str(), nullptr, 10);
    if (pid <= 0 || pid == long(::getpid())) continue;
    if (::kill(pid_t(pid), 0) == -1 && errno == ESRCH) {
      std::error_code ignored;
      std::filesystem::remove(it->path(), ignored);
    }
  }
}

std::string randomUnitId() {
  std::random_device rd;
  static const char* const kHex = "0123456789abcdef";
  std::string id;
  for (int word = 0; word < 4; ++word) {
    const std::uint32_t v = rd();
    for (int nibble = 7; nibble >= 0; --nibble) id += kHex[(v >> (4 * nibble)) & 0xFu];
  }
  return id;
}

}  // namespace

std::filesystem::path temporaryPathFor(const std::filesystem::path& path) {
  static std::atomic<unsigned> counter{0};
  std::filesystem::path tmp = path;
  tmp += ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
  registerTemporary(tmp);
  return tmp;
}

void commitTemporary(const std::filesystem::path& tmp, const std::filesystem::path& path) {
  if (std::error_code ec; !std::filesystem::is_directory(path, ec) && std::filesystem::exists(tmp, ec)) {
    try {
      syncPath(tmp, false);
    } catch (...) {
      removeQuietly(tmp);
      throw;
    }
  }
  renameOver(tmp, path);
  syncPath(folderOf(path), true);
}

void removeTemporariesOnSignals() {
  static std::atomic<bool> installed{false};
  if (installed.exchange(true)) return;
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) std::signal(sig, removeTemporariesAndStop);
}

void writeFileAtomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write) {
  checkWritable(path);
  const std::filesystem::path tmp = temporaryPathFor(path);
  try {
    writeStream(tmp, write);
  } catch (...) {
    removeQuietly(tmp);
    throw;
  }
  commitTemporary(tmp, path);
}

// ---- AtomicFileSet -----------------------------------------------------------------------------
AtomicFileSet::AtomicFileSet() : unit_id_(randomUnitId()) {}

AtomicFileSet::~AtomicFileSet() {
  if (committed_) return;
  for (const Entry& e : entries_) removeQuietly(e.tmp);
}

std::filesystem::path AtomicFileSet::add(const std::filesystem::path& path) {
  if (committed_) throw std::logic_error("AtomicFileSet::add after commit");
  checkWritable(path);
  removeStaleTemporaries(path);
  for (const Entry& e : entries_)
    if (std::filesystem::absolute(e.path) == std::filesystem::absolute(path))
      throw FileError("cannot write " + path.string() + ": the same save writes it twice (its companions' names "
                      "collide with it)");
  entries_.push_back({path, temporaryPathFor(path)});
  return entries_.back().tmp;
}

void AtomicFileSet::add(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write) {
  const std::filesystem::path tmp = add(path);
  writeStream(tmp, write);  // on failure the destructor removes every temporary of the set
}

void AtomicFileSet::commit() {
  if (committed_) throw std::logic_error("AtomicFileSet::commit twice");
  for (const Entry& e : entries_) syncPath(e.tmp, false);
  committed_ = true;
  std::size_t k = 0;
  try {
    for (; k < entries_.size(); ++k) renameOver(entries_[k].tmp, entries_[k].path);
  } catch (...) {
    for (std::size_t j = k + 1; j < entries_.size(); ++j) removeQuietly(entries_[j].tmp);
    throw;
  }
  std::vector<std::filesystem::path> folders;
  for (const Entry& e : entries_) {
    const std::filesystem::path f = folderOf(e.path);
    if (std::find(folders.begin(), folders.end(), f) == folders.end()) folders.push_back(f);
  }
  for (const auto& f : folders) syncPath(f, true);
}

}  // namespace vdbmap
