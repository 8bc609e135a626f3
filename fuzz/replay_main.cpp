// The fuzz targets as regression tests in the normal build (VDBMAP_FUZZ off): a main that feeds
// every file of the folders (or files) given on the command line to LLVMFuzzerTestOneInput, as
// libFuzzer does when it replays a corpus. A crasher kept under fuzz/regressions/<target>/
// crashes this program again (CTest: failed) if its fix is undone. Crashers found but not fixed
// yet wait in a sub-folder named "open", which is skipped (and counted) until they move up with
// their fix. See docs/fuzzing.md.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <sys/resource.h>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

// As the fuzzer's -malloc_limit_mb=1024, a reader allocating gigabytes for a small file is a
// failure here too, even where the allocation would have succeeded (lazily) and the reader then
// refused the file: under AddressSanitizer by its own limit on one allocation (an address-space
// limit would break its shadow memory), otherwise by limiting the address space to 2 GiB, where
// such an allocation throws std::bad_alloc, which no reader may let escape.
#if defined(__SANITIZE_ADDRESS__)
#define VDBMAP_REPLAY_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define VDBMAP_REPLAY_ASAN 1
#endif
#endif
#ifdef VDBMAP_REPLAY_ASAN
extern "C" const char* __asan_default_options() { return "max_allocation_size_mb=1024"; }
#endif
// The other sanitizers reserve terabytes of address space too: no limit under them.
#if defined(VDBMAP_REPLAY_ASAN) || defined(__SANITIZE_THREAD__)
#define VDBMAP_REPLAY_NO_RLIMIT 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
#define VDBMAP_REPLAY_NO_RLIMIT 1
#endif
#endif

int main(int argc, char** argv) {
#ifndef VDBMAP_REPLAY_NO_RLIMIT
  constexpr rlim_t kAddressSpaceBytes = rlim_t{2} << 30;
  const rlimit limit{kAddressSpaceBytes, kAddressSpaceBytes};
  if (setrlimit(RLIMIT_AS, &limit) != 0) std::printf("replay: cannot limit the address space, going on without\n");
#endif
  std::vector<std::filesystem::path> inputs;
  std::size_t open_skipped = 0;  // known crashers without a fix yet (an "open" folder)
  for (int a = 1; a < argc; ++a) {
    const std::filesystem::path arg = argv[a];
    std::error_code ec;
    if (std::filesystem::is_directory(arg, ec)) {
      for (auto it = std::filesystem::recursive_directory_iterator(arg, ec); it != std::filesystem::recursive_directory_iterator();
           it.increment(ec)) {
        if (it->is_directory() && it->path().filename() == "open") {
          for (const auto& known : std::filesystem::recursive_directory_iterator(it->path(), ec))
            if (known.is_regular_file()) ++open_skipped;
          it.disable_recursion_pending();
        } else if (it->is_regular_file() && it->path().filename().string().front() != '.') {
          inputs.push_back(it->path());
        }
      }
    } else if (std::filesystem::is_regular_file(arg, ec)) {
      inputs.push_back(arg);
    } else {
      std::printf("replay: %s does not exist, skipped\n", arg.c_str());
    }
  }
  std::sort(inputs.begin(), inputs.end());
  for (const std::filesystem::path& input : inputs) {
    std::printf("replay: %s\n", input.c_str());
    std::fflush(stdout);  // the name is out before a crash
    std::ifstream in(input, std::ios::binary);
    if (!in) {
      std::printf("replay: cannot open %s\n", input.c_str());
      return 1;
    }
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
  }
  std::printf("replay: %zu inputs, no crash", inputs.size());
  if (open_skipped > 0) std::printf(" (%zu open crashers not replayed)", open_skipped);
  std::printf("\n");
  return 0;
}
