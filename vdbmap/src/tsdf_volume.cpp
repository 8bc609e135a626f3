#include "vdbmap/tsdf_volume.hpp"

#include "internal/hit_counter.hpp"
#include "internal/projective_integrator.hpp"
#include "internal/ray_integrator.hpp"

#include <openvdb/tools/Prune.h>
#include <openvdb/tree/LeafManager.h>

#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

namespace vdbmap {

TsdfVolume::TsdfVolume(const TsdfConfig& config, const IntegratorConfig& integrator)
    : config_(config), integrator_(integrator) {
  config_.validate();
  integrator_.validate();
  config_.weight_scale = weightScaleFor(config_, integrator_);
  initializeOpenVdb();
  transform_ = openvdb::math::Transform::createLinearTransform(config_.voxel_size_m);
  weight_q_ = Int64GridT::create(0);
  weight_q_->setTransform(transform_);
  weight_q_->setName("weight_q");
  wsdf_q_ = Int64GridT::create(0);
  wsdf_q_->setTransform(transform_);
  wsdf_q_->setName("wsdf_q");
  hits_ = Int64GridT::create(0);
  hits_->setTransform(transform_);
  hits_->setName("hits");
}

TsdfVolume::TsdfVolume(const TsdfVolume& other)
    : config_(other.config_),
      integrator_(other.integrator_),
      transform_(other.transform_->copy()),
      weight_q_(other.weight_q_->deepCopy()),
      wsdf_q_(other.wsdf_q_->deepCopy()),
      hits_(other.hits_->deepCopy()),
      frames_(other.frames_),
      exact_state_(other.exact_state_) {
  weight_q_->setTransform(transform_);
  wsdf_q_->setTransform(transform_);
  hits_->setTransform(transform_);
}

TsdfVolume& TsdfVolume::operator=(const TsdfVolume& other) {
  if (this != &other) *this = TsdfVolume(other);
  return *this;
}

void TsdfVolume::setThreads(int threads) {
  IntegratorConfig c = integrator_;
  c.threads = threads;
  c.validate();
  integrator_ = c;
}

namespace {
/// A 64-bit hash of raw bytes: four independent multiply-rotate lanes over 8-byte words (about
/// 1 ns per point), chained onto `seed`. Equal inputs give equal hashes; a different byte changes
/// it with overwhelming probability.
constexpr std::uint64_t kP1 = 0x9e3779b185ebca87ULL, kP2 = 0xc2b2ae3d27d4eb4fULL;
inline std::uint64_t hashRound(std::uint64_t acc, std::uint64_t w) {
  acc += w * kP2;
  acc = (acc << 31) | (acc >> 33);
  return acc * kP1;
}
std::uint64_t hashBytes(std::uint64_t seed, const void* data, std::size_t n) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  std::uint64_t lane[4] = {seed + kP1 + kP2, seed + kP2, seed, seed - kP1};
  std::size_t i = 0;
  for (; i + 32 <= n; i += 32) {
    std::uint64_t w[4];
    std::memcpy(w, bytes + i, 32);
    for (int k = 0; k < 4; ++k) lane[k] = hashRound(lane[k], w[k]);
  }
  std::uint64_t h = (lane[0] << 1 | lane[0] >> 63) + (lane[1] << 7 | lane[1] >> 57) + (lane[2] << 12 | lane[2] >> 52) +
                    (lane[3] << 18 | lane[3] >> 46) + n;
  for (; i + 8 <= n; i += 8) {
    std::uint64_t w;
    std::memcpy(&w, bytes + i, 8);
    h = hashRound(h, w);
  }
  std::uint64_t tail = 0;
  std::memcpy(&tail, bytes + i, n - i);
  return hashRound(h, tail);
}
std::uint64_t finish(std::uint64_t h) {  // splitmix64's finaliser
  h ^= h >> 30;
  h *= 0xbf58476d1ce4e5b9ULL;
  h ^= h >> 27;
  h *= 0x94d049bb133111ebULL;
  h ^= h >> 31;
  return h;
}

// A frame's fingerprint is the hash of its data chained with its pose: the data's hash once, then
// one fingerprint per pose (a re-integration checks the old pose and records the new).
std::uint64_t dataHash(const PointCloud& points_S) {
  return hashBytes(0x706f696e7473ULL, points_S.data(), points_S.size() * sizeof(Vec3f));
}
std::uint64_t dataHash(const DepthImage& depth_m, const CameraIntrinsics& K) {
  const std::uint64_t h = hashBytes(0x6465707468ULL, depth_m.depth_m.data(), depth_m.depth_m.size() * sizeof(float));
  const double k[6] = {double(K.width), double(K.height), K.fx, K.fy, K.cx, K.cy};
  return hashBytes(h, k, sizeof(k));
}
std::uint64_t fingerprint(std::uint64_t data_hash, const Pose3d& T_W_S) {
  return finish(hashBytes(data_hash, T_W_S.matrix().data(), 16 * sizeof(double)));
}
}  // namespace

