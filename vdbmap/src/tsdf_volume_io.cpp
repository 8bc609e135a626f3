// Saving and loading TsdfVolume: the portable float map (.vdb) and the exact companion file.
#include "internal/vdb_file_check.hpp"

#include "vdbmap/atomic_file.hpp"
#include "vdbmap/file_error.hpp"
#include "vdbmap/tsdf_volume.hpp"

#include <nlohmann/json.hpp>

#include <openvdb/tools/Prune.h>
#include <openvdb/tree/LeafManager.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace vdbmap {
namespace {

/// 2: frame fingerprints by a faster hash (version 1 companions cannot de-integrate their frames).
/// 3: the companion also holds the hit counts (grid "hits"). Version 2 companions still load, with
///    no hits: de-integrating their frames then leaves negative counts, which read as no hits.
/// 4: the map and its companions carry the id of the save that wrote them ("vdbmap_unit_id").
constexpr int kFormatVersion = 4;
constexpr const char* kUnitIdKey = "vdbmap_unit_id";
/// The fields a companion must share with its map (beyond the unit id, which older files lack).
constexpr const char* kSharedFields[] = {
    "voxel_size_m", "truncation_vox", "weighting", "min_weight",       "occupancy_threshold_vox",
    "min_range_m",  "max_range_m",    "ray_mode",  "frames_integrated"};
constexpr int kOldestReadableVersion = 2;

openvdb::MetaMap configMetadata(const TsdfConfig& c, const IntegratorConfig& in, std::size_t frames) {
  openvdb::MetaMap meta;
  meta.insertMeta("vdbmap_format_version", openvdb::Int32Metadata(kFormatVersion));
  meta.insertMeta("voxel_size_m", openvdb::DoubleMetadata(c.voxel_size_m));
  meta.insertMeta("truncation_vox", openvdb::DoubleMetadata(c.truncation_vox));
  meta.insertMeta("truncation_m", openvdb::DoubleMetadata(c.truncation_m()));
  meta.insertMeta("weighting", openvdb::StringMetadata(toString(c.weighting)));
  meta.insertMeta("min_weight", openvdb::DoubleMetadata(c.min_weight));
  meta.insertMeta("occupancy_threshold_vox", openvdb::DoubleMetadata(c.occupancy_threshold_vox));
  meta.insertMeta("min_range_m", openvdb::DoubleMetadata(in.min_range_m));
  meta.insertMeta("max_range_m", openvdb::DoubleMetadata(in.max_range_m));
  meta.insertMeta("ray_mode", openvdb::StringMetadata(toString(in.ray_mode)));
  meta.insertMeta("frames_integrated", openvdb::Int64Metadata(openvdb::Int64(frames)));
  return meta;
}

template <typename MetaT, typename T>
T requireMeta(const openvdb::MetaMap& meta, const std::string& key, const std::filesystem::path& path) {
  const auto m = meta.getMetadata<MetaT>(key);
  if (!m) throw vdbmap::FileError(path.string() + ": metadata '" + key + "' is missing: not a vdbmap map?");
  return m->value();
}

void writeGrids(const std::filesystem::path& path, const openvdb::GridPtrVec& grids, const openvdb::MetaMap& meta,
                AtomicFileSet& files) {
  const std::filesystem::path tmp = files.add(path);
  try {
    openvdb::io::File file(tmp.string());
    file.setCompression(openvdb::io::COMPRESS_BLOSC | openvdb::io::COMPRESS_ACTIVE_MASK);
    file.write(grids, meta);
    file.close();
  } catch (const std::exception& e) {
    throw vdbmap::FileError("cannot write " + path.string() + ": " + e.what());
  }
}

std::string unitIdOf(const openvdb::MetaMap& meta) {
  const auto id = meta.getMetadata<openvdb::StringMetadata>(kUnitIdKey);
  return id ? id->value() : std::string();
}

}  // namespace

