// `vdbmap info MAP.vdb|RUN.bag [--json]`: a map's grids, voxel counts, bounds, metadata, memory; or a
// ROS bag's topics, types, message counts and time span.
#include "cli_util.hpp"
#include "command.hpp"

#include "vdbmap/io/ros_bag.hpp"
#include "vdbmap/map_file.hpp"

#include <cstdio>
#include <iostream>

namespace vdbmap::cli {
namespace {

nlohmann::json toJson(const MapFileInfo& info) {
  nlohmann::json grids = nlohmann::json::array();
  for (const MapFileGrid& g : info.grids) {
    nlohmann::json j = {{"name", g.name},          {"type", g.type},
                        {"class", g.grid_class},   {"active_voxels", g.active_voxels},
                        {"leaf_nodes", g.leaf_nodes}, {"memory_bytes", g.memory_bytes},
                        {"voxel_size_m", g.voxel_size_m}};
    if (!g.bbox_index.empty()) {
      j["bbox_min_m"] = {g.bbox_min_m[0], g.bbox_min_m[1], g.bbox_min_m[2]};
      j["bbox_max_m"] = {g.bbox_max_m[0], g.bbox_max_m[1], g.bbox_max_m[2]};
    }
    grids.push_back(j);
  }
  nlohmann::json meta = nlohmann::json::object();
  for (const auto& [k, v] : info.metadata) meta[k] = v;
  nlohmann::json j = {{"path", info.path.string()}, {"file_bytes", info.file_bytes},
                      {"has_exact_state", info.has_exact_state}, {"unit_id", info.unit_id},
                      {"grids", grids}, {"metadata", meta}};
  if (!info.exact_state_problem.empty()) j["exact_state_problem"] = info.exact_state_problem;
  if (info.has_exact_state) j["weight_scale"] = info.weight_scale;
  return j;
}

const Registration registration("info", [](CLI::App& app) {
  auto map = std::make_shared<std::filesystem::path>();
  auto json = std::make_shared<std::string>();
  CLI::App* sub = app.add_subcommand(
      "info", "Describe a map (.vdb: grids, voxel counts, bounds, metadata, memory) or a ROS bag (.bag: topics, "
              "types, message counts, time span)");
  sub->add_option("map", *map, "Map file (.vdb) or ROS bag (.bag)")->required()->check(CLI::ExistingFile);
  sub->add_option("--json", *json, "Write the description as JSON to this file ('-' = standard output)")
      ->expected(0, 1)->default_str("-");
  sub->callback([map, json, sub] {
    if (map->extension() == ".bag") {
      const io::RosBagInfo bag = io::inspectRosBag(*map);
      nlohmann::json topics = nlohmann::json::array();
      for (const io::RosBagTopic& t : bag.topics)
        topics.push_back({{"topic", t.name}, {"type", t.type}, {"messages", t.messages}, {"first_s", t.first_s}, {"last_s", t.last_s}});
      const nlohmann::json j = {{"path", map->string()}, {"messages", bag.messages}, {"start_s", bag.start_s},
                                {"end_s", bag.end_s}, {"topics", topics}};
      if (sub->count("--json")) {
        if (json->empty() || *json == "-") std::cout << j.dump(2) << "\n";
        else writeJson(*json, j);
        return;
      }
      std::printf("%s: %zu messages, %.3f s from %.3f to %.3f\n", map->c_str(), bag.messages, bag.end_s - bag.start_s,
                  bag.start_s, bag.end_s);
      for (const io::RosBagTopic& t : bag.topics)
        std::printf("  %-32s %-32s %7zu messages, %.3f to %.3f\n", t.name.c_str(), t.type.c_str(), t.messages, t.first_s,
                    t.last_s);
      return;
    }
    const MapFileInfo info = inspectMapFile(*map);
    if (sub->count("--json")) {
      const nlohmann::json j = toJson(info);
      if (json->empty() || *json == "-")
        std::cout << j.dump(2) << "\n";
      else
        writeJson(*json, j);
      return;
    }
    const std::string exact = info.has_exact_state ? "present (weight scale " + std::to_string(info.weight_scale) + ")"
                              : info.exact_state_problem.empty() ? "absent"
                                                                 : "unusable: " + info.exact_state_problem;
    std::printf("%s: %.1f MB, exact state %s\n", map->c_str(), info.file_bytes / 1e6, exact.c_str());
    for (const MapFileGrid& g : info.grids) {
      std::printf("  grid %-8s %-6s %-10s %10zu active voxels, %.1f MB in memory, voxel %.3f m", g.name.c_str(),
                  g.type.c_str(), g.grid_class.c_str(), g.active_voxels, g.memory_bytes / 1e6, g.voxel_size_m);
      if (!g.bbox_index.empty())
        std::printf(", bounds [%.2f %.2f %.2f] .. [%.2f %.2f %.2f] m", g.bbox_min_m[0], g.bbox_min_m[1], g.bbox_min_m[2],
                    g.bbox_max_m[0], g.bbox_max_m[1], g.bbox_max_m[2]);
      std::printf("\n");
    }
    for (const auto& [k, v] : info.metadata) std::printf("  %s = %s\n", k.c_str(), v.c_str());
  });
});

}  // namespace
}  // namespace vdbmap::cli
