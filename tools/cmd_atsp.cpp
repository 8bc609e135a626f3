// `vdbmap atsp FILE.atsp [--time-limit-s S] [--seed N] [--json OUT.json]`: solves a TSPLIB
// full-matrix instance with the planner's ATSP solver and prints {name, n, cost, optimal_proven, time_s}.
#include "cli_util.hpp"
#include "command.hpp"

#include "vdbmap/planner/atsp.hpp"
#include "vdbmap/planner/tsplib.hpp"

#include <cstdio>
#include <iostream>
#include <memory>

namespace vdbmap::cli {
namespace {

struct AtspArgs {
  std::filesystem::path file;
  planner::AtspConfig options;
  std::size_t open_from = 0;
  std::string json;
};

nlohmann::json toJson(const planner::TsplibInstance& instance, const AtspArgs& args, const planner::AtspResult& r) {
  nlohmann::json j = {{"name", instance.name},
                      {"n", instance.costs.size()},
                      {"cost", r.cost},
                      {"optimal_proven", r.optimal_proven},
                      {"time_s", r.time_s},
                      {"status", planner::toString(r.status)},
                      {"time_to_best_s", r.time_to_best_s},
                      {"iterations", r.iterations},
                      {"seed", args.options.seed},
                      {"time_limit_s", args.options.time_limit_s},
                      {"order", r.order}};
  j["lower_bound"] =
      r.lower_bound == std::numeric_limits<std::int64_t>::min() ? nlohmann::json() : nlohmann::json(r.lower_bound);
  if (args.options.open_from) j["open_from"] = *args.options.open_from;
  return j;
}

const Registration registration("atsp", [](CLI::App& app) {
  auto args = std::make_shared<AtspArgs>();
  CLI::App* sub = app.add_subcommand("atsp", "Solve an asymmetric TSP instance (TSPLIB FULL_MATRIX file)");
  sub->add_option("file", args->file, "TSPLIB .atsp file")->required()->check(CLI::ExistingFile);
  sub->add_option("--time-limit-s", args->options.time_limit_s, "Time limit in seconds")->capture_default_str();
  sub->add_option("--seed", args->options.seed, "Seed of the local search")->capture_default_str();
  sub->add_option("--open-from", args->open_from, "Solve an open path from this node (no return) instead of a tour");
  sub->add_option("--exact-max-n", args->options.exact_max_n, "Largest n solved exactly by dynamic programming")
      ->capture_default_str();
  sub->add_option("--max-iterations", args->options.max_iterations,
                  "Stop after this many local-search rounds (0 = only the time limit)")
      ->capture_default_str();
  sub->add_option("--max-stale-iterations", args->options.max_stale_iterations,
                  "Stop after this many rounds in a row without a cheaper tour (0 = never)")
      ->capture_default_str();
  sub->add_option("--json", args->json, "Write the result as JSON to this file ('-' = standard output)")
      ->expected(0, 1)
      ->default_str("-");
  sub->callback([args, sub] {
    const planner::TsplibInstance instance = planner::readTsplib(args->file);
    if (sub->count("--open-from")) args->options.open_from = args->open_from;
    const planner::AtspResult result = planner::solveAtsp(instance.costs, args->options);
    if (sub->count("--json")) {
      const nlohmann::json j = toJson(instance, *args, result);
      if (args->json.empty() || args->json == "-") {
        std::cout << j.dump(2) << "\n";
        return;
      }
      writeJson(args->json, j);
    }
    std::printf("%s: n %zu, cost %lld, %s (%s), %.3f s (best found at %.3f s, %llu rounds)\n", instance.name.c_str(),
                instance.costs.size(), static_cast<long long>(result.cost),
                result.optimal_proven ? "optimal" : "not proven optimal", planner::toString(result.status).c_str(),
                result.time_s, result.time_to_best_s, static_cast<unsigned long long>(result.iterations));
  });
});

}  // namespace
}  // namespace vdbmap::cli