namespace {
/// Runs `work` in an arena of `threads` workers (0 = TBB's default).
template <typename Fn>
void inArena(int threads, Fn&& work) {
  if (threads > 0) {
    tbb::task_arena arena(threads);
    arena.execute(work);
  } else {
    work();
  }
}
}  // namespace

IntegrationStats TsdfVolume::apply(const PointCloud& points_S, const Pose3d& T_W_S, std::int64_t sign) {
  IntegrationStats stats;
  inArena(integrator_.threads, [&] {
    const std::vector<internal::RayBundle> bundles =
        internal::bundleRays(points_S, T_W_S, config_, integrator_, stats);
    internal::castRays(bundles, T_W_S.translation(), config_, *weight_q_, *wsdf_q_, sign, stats);
    internal::countHits(points_S, T_W_S, config_, integrator_, *hits_, sign);
  });
  return stats;
}

IntegrationStats TsdfVolume::apply(const DepthImage& depth_m, const CameraIntrinsics& K, const Pose3d& T_W_S,
                                   std::int64_t sign, VoxelFootprint* footprint) {
  if (footprint) footprint->clear();
  if (integrator_.ray_mode != RayMode::Projective) return apply(backProject(depth_m, K), T_W_S, sign);
  IntegrationStats stats;
  inArena(integrator_.threads, [&] {
    internal::integrateProjective(depth_m, K, {{T_W_S, sign}}, config_, integrator_, *weight_q_, *wsdf_q_, hits_.get(),
                                  stats, footprint);
  });
  return stats;
}

void TsdfVolume::checkPose(FrameId id, const Pose3d& T_W_S, const char* what) const {
  if (!isValidRigidTransform(T_W_S))
    throw FrameError("frame " + std::to_string(id) + ": " + what + " is not a rigid transform (NaN or non-orthonormal rotation)");
  // Voxel coordinates are 32-bit: the sensor and everything within max range of it must stay far
  // inside them, or a ray's walk overflows (and a huge translation would mean unbounded work).
  const double reach_vox = (T_W_S.translation().cwiseAbs().maxCoeff() + integrator_.max_range_m) / config_.voxel_size_m;
  if (T_W_S.translation().cwiseAbs().maxCoeff() > kMaxAbsPosition_m || reach_vox > double(1 << 30)) {
    std::ostringstream msg;
    msg << "frame " << id << ": " << what << " translation (" << T_W_S.translation().transpose()
        << ") m is outside the map's range (|x|, |y|, |z| <= " << kMaxAbsPosition_m << " m, and within 2^30 voxels)";
    throw FrameError(msg.str());
  }
}

void TsdfVolume::checkNewFrame(FrameId id, const Pose3d& T_W_S) const {
  if (frames_.count(id)) throw FrameError("frame " + std::to_string(id) + " is already integrated");
  checkPose(id, T_W_S, "T_W_S");
}

std::map<FrameId, TsdfVolume::FrameRecord>::iterator TsdfVolume::checkKnownFrame(FrameId id, std::uint64_t fingerprint,
                                                                                 const char* what) {
  const auto it = frames_.find(id);
  if (it == frames_.end())
    throw FrameError("frame " + std::to_string(id) + " cannot be de-integrated: it was never integrated");
  if (it->second.fingerprint != fingerprint)
    throw FrameError("frame " + std::to_string(id) + " cannot be de-integrated: its " + what +
                     " or pose differ from those it was integrated with");
  return it;
}

