// `vdbmap atsp`: solves a TSPLIB file and writes {name, n, cost, optimal_proven, time_s}; a bad
// file fails naming the file and line.
#include "common/shared_data.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;

namespace {
const std::filesystem::path kTsplib = vdbmap::test::sharedDataDir() / "tsplib_atsp";

int runCli(const std::string& args, const fs::path& out_file) {
  const std::string cmd = std::string(VDBMAP_CLI_PATH) + " " + args + " > " + out_file.string() + " 2>&1";
  return std::system(cmd.c_str());
}

std::string readAll(const fs::path& p) {
  std::ifstream in(p);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}
}  // namespace

TEST_CASE("vdbmap atsp solves br17 and writes the JSON summary", "[cli][atsp]") {
  vdbmap::test::requireSharedData("tsplib_atsp/br17.atsp");
  const fs::path dir = fs::temp_directory_path() / "vdbmap_cli_atsp";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path log = dir / "log.txt", json = dir / "br17.json";
  // Limits far above what the solver takes (the DP about 0.1 s, 200 rounds a few ms), so that a
  // loaded machine cuts neither short.
  REQUIRE(runCli("atsp " + (kTsplib / "br17.atsp").string() + " --time-limit-s 30 --seed 3 --exact-max-n 17 --json " +
                     json.string(),
                 log) == 0);
  CHECK(readAll(log).find("br17: n 17, cost 39") != std::string::npos);
  const auto j = nlohmann::json::parse(readAll(json));
  CHECK(j.at("name") == "br17");
  CHECK(j.at("n") == 17);
  CHECK(j.at("cost") == 39);
  CHECK(j.at("optimal_proven") == true);  // the DP at n = 17
  CHECK(j.at("time_s").get<double>() > 0.0);
  CHECK(j.at("order").size() == 17);

  // An open path from node 5 is never dearer than the best closed tour.
  REQUIRE(runCli("atsp " + (kTsplib / "br17.atsp").string() +
                     " --time-limit-s 30 --max-iterations 200 --open-from 5 --json -",
                 log) == 0);
  const auto open = nlohmann::json::parse(readAll(log));
  CHECK(open.at("order")[0] == 5);
  CHECK(open.at("cost").get<int>() <= 39);

  std::ofstream(dir / "bad.atsp") << "NAME: bad\nTYPE: ATSP\nDIMENSION: 2\nEDGE_WEIGHT_TYPE: EXPLICIT\n"
                                     "EDGE_WEIGHT_FORMAT: FULL_MATRIX\nEDGE_WEIGHT_SECTION\n0 1\n2 zero\n";
  CHECK(runCli("atsp " + (dir / "bad.atsp").string(), log) != 0);
  CHECK(readAll(log).find("bad.atsp:8") != std::string::npos);
}
