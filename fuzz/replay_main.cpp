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

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

int main(int argc, char** argv) {
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