namespace {

/// Bytes of one leaf (8^3 voxels) in each of the three Int64 grids, values and masks.
constexpr double kLeafBytes = 3.0 * (512.0 * 8.0 + 3.0 * 64.0);
/// Frames whose bound with the configured max range stays below this are not examined further.
constexpr double kQuickBoundBytes = 256.0 * (1 << 20);

/// MemAvailable of /proc/meminfo in bytes, or +inf where it cannot be read.
double availableMemoryBytes() {
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  while (meminfo >> key) {
    if (key == "MemAvailable:") {
      double kib = 0.0;
      meminfo >> kib;
      return kib * 1024.0;
    }
    meminfo.ignore(1 << 12, '\n');
  }
  return std::numeric_limits<double>::infinity();
}

/// An upper estimate of the map memory one frame can add: a ray of length l crosses at most
/// sqrt(3) l / L + 3 leaves of side L, and the rays together no more leaves than their view
/// volume (dilated by two leaves) holds.
double frameBytesBound(double rays, double reach_m, double view_volume_m3, double voxel_m) {
  const double leaf_m = 8.0 * voxel_m;
  const double along_rays = rays * (std::sqrt(3.0) * reach_m / leaf_m + 3.0);
  const double in_view = view_volume_m3 / (leaf_m * leaf_m * leaf_m);
  return std::min(along_rays, in_view) * kLeafBytes;
}

/// Throws FrameError naming the frame and the estimate when it exceeds the available memory.
void checkFrameFits(FrameId id, double estimate_bytes, double rays, double reach_m, double voxel_m) {
  if (estimate_bytes <= kQuickBoundBytes) return;
  const double available = availableMemoryBytes();
  if (estimate_bytes <= available) return;
  std::ostringstream msg;
  msg.precision(3);
  msg << "frame " << id << ": integrating it could take about " << estimate_bytes / 1e9 << " GB of map memory ("
      << rays << " rays up to " << reach_m << " m through voxels of " << voxel_m << " m), more than the "
      << available / 1e9 << " GB available; use a larger voxel size or a shorter max range";
  throw FrameError(msg.str());
}

/// The pinhole's view pyramid to depth r, dilated by two leaves (its volume, m^3).
double pyramidVolume(const CameraIntrinsics& K, double r, double leaf_m) {
  const double rr = r + 2.0 * leaf_m;
  return (K.width / std::abs(K.fx) * rr + 4.0 * leaf_m) * (K.height / std::abs(K.fy) * rr + 4.0 * leaf_m) * rr / 3.0;
}

}  // namespace

void TsdfVolume::checkFrameMemory(FrameId id, const PointCloud& points_S) const {
  const double v = config_.voxel_size_m, reach = integrator_.max_range_m + config_.truncation_m();
  const double rays = double(points_S.size());
  auto sphere = [v](double r) { return 4.0 / 3.0 * M_PI * std::pow(r + 16.0 * v, 3.0); };
  if (frameBytesBound(rays, reach, sphere(reach), v) <= kQuickBoundBytes) return;
  double far = 0.0;  // the farthest point within range: what this frame really reaches
  for (const Vec3f& p : points_S)
    if (p.allFinite()) far = std::max(far, std::min(double(p.norm()), integrator_.max_range_m));
  far += config_.truncation_m();
  checkFrameFits(id, frameBytesBound(rays, far, sphere(far), v), rays, far, v);
}

void TsdfVolume::checkFrameMemory(FrameId id, const DepthImage& depth_m, const CameraIntrinsics& K) const {
  const double v = config_.voxel_size_m, reach = integrator_.max_range_m + config_.truncation_m();
  const double rays = double(depth_m.depth_m.size());
  if (frameBytesBound(rays, reach, pyramidVolume(K, reach, 8.0 * v), v) <= kQuickBoundBytes) return;
  double far = 0.0;
  for (float d : depth_m.depth_m)
    if (std::isfinite(d) && d > 0.0f) far = std::max(far, std::min(double(d), integrator_.max_range_m));
  // A pixel's ray is longer than its depth off the optical axis: bounded by the image corners.
  const double corner = std::hypot(K.width / std::abs(K.fx), K.height / std::abs(K.fy));
  far = far * std::sqrt(1.0 + corner * corner) + config_.truncation_m();
  checkFrameFits(id, frameBytesBound(rays, far, pyramidVolume(K, far, 8.0 * v), v), rays, far, v);
}

IntegrationStats TsdfVolume::integrate(FrameId id, const PointCloud& points_S, const Pose3d& T_W_S) {
  checkNewFrame(id, T_W_S);
  checkFrameMemory(id, points_S);
  IntegrationStats stats = apply(points_S, T_W_S, +1);
  frames_[id] = FrameRecord{fingerprint(dataHash(points_S), T_W_S), T_W_S};
  return stats;
}

IntegrationStats TsdfVolume::deintegrate(FrameId id, const PointCloud& points_S, const Pose3d& T_W_S) {
  const auto it = checkKnownFrame(id, fingerprint(dataHash(points_S), T_W_S), "points");
  IntegrationStats stats = apply(points_S, T_W_S, -1);
  frames_.erase(it);
  return stats;
}

