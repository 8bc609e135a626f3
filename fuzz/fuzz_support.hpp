// Shared by the fuzz targets (fuzz_*.cpp): a scratch folder per process for parsers that read
// files, and the one rule for what a target may swallow. See docs/fuzzing.md.
//
// The contract every parser states (DESIGN.md, "Errors"): bad input is refused with
// std::runtime_error (vdbmap::FileError, io::BadFrameError) or std::invalid_argument, whose
// message names the problem. Anything else that escapes (std::out_of_range, std::length_error,
// std::bad_alloc, a library's own exception type), a crash, undefined behaviour, a hang or an
// allocation beyond the fuzzer's limit is a finding.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <system_error>

#include <unistd.h>

namespace vdbmap::fuzz {

/// An empty folder of this process's own (under $TMPDIR, else /tmp), emptied again on each call,
/// so that one input's files never leak into the next. Removed when the process exits normally.
inline std::filesystem::path freshScratchDir() {
  struct Scratch {
    std::filesystem::path dir;
    Scratch() {
      std::error_code ec;
      std::filesystem::path base = std::filesystem::temp_directory_path(ec);
      if (ec) base = "/tmp";
      dir = base / ("vdbmap-fuzz-" + std::to_string(::getpid()));
    }
    ~Scratch() {
      std::error_code ec;
      std::filesystem::remove_all(dir, ec);
    }
  };
  static Scratch scratch;
  std::error_code ec;
  std::filesystem::remove_all(scratch.dir, ec);
  std::filesystem::create_directories(scratch.dir, ec);
  if (ec) {
    std::fprintf(stderr, "fuzz: cannot create %s: %s\n", scratch.dir.c_str(), ec.message().c_str());
    std::abort();  // a broken harness must not look like a clean run
  }
  return scratch.dir;
}

/// Writes `size` bytes to `path` (whose folder exists); aborts when it cannot (harness failure).
inline void writeFile(const std::filesystem::path& path, const std::uint8_t* data, std::size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (size > 0) out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
  out.close();
  if (!out) {
    std::fprintf(stderr, "fuzz: cannot write %s\n", path.c_str());
    std::abort();
  }
}

/// Aborts when a refusal's message is empty (it must name the problem).
inline void requireMessage(const std::exception& e) {
  if (e.what() == nullptr || e.what()[0] == '\0') {
    std::fprintf(stderr, "fuzz: a parser refused the input with an empty message\n");
    std::abort();
  }
}

/// Runs `parse()` and swallows the documented refusals: std::runtime_error (FileError and the
/// io errors derive from it) and std::invalid_argument. Their message must name the problem, so
/// an empty one aborts. Every other exception propagates and ends the run as a crash.
template <class F>
void expectRefusalOrSuccess(F&& parse) {
  try {
    parse();
  } catch (const std::runtime_error& e) {
    requireMessage(e);
  } catch (const std::invalid_argument& e) {
    requireMessage(e);
  }
}

}  // namespace vdbmap::fuzz
