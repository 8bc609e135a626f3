// Writing outputs so that a failed run never replaces a good file with a truncated one, and a set
// of files that belong together (a map and its companions) is written as one unit.
#pragma once

#include <filesystem>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

namespace vdbmap {

/// Calls `write` on a stream to a temporary file beside `path` (same folder, so the rename is
/// atomic), checks the stream, flushes it to disk and renames the temporary over `path`. On any
/// failure the temporary is removed, `path` is left as it was, and FileError names the file.
void writeFileAtomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write);

/// A temporary path beside `path` for writers that must write by file name (OpenVDB's io::File);
/// commit it with commitTemporary(), or remove it with std::filesystem::remove on failure. The
/// temporary is removed by the handlers of removeTemporariesOnSignals() if the process is stopped.
std::filesystem::path temporaryPathFor(const std::filesystem::path& path);
/// Flushes `tmp` to disk and renames it over `path` (then flushes the folder). Throws FileError
/// naming `path` (the temporary removed) when `path` is a folder or the rename fails.
void commitTemporary(const std::filesystem::path& tmp, const std::filesystem::path& path);

/// Installs SIGINT, SIGTERM and SIGHUP handlers that remove the temporaries of writes in progress
/// and then end the process as the signal would have (for programs such as the CLI; a library
/// never installs handlers by itself). Idempotent.
void removeTemporariesOnSignals();

/// Files that belong together, written as one save: each is written to a temporary beside it;
/// commit() flushes every temporary to disk, then renames them in the order they were added (add
/// the companions first and the file that names the unit last) and flushes the folders. The
/// destructor removes temporaries that were not committed. Every file of the set records
/// unitId(), a fresh random id: a stop between two renames can leave files of two saves side by
/// side, and readers tell them apart by that id instead of mixing them.
class AtomicFileSet {
 public:
  AtomicFileSet();
  ~AtomicFileSet();
  AtomicFileSet(const AtomicFileSet&) = delete;
  AtomicFileSet& operator=(const AtomicFileSet&) = delete;

  /// 32 hex digits, drawn from std::random_device.
  const std::string& unitId() const { return unit_id_; }
  /// A temporary to write `path` into by name. Throws FileError when `path`'s folder is missing,
  /// `path` is a folder, or `path` is already in the set. Temporaries of `path` left by a process
  /// that no longer runs (killed during a save) are removed first.
  std::filesystem::path add(const std::filesystem::path& path);
  /// Writes `path`'s temporary now through a stream (checked as writeFileAtomically does).
  void add(const std::filesystem::path& path, const std::function<void(std::ostream&)>& write);
  /// Makes every file visible, in the order added. Throws FileError naming the file that failed;
  /// files renamed before it stay, the others keep their previous content.
  void commit();

 private:
  struct Entry {
    std::filesystem::path path, tmp;
  };
  std::string unit_id_;
  std::vector<Entry> entries_;
  bool committed_ = false;
};

}  // namespace vdbmap