IntegrationStats TsdfVolume::integrate(FrameId id, const DepthImage& depth_m, const CameraIntrinsics& K,
                                       const Pose3d& T_W_S, VoxelFootprint* footprint) {
  checkNewFrame(id, T_W_S);
  checkFrameMemory(id, depth_m, K);
  IntegrationStats stats = apply(depth_m, K, T_W_S, +1, footprint);
  frames_[id] = FrameRecord{fingerprint(dataHash(depth_m, K), T_W_S), T_W_S};
  return stats;
}

IntegrationStats TsdfVolume::deintegrate(FrameId id, const DepthImage& depth_m, const CameraIntrinsics& K,
                                         const Pose3d& T_W_S) {
  const auto it = checkKnownFrame(id, fingerprint(dataHash(depth_m, K), T_W_S), "depth image, intrinsics");
  IntegrationStats stats = apply(depth_m, K, T_W_S, -1);
  frames_.erase(it);
  return stats;
}

IntegrationStats TsdfVolume::integrate(FrameId id, const SensorFrame& frame, const Pose3d& T_W_S,
                                       VoxelFootprint* footprint) {
  if (!frame.isDepth()) {
    if (footprint) footprint->clear();
    return integrate(id, frame.points_S(), T_W_S);
  }
  return integrate(id, frame.depthImage(), frame.intrinsics(), T_W_S, footprint);
}

IntegrationStats TsdfVolume::deintegrate(FrameId id, const SensorFrame& frame, const Pose3d& T_W_S) {
  return frame.isDepth() ? deintegrate(id, frame.depthImage(), frame.intrinsics(), T_W_S)
                         : deintegrate(id, frame.points_S(), T_W_S);
}

IntegrationStats TsdfVolume::reintegrate(FrameId id, const SensorFrame& frame, const Pose3d& T_W_S_old,
                                         const Pose3d& T_W_S_new, VoxelFootprint* footprint) {
  if (!frame.isDepth()) {
    if (footprint) footprint->clear();
    return reintegrate(id, frame.points_S(), T_W_S_old, T_W_S_new);
  }
  return reintegrate(id, frame.depthImage(), frame.intrinsics(), T_W_S_old, T_W_S_new, footprint);
}

IntegrationStats TsdfVolume::reintegrate(FrameId id, const PointCloud& points_S, const Pose3d& T_W_S_old,
                                         const Pose3d& T_W_S_new) {
  const std::uint64_t data_hash = dataHash(points_S);
  const auto it = checkKnownFrame(id, fingerprint(data_hash, T_W_S_old), "points");
  checkPose(id, T_W_S_new, "the new T_W_S");
  IntegrationStats stats = apply(points_S, T_W_S_old, -1);
  const IntegrationStats in = apply(points_S, T_W_S_new, +1);
  stats.voxel_updates += in.voxel_updates;
  stats.touched_voxels.expand(in.touched_voxels);
  it->second = FrameRecord{fingerprint(data_hash, T_W_S_new), T_W_S_new};
  return stats;
}

IntegrationStats TsdfVolume::reintegrate(FrameId id, const DepthImage& depth_m, const CameraIntrinsics& K,
                                         const Pose3d& T_W_S_old, const Pose3d& T_W_S_new,
                                         VoxelFootprint* footprint) {
  const std::uint64_t data_hash = dataHash(depth_m, K);
  const auto it = checkKnownFrame(id, fingerprint(data_hash, T_W_S_old), "depth image, intrinsics");
  checkPose(id, T_W_S_new, "the new T_W_S");
  IntegrationStats stats;
  if (footprint) footprint->clear();
  if (integrator_.ray_mode == RayMode::Projective) {
    inArena(integrator_.threads, [&] {
      internal::integrateProjective(depth_m, K, {{T_W_S_old, -1}, {T_W_S_new, +1}}, config_, integrator_, *weight_q_,
                                    *wsdf_q_, hits_.get(), stats, footprint);
    });
  } else {
    stats = apply(depth_m, K, T_W_S_old, -1);
    const IntegrationStats in = apply(depth_m, K, T_W_S_new, +1);
    stats.voxel_updates += in.voxel_updates;
    stats.touched_voxels.expand(in.touched_voxels);
  }
  it->second = FrameRecord{fingerprint(data_hash, T_W_S_new), T_W_S_new};
  return stats;
}

