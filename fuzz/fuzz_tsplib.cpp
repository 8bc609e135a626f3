// Fuzz target: TSPLIB instances (planner/tsplib.hpp, parseTsplib) from a seekable stream and from
// one that cannot seek (as a pipe), which the parser buffers to learn its length.
#include "fuzz_support.hpp"

#include "vdbmap/planner/tsplib.hpp"

#include <sstream>
#include <streambuf>
#include <string>

namespace {

// A read-only stream buffer over memory that refuses to seek, like a pipe's.
class NoSeekBuf : public std::streambuf {
 public:
  NoSeekBuf(const char* data, std::size_t size) {
    char* p = const_cast<char*>(data);  // get area only: never written through
    setg(p, p, p + size);
  }

 protected:
  pos_type seekoff(off_type, std::ios_base::seekdir, std::ios_base::openmode) override { return pos_type(off_type(-1)); }
  pos_type seekpos(pos_type, std::ios_base::openmode) override { return pos_type(off_type(-1)); }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace vdbmap;
  const std::string text(reinterpret_cast<const char*>(data), size);
  fuzz::expectRefusalOrSuccess([&] {
    std::istringstream in(text);
    const planner::TsplibInstance instance = planner::parseTsplib(in, "fuzz.atsp");
    if (instance.costs.values().size() != instance.costs.size() * instance.costs.size()) std::abort();
  });
  fuzz::expectRefusalOrSuccess([&] {
    NoSeekBuf buf(text.data(), text.size());
    std::istream in(&buf);
    planner::parseTsplib(in, "fuzz-pipe.atsp");
  });
  return 0;
}