namespace detail {

// Declared where it is used (map_file.cpp) too; defined here beside kFormatVersion, its one source.
void checkMapFormatVersion(const openvdb::MetaMap& meta, const std::filesystem::path& path) {
  const openvdb::Metadata::ConstPtr any = meta["vdbmap_format_version"];
  if (!any) return;  // foreign OpenVDB files: the callers check the grids and fields they need
  const auto version = meta.getMetadata<openvdb::Int32Metadata>("vdbmap_format_version");
  if (!version)
    throw vdbmap::FileError(path.string() + ": metadata 'vdbmap_format_version' is a " + any->typeName() +
                            ", expected an int32");
  if (version->value() > kFormatVersion)
    throw vdbmap::FileError(path.string() + ": metadata 'vdbmap_format_version' is " +
                            std::to_string(version->value()) + ", newer than this build reads (newest supported: " +
                            std::to_string(kFormatVersion) + "); written by a newer vdbmap?");
}

std::int64_t checkExactCompanion(const openvdb::MetaMap& map_meta, const openvdb::MetaMap& exact_meta,
                                 const std::filesystem::path& map_path, const std::filesystem::path& exact_path) {
  const int version =
      requireMeta<openvdb::Int32Metadata, openvdb::Int32>(exact_meta, "vdbmap_format_version", exact_path);
  if (version < kOldestReadableVersion || version > kFormatVersion)
    throw vdbmap::FileError(exact_path.string() + ": exact state of format version " + std::to_string(version) +
                            ", this build reads versions " + std::to_string(kOldestReadableVersion) + " to " +
                            std::to_string(kFormatVersion) +
                            " (remove the .exact.vdb file to load the map approximately)");
  const std::string hint = ": a save was stopped between its files, or two programs wrote the same map (remove " +
                           exact_path.filename().string() + " to load the map approximately)";
  const std::string map_id = unitIdOf(map_meta), exact_id = unitIdOf(exact_meta);
  if (map_id != exact_id)
    throw vdbmap::FileError(exact_path.string() + " belongs to another save than " + map_path.string() + " (unit id " +
                            (exact_id.empty() ? "none" : exact_id) + ", the map's " +
                            (map_id.empty() ? "none" : map_id) + ")" + hint);
  for (const char* field : kSharedFields) {
    const openvdb::Metadata::ConstPtr a = map_meta[field], b = exact_meta[field];
    if (!a || !b || a->str() != b->str())
      throw vdbmap::FileError(exact_path.string() + ": '" + field + "' is " + (b ? b->str() : "missing") +
                              ", the map " + map_path.string() + " says " + (a ? a->str() : "nothing") + hint);
  }
  const std::int64_t sdf_scale =
      requireMeta<openvdb::Int64Metadata, openvdb::Int64>(exact_meta, "sdf_scale", exact_path);
  if (sdf_scale != kSdfScale)
    throw vdbmap::FileError(exact_path.string() + ": sdf_scale is " + std::to_string(sdf_scale) + ", this build's is " +
                            std::to_string(kSdfScale));
  // Each map keeps the weight scale it was made with (companions before the scale followed the
  // range all hold 1024).
  TsdfConfig scaled;
  scaled.weight_scale = requireMeta<openvdb::Int64Metadata, openvdb::Int64>(exact_meta, "weight_scale", exact_path);
  try {
    scaled.validate();
  } catch (const std::invalid_argument& e) {
    throw vdbmap::FileError(exact_path.string() + ": " + e.what());
  }
  return scaled.weight_scale;
}

}  // namespace detail