std::map<FrameId, Pose3d> TsdfVolume::integratedPoses() const {
  std::map<FrameId, Pose3d> poses;
  for (const auto& [id, rec] : frames_) poses.emplace(id, rec.T_W_S);
  return poses;
}

openvdb::Coord TsdfVolume::worldToVoxel(const Vec3d& p_W) const {
  const double inv = 1.0 / config_.voxel_size_m;
  return openvdb::Coord(int(std::floor(p_W.x() * inv + 0.5)), int(std::floor(p_W.y() * inv + 0.5)),
                        int(std::floor(p_W.z() * inv + 0.5)));
}

Vec3d TsdfVolume::voxelCenter(const openvdb::Coord& ijk) const {
  return Vec3d(ijk.x(), ijk.y(), ijk.z()) * config_.voxel_size_m;
}


VoxelSample TsdfVolume::sample(const openvdb::Coord& ijk) const {
  const std::int64_t w = weight_q_->tree().getValue(ijk);
  const std::int64_t wd = wsdf_q_->tree().getValue(ijk);
  VoxelSample s = VoxelCodec(config_).decode(w, wd);
  s.hits = hits_->tree().getValue(ijk);
  return s;
}

openvdb::CoordBBox TsdfVolume::activeBoundingBox() const {
  openvdb::CoordBBox bbox;
  weight_q_->tree().evalActiveVoxelBoundingBox(bbox);
  return bbox;
}

namespace {
/// A float grid with the exact state's topology, holding `value(sample)` on known voxels only.
template <typename ValueFn>
openvdb::FloatGrid::Ptr derivedGrid(const openvdb::Int64Grid& weight_q, const openvdb::Int64Grid& wsdf_q,
                                    const TsdfConfig& config, float background, const char* name, ValueFn value) {
  auto tree = std::make_shared<openvdb::FloatTree>(weight_q.tree(), background, openvdb::TopologyCopy());
  openvdb::tree::LeafManager<openvdb::FloatTree> leaves(*tree);
  const VoxelCodec codec(config);
  leaves.foreach([&](openvdb::FloatTree::LeafNodeType& leaf, std::size_t) {
    const auto* w_leaf = weight_q.tree().probeConstLeaf(leaf.origin());
    const auto* wd_leaf = wsdf_q.tree().probeConstLeaf(leaf.origin());
    for (auto it = leaf.beginValueOn(); it; ++it) {
      const VoxelSample s = codec.decode(w_leaf->getValue(it.pos()), wd_leaf->getValue(it.pos()));
      if (s.state == VoxelState::Unknown)
        it.setValueOff();  // the leaf's value stays the background below
      else
        it.setValue(value(s));
    }
    for (auto it = leaf.beginValueOff(); it; ++it) it.setValue(background);
  });
  openvdb::tools::pruneInactive(*tree);
  auto grid = openvdb::FloatGrid::create(tree);
  grid->setTransform(weight_q.transform().copy());
  grid->setName(name);
  return grid;
}
}  // namespace

openvdb::FloatGrid::Ptr TsdfVolume::tsdfGrid() const {
  auto grid = derivedGrid(*weight_q_, *wsdf_q_, config_, float(config_.truncation_m()), "tsdf",
                          [](const VoxelSample& s) { return s.tsdf_m; });
  grid->setGridClass(openvdb::GRID_LEVEL_SET);
  return grid;
}

openvdb::FloatGrid::Ptr TsdfVolume::weightGrid() const {
  auto grid = derivedGrid(*weight_q_, *wsdf_q_, config_, 0.0f, "weight", [](const VoxelSample& s) { return s.weight; });
  grid->setGridClass(openvdb::GRID_UNKNOWN);
  return grid;
}

namespace {
bool treesEqual(const openvdb::Int64Tree& a, const openvdb::Int64Tree& b) {
  if (a.activeVoxelCount() != b.activeVoxelCount() || a.leafCount() != b.leafCount()) return false;
  if (!a.hasSameTopology(b)) return false;
  for (auto it = a.cbeginValueOn(); it; ++it)
    if (b.getValue(it.getCoord()) != *it) return false;
  return true;
}
}  // namespace

bool TsdfVolume::exactlyEquals(const TsdfVolume& other) const {
  return treesEqual(weight_q_->tree(), other.weight_q_->tree()) && treesEqual(wsdf_q_->tree(), other.wsdf_q_->tree()) &&
         treesEqual(hits_->tree(), other.hits_->tree());
}

}  // namespace vdbmap