bool TsdfVolume::isExactStatePath(const std::filesystem::path& path) {
  const std::string name = path.filename().string();
  const std::string suffix = ".exact.vdb";
  return name.size() >= suffix.size() && name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string TsdfVolume::savedUnitId(const std::filesystem::path& path) {
  initializeOpenVdb();
  try {
    internal::checkVdbFileStructure(path);
    openvdb::io::File file(path.string());
    file.open(/*delayLoad=*/false);
    return unitIdOf(*file.getMetadata());
  } catch (const openvdb::Exception& e) {
    throw vdbmap::FileError("cannot read map " + path.string() + ": " + e.what());
  }
}

std::filesystem::path TsdfVolume::exactStatePath(const std::filesystem::path& path) {
  std::filesystem::path p = path;
  p.replace_extension();
  p += ".exact.vdb";
  return p;
}

void TsdfVolume::save(const std::filesystem::path& path) const {
  AtomicFileSet files;
  stageSave(path, files);
  files.commit();
}

void TsdfVolume::stageSave(const std::filesystem::path& path, AtomicFileSet& files) const {
  if (path.has_parent_path() && !std::filesystem::is_directory(path.parent_path()))
    throw vdbmap::FileError("cannot write " + path.string() + ": folder " + path.parent_path().string() +
                            " does not exist");
  if (std::error_code ec; std::filesystem::is_directory(path, ec))
    throw vdbmap::FileError("cannot write " + path.string() + ": it is a folder (give a file name)");
  if (isExactStatePath(path))
    throw vdbmap::FileError("cannot write map " + path.string() +
                            ": a name ending in .exact.vdb is the name of a map's exact companion; choose another");
  openvdb::MetaMap meta = configMetadata(config_, integrator_, frames_.size());
  meta.insertMeta(kUnitIdKey, openvdb::StringMetadata(files.unitId()));

  // The companion is renamed before the map: a stop in between leaves a map and a companion of
  // different saves, which load() refuses by their unit ids.
  if (exact_state_) {
    nlohmann::json registry = nlohmann::json::array();
    for (const auto& [id, rec] : frames_) {
      const auto& m = rec.T_W_S.matrix();
      registry.push_back({{"id", id},
                          {"fingerprint", std::to_string(rec.fingerprint)},
                          {"T_W_S", std::vector<double>(m.data(), m.data() + 16)}});
    }
    openvdb::MetaMap exact_meta = meta;
    exact_meta.insertMeta("frames_json", openvdb::StringMetadata(registry.dump()));
    exact_meta.insertMeta("weight_scale", openvdb::Int64Metadata(config_.weight_scale));
    exact_meta.insertMeta("sdf_scale", openvdb::Int64Metadata(kSdfScale));
    writeGrids(exactStatePath(path), {weight_q_->deepCopyGrid(), wsdf_q_->deepCopyGrid(), hits_->deepCopyGrid()},
               exact_meta, files);
  }

  openvdb::FloatGrid::Ptr tsdf = tsdfGrid();
  openvdb::FloatGrid::Ptr weight = weightGrid();
  for (auto it = meta.beginMeta(); it != meta.endMeta(); ++it) {
    tsdf->insertMeta(it->first, *it->second);
    weight->insertMeta(it->first, *it->second);
  }
  writeGrids(path, {tsdf, weight}, meta, files);
}

TsdfVolume TsdfVolume::fromWeightedSums(const TsdfConfig& config, const IntegratorConfig& integrator,
                                        const openvdb::FloatGrid& weight, const openvdb::FloatGrid& weighted_tsdf) {
  TsdfVolume volume(config, integrator);
  auto wacc = volume.weight_q_->getAccessor();
  auto wdacc = volume.wsdf_q_->getAccessor();
  const double delta = config.truncation_m();
  const double scale = double(volume.config_.weight_scale);
  // W at most 2^40 units (2^30 rays of weight 1 at the smallest scale: far above what rays give),
  // so that W * kSdfScale stays at 2^55 and the sums of later frames cannot overflow 64 bits.
  const int max_weight_log2 = 40 - int(std::lround(std::log2(scale)));
  const double max_weight = std::ldexp(1.0, max_weight_log2);
  for (auto it = weight.cbeginValueOn(); it; ++it) {
    const double w = double(*it), w_sdf = double(weighted_tsdf.tree().getValue(it.getCoord()));
    if (!std::isfinite(w) || w > max_weight || !std::isfinite(w_sdf)) {
      std::ostringstream msg;  // the stream's precision: 1e+38, not 39 digits
      msg << "voxel " << it.getCoord() << " has weight " << w << " and weighted tsdf " << w_sdf
          << ": weights must be finite and at most 2^" << max_weight_log2 << ", sums finite";
      throw std::invalid_argument(msg.str());
    }
    const std::int64_t wq = std::llround(w * scale);
    if (wq <= 0) continue;
    const double sdf = std::clamp(w_sdf / w, -delta, delta);
    wacc.setValue(it.getCoord(), wq);
    wdacc.setValue(it.getCoord(), wq * std::llround(sdf / delta * kSdfScale));
  }
  volume.exact_state_ = false;
  return volume;
}

TsdfVolume TsdfVolume::load(const std::filesystem::path& path) {
  initializeOpenVdb();
  if (!std::filesystem::is_regular_file(path))
    throw vdbmap::FileError("cannot open map " + path.string() + ": no such file");
  try {
    internal::checkVdbFileStructure(path);
    openvdb::io::File file(path.string());
    file.open(/*delayLoad=*/false);
    const openvdb::MetaMap::Ptr meta = file.getMetadata();
    detail::checkMapFormatVersion(*meta, path);
    TsdfConfig c;
    IntegratorConfig in;
    try {  // settings out of range in a file are damage, not misuse
      c.voxel_size_m = requireMeta<openvdb::DoubleMetadata, double>(*meta, "voxel_size_m", path);
      c.truncation_vox = requireMeta<openvdb::DoubleMetadata, double>(*meta, "truncation_vox", path);
      c.weighting = parseWeighting(requireMeta<openvdb::StringMetadata, std::string>(*meta, "weighting", path));
      c.min_weight = requireMeta<openvdb::DoubleMetadata, double>(*meta, "min_weight", path);
      c.occupancy_threshold_vox = requireMeta<openvdb::DoubleMetadata, double>(*meta, "occupancy_threshold_vox", path);
      in.min_range_m = requireMeta<openvdb::DoubleMetadata, double>(*meta, "min_range_m", path);
      in.max_range_m = requireMeta<openvdb::DoubleMetadata, double>(*meta, "max_range_m", path);
      in.ray_mode = parseRayMode(requireMeta<openvdb::StringMetadata, std::string>(*meta, "ray_mode", path));
      c.validate();
      in.validate();
    } catch (const std::invalid_argument& e) {
      throw vdbmap::FileError(path.string() + ": bad map settings: " + e.what());
    }
    TsdfVolume volume(c, in);

    const std::filesystem::path exact = exactStatePath(path);
    if (std::filesystem::is_regular_file(exact)) {
      // Errors from here on name the companion, the file they are in.
      const auto readExactState = [&] {
        internal::checkVdbFileStructure(exact);
        openvdb::io::File ef(exact.string());
        ef.open(/*delayLoad=*/false);
        const openvdb::MetaMap::Ptr emeta = ef.getMetadata();
        volume.config_.weight_scale = detail::checkExactCompanion(*meta, *emeta, path, exact);
        const int version = requireMeta<openvdb::Int32Metadata, openvdb::Int32>(*emeta, "vdbmap_format_version", exact);
        auto w = openvdb::gridPtrCast<openvdb::Int64Grid>(ef.readGrid("weight_q"));
        auto wd = openvdb::gridPtrCast<openvdb::Int64Grid>(ef.readGrid("wsdf_q"));
        if (!w || !wd) throw vdbmap::FileError(exact.string() + ": grids weight_q / wsdf_q missing or not Int64");
        volume.weight_q_->setTree(w->treePtr());
        volume.wsdf_q_->setTree(wd->treePtr());
        if (version >= 3) {
          auto hits = openvdb::gridPtrCast<openvdb::Int64Grid>(ef.readGrid("hits"));
          if (!hits) throw vdbmap::FileError(exact.string() + ": grid hits is not Int64");
          volume.hits_->setTree(hits->treePtr());
        }
        // Maps written here hold no inactive node; a file from elsewhere may. Integration prunes
        // only the branches it empties (internal/prune_leaves.hpp), so the rest is pruned here.
        openvdb::tools::pruneInactive(volume.weight_q_->tree());
        openvdb::tools::pruneInactive(volume.wsdf_q_->tree());
        openvdb::tools::pruneInactive(volume.hits_->tree());
        const auto registry =
            nlohmann::json::parse(requireMeta<openvdb::StringMetadata, std::string>(*emeta, "frames_json", exact));
        for (const auto& f : registry) {
          FrameRecord rec;
          rec.fingerprint = std::stoull(f.at("fingerprint").get<std::string>());
          const auto m = f.at("T_W_S").get<std::vector<double>>();
          if (m.size() != 16) throw vdbmap::FileError(exact.string() + ": frame pose must have 16 numbers");
          std::copy(m.begin(), m.end(), rec.T_W_S.matrix().data());
          volume.frames_[f.at("id").get<FrameId>()] = rec;
        }
      };
      try {
        readExactState();
      } catch (const openvdb::Exception& e) {
        throw vdbmap::FileError("cannot read exact state " + exact.string() + ": " + e.what());
      } catch (const nlohmann::json::exception& e) {
        throw vdbmap::FileError("cannot read exact state " + exact.string() + ": bad frame registry: " + e.what());
      } catch (const std::logic_error& e) {  // std::stoull of a fingerprint
        throw vdbmap::FileError("cannot read exact state " + exact.string() + ": bad frame registry: " + e.what());
      }
      return volume;
    }

    // No companion: rebuild an approximate integer state from the float grids.
    auto tsdf = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("tsdf"));
    auto weight = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("weight"));
    if (!tsdf || !weight) throw vdbmap::FileError(path.string() + ": grids tsdf / weight missing or not float");
    auto weighted = weight->deepCopy();
    for (auto it = weighted->beginValueOn(); it; ++it) it.setValue(*it * tsdf->tree().getValue(it.getCoord()));
    try {
      return fromWeightedSums(c, in, *weight, *weighted);
    } catch (const std::invalid_argument& e) {
      throw vdbmap::FileError(path.string() + ": " + e.what());
    }
  } catch (const openvdb::Exception& e) {
    throw vdbmap::FileError("cannot read map " + path.string() + ": " + e.what());
  } catch (const nlohmann::json::exception& e) {
    throw vdbmap::FileError("cannot read map " + path.string() + ": bad frame registry: " + e.what());
  }
}

}  // namespace vdbmap
