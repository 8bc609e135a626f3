#include "internal/projective_integrator.hpp"

#include "internal/free_list.hpp"
#include "internal/grid_dda.hpp"
#include "internal/hit_counter.hpp"
#include "internal/pixel_classifier.hpp"
#include "internal/prune_leaves.hpp"
#include "internal/simd.hpp"
#include "internal/voxel_blocks.hpp"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if VDBMAP_AVX2_KERNELS
#include <immintrin.h>
#endif

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cstddef>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <stdexcept>

namespace vdbmap::internal {
namespace {

struct PixelTable {
  int width = 0, height = 0;
  std::vector<PixelRay> rays;
  double max_range_m = 0.0;  // largest range of a valid pixel
  /// Largest range per tile of kTile x kTile pixels (-1: no valid pixel), to cull leaves that lie
  /// entirely behind the surfaces they project onto.
  static constexpr int kTile = kPixelTile;
  int tiles_x = 0, tiles_y = 0;
  std::vector<float> tile_max_m;

  /// Largest range over the pixels [u0, u1] x [v0, v1] (tile-granular, so an upper bound).
  float maxRange(int u0, int u1, int v0, int v1) const {
    float m = -1.0f;
    for (int ty = v0 / kTile; ty <= v1 / kTile; ++ty)
      for (int tx = u0 / kTile; tx <= u1 / kTile; ++tx)
        m = std::max(m, tile_max_m[std::size_t(ty) * std::size_t(tiles_x) + std::size_t(tx)]);
    return m;
  }
};

/// A pixel table for one image. Tables are 24 bytes per pixel (7.4 MB at 640x480), so they are
/// kept for the next image instead of being allocated and cleared for each one; concurrent
/// integrations take different tables.
class PixelTableLease {
 public:
  PixelTableLease() : table_(pool().take()) {
    if (!table_) table_ = std::make_unique<PixelTable>();
  }
  ~PixelTableLease() { pool().keep(std::move(table_)); }
  PixelTableLease(const PixelTableLease&) = delete;
  PixelTableLease& operator=(const PixelTableLease&) = delete;
  PixelTable& operator*() const { return *table_; }

 private:
  static FreeList<PixelTable>& pool() {
    static FreeList<PixelTable> p(4);
    return p;
  }
  std::unique_ptr<PixelTable> table_;
};

/// |(x/z, y/z, 1)| of every pixel's ray: range = depth * norm. Cached for the last camera, since a
/// log or a flight keeps one camera.
std::shared_ptr<const std::vector<float>> rayNorms(const CameraIntrinsics& K) {
  static std::mutex mutex;
  static CameraIntrinsics cached_K;
  static std::shared_ptr<const std::vector<float>> cached;
  std::lock_guard<std::mutex> lock(mutex);
  if (cached && cached_K.width == K.width && cached_K.height == K.height && cached_K.fx == K.fx &&
      cached_K.fy == K.fy && cached_K.cx == K.cx && cached_K.cy == K.cy)
    return cached;
  auto norms = std::make_shared<std::vector<float>>(std::size_t(K.width) * std::size_t(K.height));
  for (int v = 0; v < K.height; ++v) {
    const double dy = (v - K.cy) / K.fy;
    for (int u = 0; u < K.width; ++u) {
      const double dx = (u - K.cx) / K.fx;
      (*norms)[std::size_t(v) * std::size_t(K.width) + std::size_t(u)] = float(std::sqrt(dx * dx + dy * dy + 1.0));
    }
  }
  cached_K = K;
  cached = norms;
  return cached;
}

/// Classifies every pixel of the image into `t` and, when `hit_runs` is given, counts in the same
/// pass the surface end points of every placement (each with its sign; countRowHits). Rows are
/// taken a tile row at a time, so the work does not depend on how TBB splits it.
void classifyPixels(const DepthImage& depth, const CameraIntrinsics& K, const TsdfConfig& tsdf,
                    const IntegratorConfig& in, const std::vector<ImagePlacement>& placements, PixelTable& t,
                    std::vector<HitRun>* hit_runs, IntegrationStats& stats) {
  constexpr int kTile = PixelTable::kTile;
  t.width = depth.width;
  t.height = depth.height;
  const std::size_t n = std::size_t(depth.width) * std::size_t(depth.height);
  t.rays.resize(n);  // every record is written below
  t.tiles_x = (depth.width + kTile - 1) / kTile;
  t.tiles_y = (depth.height + kTile - 1) / kTile;
  t.tile_max_m.assign(std::size_t(t.tiles_x) * std::size_t(t.tiles_y), -1.0f);
  const std::shared_ptr<const std::vector<float>> norms = rayNorms(K);
  const std::size_t chunks = std::size_t(t.tiles_y);
  std::vector<PixelClassifier::Tally> tallies(chunks);
  const PixelClassifier classifier(tsdf, in);

  // Hit counting: one run list per chunk and placement.
  const EndVoxels ends(tsdf, in);
  std::vector<HitPose> poses;
  if (hit_runs)
    for (const ImagePlacement& p : placements) poses.push_back({p.T_W_S.linear(), p.T_W_S.translation(), p.sign});
  const std::size_t P = poses.size();
  std::vector<std::vector<HitRun>> runs(chunks * P);
  for (std::vector<HitRun>& r : runs)
    r.reserve(std::size_t(depth.width) * std::size_t(kTile) / 8);  // ~the runs of a chunk

  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t c = r.begin(); c != r.end(); ++c) {
      std::vector<HitRun>* chunk_runs = P ? &runs[c * P] : nullptr;
      const int v_end = std::min(depth.height, int(c + 1) * kTile);
      for (int v = int(c) * kTile; v < v_end; ++v) {
        if (P) countRowHits(depth, v, K, ends, poses, chunk_runs);
        const std::size_t row = std::size_t(v) * std::size_t(depth.width);
        classifier.row(depth.depth_m.data() + row, norms->data() + row, depth.width, t.rays.data() + row,
                       t.tile_max_m.data() + c * std::size_t(t.tiles_x), tallies[c]);
      }
      for (std::size_t j = 0; j < P; ++j) compactHitRuns(chunk_runs[j]);
    }
  });
  stats.points_total += n;
  t.max_range_m = 0.0;
  for (const PixelClassifier::Tally& tally : tallies) {
    stats.points_invalid += tally.invalid;
    stats.points_beyond_range += tally.beyond;
    t.max_range_m = std::max(t.max_range_m, tally.max_range_m);
  }
  if (hit_runs)
    for (const std::vector<HitRun>& c : runs) hit_runs->insert(hit_runs->end(), c.begin(), c.end());
}

/// The leaves (8^3 voxels) that may hold voxels of the frustum: those crossed by a coarse ray
/// through each image tile, out to the tile's farthest range + truncation, dilated by one leaf.
/// Tiles are as wide as a leaf appears at max range, so neighbouring tile rays are less than a
/// leaf apart everywhere and the dilation covers the space between them.
void candidateLeaves(const PixelTable& px, const CameraIntrinsics& K, const Pose3d& T_W_S, const TsdfConfig& tsdf,
                     KeyIndex& index, std::vector<openvdb::Coord>& leaves) {
  const double vs = tsdf.voxel_size_m, leaf_m = 8.0 * vs, delta = tsdf.truncation_m();
  const double f = std::min(std::abs(K.fx), std::abs(K.fy));
  // At most a leaf's width at max range; whole classification tiles where that is one or more, so
  // that their maxima give each tile's reach without a pass over its pixels. Any smaller tile
  // marks a superset of the leaves that hold updates, so the choice does not change the map.
  int tile = std::clamp(int(std::floor(leaf_m * f / std::max(px.max_range_m, 1e-3))), 1, 32);
  if (tile >= PixelTable::kTile) tile -= tile % PixelTable::kTile;
  const Vec3d origin = T_W_S.translation();
  const Vec3d q0 = (origin / vs + Vec3d::Constant(0.5)) / 8.0;  // leaf space: leaf L spans [L, L + 1)

  std::vector<openvdb::Coord> marked;
  auto mark = [&](const openvdb::Coord& leaf) {
    const openvdb::Coord origin_ijk(leaf.x() * 8, leaf.y() * 8, leaf.z() * 8);
    bool inserted = false;
    index.findOrInsert(blockKey(origin_ijk), inserted);
    if (inserted) {
      marked.push_back(origin_ijk);
      leaves.push_back(origin_ijk);
    }
  };
  for (int v0 = 0; v0 < px.height; v0 += tile) {
    for (int u0 = 0; u0 < px.width; u0 += tile) {
      const int u1 = std::min(px.width, u0 + tile), v1 = std::min(px.height, v0 + tile);
      double reach = -1.0;
      if (tile % PixelTable::kTile == 0) {  // whole classification tiles: their maxima are the pixels'
        reach = px.maxRange(u0, u1 - 1, v0, v1 - 1);
      } else {
        for (int v = v0; v < v1; ++v)
          for (int u = u0; u < u1; ++u) {
            const PixelRay& ray = px.rays[std::size_t(v) * std::size_t(px.width) + std::size_t(u)];
            if (ray.weight_q > 0) reach = std::max(reach, double(ray.range_m));
          }
      }
      if (reach < 0.0) continue;
      reach += delta;
      const double uc = 0.5 * (u0 + u1 - 1), vc = 0.5 * (v0 + v1 - 1);
      const Vec3d dir = (T_W_S.linear() * Vec3d((uc - K.cx) / K.fx, (vc - K.cy) / K.fy, 1.0)).normalized();
      // 3D DDA over leaves from the camera to `reach`.
      GridDda dda(q0, dir, 1.0 / leaf_m);
      while (true) {
        mark(openvdb::Coord(dda.cell[0], dda.cell[1], dda.cell[2]));
        const int a = dda.nextAxis();
        if (dda.t_max[a] > reach) break;
        dda.advance(a);
      }
    }
  }
  for (const openvdb::Coord& c : marked)
    for (int dx = -8; dx <= 8; dx += 8)
      for (int dy = -8; dy <= 8; dy += 8)
        for (int dz = -8; dz <= 8; dz += 8) {
          const openvdb::Coord n = c.offsetBy(dx, dy, dz);
          bool inserted = false;
          index.findOrInsert(blockKey(n), inserted);
          if (inserted) leaves.push_back(n);
        }
}

/// A leaf's box in the sensor frame, to cull leaves outside the frustum before testing voxels.
class FrustumCull {
 public:
  FrustumCull(const PixelTable& px, const CameraIntrinsics& K, const Pose3d& T_W_S, double voxel_size_m,
              double truncation_m)
      : px_(px),
        K_(K),
        T_S_W_(T_W_S.inverse()),
        vs_(voxel_size_m),
        delta_(truncation_m),
        reach_(px.max_range_m + truncation_m) {}

  /// True when no voxel of the leaf at `origin` can be in the frustum within reach: behind the
  /// camera, outside the image, or beyond every surface it projects onto (+ truncation).
  bool outside(const openvdb::Coord& origin) const {
    std::array<Vec3d, 8> c;
    for (int k = 0; k < 8; ++k) {
      const Vec3d corner_W((origin.x() - 0.5 + 8.0 * (k & 1)) * vs_, (origin.y() - 0.5 + 8.0 * ((k >> 1) & 1)) * vs_,
                           (origin.z() - 0.5 + 8.0 * ((k >> 2) & 1)) * vs_);
      c[std::size_t(k)] = T_S_W_ * corner_W;
    }
    // Behind the camera, or entirely beyond reach (the box's nearest point).
    if (std::all_of(c.begin(), c.end(), [](const Vec3d& p) { return p.z() <= 0.0; })) return true;
    Vec3d lo = c[0], hi = c[0];
    for (const Vec3d& p : c) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    const Vec3d nearest = Vec3d::Zero().cwiseMax(lo).cwiseMin(hi);
    if (nearest.norm() > reach_) return true;
    if (std::any_of(c.begin(), c.end(), [](const Vec3d& p) { return p.z() <= 0.0; })) return false;
    // The four side planes through the camera centre: u in [-0.5, W - 0.5], v in [-0.5, H - 0.5].
    auto allOutside = [&](auto signedSide) {
      return std::all_of(c.begin(), c.end(), [&](const Vec3d& p) { return signedSide(p) < 0.0; });
    };
    if (allOutside([&](const Vec3d& p) { return K_.fx * p.x() + (K_.cx + 0.5) * p.z(); })) return true;
    if (allOutside([&](const Vec3d& p) { return -(K_.fx * p.x() + (K_.cx - K_.width + 0.5) * p.z()); })) return true;
    if (allOutside([&](const Vec3d& p) { return K_.fy * p.y() + (K_.cy + 0.5) * p.z(); })) return true;
    if (allOutside([&](const Vec3d& p) { return -(K_.fy * p.y() + (K_.cy - K_.height + 0.5) * p.z()); })) return true;
    // The pixels the leaf projects onto (its voxels take the nearest pixel centre); beyond all of
    // their surfaces + truncation, no voxel of it is updated.
    double u_lo = 1e30, u_hi = -1e30, v_lo = 1e30, v_hi = -1e30;
    for (const Vec3d& p : c) {
      const double u = K_.fx * p.x() / p.z() + K_.cx, v = K_.fy * p.y() / p.z() + K_.cy;
      u_lo = std::min(u_lo, u);
      u_hi = std::max(u_hi, u);
      v_lo = std::min(v_lo, v);
      v_hi = std::max(v_hi, v);
    }
    const int u0 = std::max(0, int(std::floor(u_lo + 0.5))), u1 = std::min(K_.width - 1, int(std::floor(u_hi + 0.5)));
    const int v0 = std::max(0, int(std::floor(v_lo + 0.5))), v1 = std::min(K_.height - 1, int(std::floor(v_hi + 0.5)));
    if (u0 > u1 || v0 > v1) return true;
    constexpr int kMaxTiles = 256;  // near leaves cover much of the image and are rarely behind it
    const int tiles = (u1 / PixelTable::kTile - u0 / PixelTable::kTile + 1) * (v1 / PixelTable::kTile - v0 / PixelTable::kTile + 1);
    if (tiles > kMaxTiles) return false;
    const float local_max = px_.maxRange(u0, u1, v0, v1);
    return local_max < 0.0f || nearest.norm() > double(local_max) + delta_;
  }

 private:
  const PixelTable& px_;
  CameraIntrinsics K_;
  Pose3d T_S_W_;
  double vs_, delta_, reach_;
};

/// The eight voxels of a leaf column at sensor-frame positions (xs, ys, zs): their pixel
/// coordinates + 0.5 into (us, vs) and, as bit k of the result, whether voxel k is in front of the
/// camera and inside the image. Four at a time with SSE2, each lane doing the one-voxel arithmetic.
struct ColumnProjector {
  float fx, fy, cx, cy, u_end, v_end;

  ColumnProjector(const CameraIntrinsics& K, const PixelTable& px)
      : fx(float(K.fx)),
        fy(float(K.fy)),
        cx(float(K.cx) + 0.5f),
        cy(float(K.cy) + 0.5f),
        u_end(float(px.width)),
        v_end(float(px.height)) {}

  int project(const float* xs, const float* ys, const float* zs, float* us, float* vs) const {
    int inside = 0;
#if defined(__SSE2__)
    const __m128 zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f);
    for (int h = 0; h < 8; h += 4) {
      const __m128 x = _mm_load_ps(xs + h), y = _mm_load_ps(ys + h), z = _mm_load_ps(zs + h);
      const __m128 inv_z = _mm_div_ps(one, z);  // lanes behind the camera are masked out below
      const __m128 u = _mm_add_ps(_mm_mul_ps(_mm_mul_ps(_mm_set1_ps(fx), x), inv_z), _mm_set1_ps(cx));
      const __m128 v = _mm_add_ps(_mm_mul_ps(_mm_mul_ps(_mm_set1_ps(fy), y), inv_z), _mm_set1_ps(cy));
      __m128 in =
          _mm_and_ps(_mm_cmpgt_ps(z, zero), _mm_and_ps(_mm_cmpge_ps(u, zero), _mm_cmplt_ps(u, _mm_set1_ps(u_end))));
      in = _mm_and_ps(in, _mm_and_ps(_mm_cmpge_ps(v, zero), _mm_cmplt_ps(v, _mm_set1_ps(v_end))));
      _mm_store_ps(us + h, u);
      _mm_store_ps(vs + h, v);
      inside |= _mm_movemask_ps(in) << h;
    }
#else
    for (int k = 0; k < 8; ++k) {
      if (!(zs[k] > 0.0f)) continue;
      const float inv_z = 1.0f / zs[k];
      us[k] = fx * xs[k] * inv_z + cx;
      vs[k] = fy * ys[k] * inv_z + cy;
      if (us[k] >= 0.0f && us[k] < u_end && vs[k] >= 0.0f && vs[k] < v_end) inside |= 1 << k;
    }
#endif
    return inside;
  }
};

/// Projects the 512 voxels of one leaf into the image and calls visit(n, ray, d2) for each voxel
/// within its pixel's reach (free space or band): n its offset in the leaf, ray its pixel, d2 its
/// squared distance from the camera. Single precision: positions are relative to the camera
/// (metres, well within float's range), and the same arithmetic runs for integration,
/// de-integration and the footprint, so they agree exactly.
template <typename Visit>
void visitLeaf(const PixelTable& px, const CameraIntrinsics& K, const Eigen::Matrix3f& A, const Eigen::Vector3f& b,
               Visit&& visit) {
  const ColumnProjector projector(K, px);
  const Eigen::Vector3f step = A.col(2);
  alignas(16) float xs[8], ys[8], zs[8], us[8], vs[8];
  for (int i = 0; i < 8; ++i) {
    for (int j = 0; j < 8; ++j) {
      Eigen::Vector3f p = A.col(0) * float(i) + A.col(1) * float(j) + b;  // voxel (i, j, 0) in the sensor frame
      for (int k = 0; k < 8; ++k, p += step) {
        xs[k] = p.x();
        ys[k] = p.y();
        zs[k] = p.z();
      }
      const openvdb::Index n0 = openvdb::Index(i * 64 + j * 8);
      // Pixel coordinates + 0.5: the nearest pixel centre is their floor.
      for (int inside = projector.project(xs, ys, zs, us, vs); inside != 0; inside &= inside - 1) {
        const int k = __builtin_ctz(unsigned(inside));
        const PixelRay& ray = px.rays[std::size_t(vs[k]) * std::size_t(px.width) + std::size_t(us[k])];
        if (ray.weight_q == 0) continue;
        const float d2 = xs[k] * xs[k] + (ys[k] * ys[k] + zs[k] * zs[k]);  // integrateLeafAvx2 sums so too
        if (d2 <= ray.band2) visit(n0 + openvdb::Index(k), ray, d2);
      }
    }
  }
}

/// The update of voxel n at squared distance d2 from the camera along `ray`, beyond its free
/// space: the signed distance to the pixel's surface through SdfUpdate (both voxel loops).
inline bool applyBand(const SdfUpdate& update, Block& block, openvdb::Index n, const PixelRay& ray, float d2,
                      std::int64_t sign) {
  return update.apply(block, n, double(ray.range_m) - std::sqrt(double(d2)), ray.weight_q, sign);
}

/// Tests the 512 voxels of one leaf against the image and writes their updates into `block`; marks
/// the visited voxels in `mask` when given (a LeafFootprint's words).
std::size_t integrateLeaf(const PixelTable& px, const CameraIntrinsics& K, const Eigen::Matrix3f& A, const Eigen::Vector3f& b,
                          const SdfUpdate& update, std::int64_t sign, Block& block, std::uint64_t* mask) {
  std::size_t updates = 0;
  visitLeaf(px, K, A, b, [&](openvdb::Index n, const PixelRay& ray, float d2) {
    if (mask) mask[n >> 6] |= std::uint64_t(1) << (n & 63);
    if (d2 <= ray.free2) {  // free space: the update does not depend on the distance
      block.addFree(n, sign * ray.weight_q);
      ++updates;
    } else {
      updates += applyBand(update, block, n, ray, d2, sign) ? 1 : 0;
    }
  });
  return updates;
}

#if VDBMAP_AVX2_KERNELS
/// Whether integrateLeafAvx2 can take this table and sign: its gathers address records with
/// 32-bit byte offsets, and it negates weights rather than multiplying them.
bool avx2LeavesFit(const PixelTable& px, std::int64_t sign) {
  return px.rays.size() <= std::size_t(std::numeric_limits<std::int32_t>::max()) / sizeof(PixelRay) &&
         (sign == 1 || sign == -1);
}

/// The free2 and band2 limits of the pixel records at byte offsets `at` (eight lanes): one 8-byte
/// load per lane, since the two fields are adjacent. On this machine's AMD cores eight loads beat
/// AVX2's gathers (docs/results/realtime_7scenes.md, stop 53).
VDBMAP_TARGET_AVX2 inline void loadLimits(const char* records, const std::int32_t* at, __m256& free2, __m256& band2) {
  static_assert(offsetof(PixelRay, band2) == offsetof(PixelRay, free2) + sizeof(float), "free2, band2 adjacent");
  const char* base = records + offsetof(PixelRay, free2);
  const auto pair = [&](int k) { return _mm_loadl_epi64(reinterpret_cast<const __m128i*>(base + at[k])); };
  // lo = (free2, band2) of lanes 0-3, hi of lanes 4-7
  const __m256i lo = _mm256_set_m128i(_mm_unpacklo_epi64(pair(2), pair(3)), _mm_unpacklo_epi64(pair(0), pair(1)));
  const __m256i hi = _mm256_set_m128i(_mm_unpacklo_epi64(pair(6), pair(7)), _mm_unpacklo_epi64(pair(4), pair(5)));
  // Per 128-bit half: (lo a, lo b, hi a, hi b), i.e. lanes (0 1 4 5 | 2 3 6 7); then in order.
  const __m256 f = _mm256_shuffle_ps(_mm256_castsi256_ps(lo), _mm256_castsi256_ps(hi), _MM_SHUFFLE(2, 0, 2, 0));
  const __m256 b = _mm256_shuffle_ps(_mm256_castsi256_ps(lo), _mm256_castsi256_ps(hi), _MM_SHUFFLE(3, 1, 3, 1));
  free2 = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(f), _MM_SHUFFLE(3, 1, 2, 0)));
  band2 = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(b), _MM_SHUFFLE(3, 1, 2, 0)));
}

/// The weights of the pixel records at byte offsets at[first..first + 3], as four 64-bit lanes.
VDBMAP_TARGET_AVX2 inline __m256i loadWeights(const char* records, const std::int32_t* at, int first) {
  // Read as the records they are, as the band voxels' are (a long long read would alias int64_t).
  const auto weight = [&](int k) { return reinterpret_cast<const PixelRay*>(records + at[first + k])->weight_q; };
  return _mm256_set_epi64x(weight(3), weight(2), weight(1), weight(0));
}

/// integrateLeaf a leaf column (eight voxels) at a time, with the same result: the projection and
/// the squared distances are the same single-precision operations lane by lane (internal/simd.hpp),
/// the pixel records' fields are loaded lane by lane, and the free-space voxels of a column are summed in
/// one vector add (their updates are the pixel weights, integers). Band voxels go through
/// SdfUpdate::apply one at a time as in integrateLeaf. Invalid pixels need no test of their own:
/// their band2 of -1 rejects every voxel.
VDBMAP_TARGET_AVX2 std::size_t integrateLeafAvx2(const PixelTable& px, const CameraIntrinsics& K,
                                                 const Eigen::Matrix3f& A, const Eigen::Vector3f& b,
                                                 const SdfUpdate& update, std::int64_t sign, Block& block,
                                                 std::uint64_t* mask) {
  const __m256 fx = _mm256_set1_ps(float(K.fx)), fy = _mm256_set1_ps(float(K.fy));
  const __m256 cx = _mm256_set1_ps(float(K.cx) + 0.5f), cy = _mm256_set1_ps(float(K.cy) + 0.5f);
  const __m256 u_end = _mm256_set1_ps(float(px.width)), v_end = _mm256_set1_ps(float(px.height));
  const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  const __m256i width = _mm256_set1_epi32(px.width), record = _mm256_set1_epi32(int(sizeof(PixelRay)));
  const char* records = reinterpret_cast<const char*>(px.rays.data());
  const Eigen::Vector3f step = A.col(2);
  alignas(32) float xs[8], ys[8], zs[8], d2s[8];
  alignas(32) std::int32_t offsets[8];
  std::size_t updates = 0;
  for (int i = 0; i < 8; ++i) {
    for (int j = 0; j < 8; ++j) {
      Eigen::Vector3f p = A.col(0) * float(i) + A.col(1) * float(j) + b;  // as visitLeaf
      for (int k = 0; k < 8; ++k, p += step) {
        xs[k] = p.x();
        ys[k] = p.y();
        zs[k] = p.z();
      }
      const __m256 x = _mm256_load_ps(xs), y = _mm256_load_ps(ys), z = _mm256_load_ps(zs);
      const __m256 inv_z = _mm256_div_ps(one, z);
      const __m256 u = _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(fx, x), inv_z), cx);
      const __m256 v = _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(fy, y), inv_z), cy);
      const __m256 in = _mm256_and_ps(
          _mm256_and_ps(_mm256_cmp_ps(z, zero, _CMP_GT_OQ),
                        _mm256_and_ps(_mm256_cmp_ps(u, zero, _CMP_GE_OQ), _mm256_cmp_ps(u, u_end, _CMP_LT_OQ))),
          _mm256_and_ps(_mm256_cmp_ps(v, zero, _CMP_GE_OQ), _mm256_cmp_ps(v, v_end, _CMP_LT_OQ)));
      if (_mm256_movemask_ps(in) == 0) continue;
      // Byte offsets of the voxels' pixel records; lanes outside the image read record 0, masked below.
      const __m256i pixel = _mm256_add_epi32(_mm256_mullo_epi32(_mm256_cvttps_epi32(v), width), _mm256_cvttps_epi32(u));
      _mm256_store_si256(reinterpret_cast<__m256i*>(offsets),
                         _mm256_and_si256(_mm256_mullo_epi32(pixel, record), _mm256_castps_si256(in)));
      __m256 free2, band2;
      loadLimits(records, offsets, free2, band2);
      // Summed as Eigen's squaredNorm() of a Vector3f sums: x^2 + (y^2 + z^2).
      const __m256 d2 = _mm256_add_ps(_mm256_mul_ps(x, x), _mm256_add_ps(_mm256_mul_ps(y, y), _mm256_mul_ps(z, z)));
      const __m256 visit = _mm256_and_ps(in, _mm256_cmp_ps(d2, band2, _CMP_LE_OQ));
      const unsigned visited = unsigned(_mm256_movemask_ps(visit));
      if (visited == 0) continue;
      const __m256 free = _mm256_and_ps(visit, _mm256_cmp_ps(d2, free2, _CMP_LE_OQ));
      const unsigned freed = unsigned(_mm256_movemask_ps(free));
      const int shift = 8 * j;  // voxel (i, j, k) is bit 8 j + k of word i
      if (mask) mask[i] |= std::uint64_t(visited) << shift;
      const openvdb::Index n0 = openvdb::Index(i * 64 + j * 8);
      if (freed != 0) {
        // The free voxels' weights, 0 in the other lanes, added to the column's eight sums.
        const __m256i free_i = _mm256_castps_si256(free);
        const __m128i lane_free[2] = {_mm256_castsi256_si128(free_i), _mm256_extracti128_si256(free_i, 1)};
        for (int half = 0; half < 2; ++half) {  // lanes 0-3, then 4-7: 64-bit weights, four at a time
          __m256i w = _mm256_and_si256(loadWeights(records, offsets, 4 * half), _mm256_cvtepi32_epi64(lane_free[half]));
          if (sign < 0) w = _mm256_sub_epi64(_mm256_setzero_si256(), w);
          __m256i* sums = reinterpret_cast<__m256i*>(block.free_w.data() + n0 + 4 * half);
          _mm256_storeu_si256(sums, _mm256_add_epi64(_mm256_loadu_si256(sums), w));
        }
        block.touched[std::size_t(i)] |= std::uint64_t(freed) << shift;
        updates += std::size_t(__builtin_popcount(freed));
      }
      if (const unsigned band = visited & ~freed) {
        _mm256_store_ps(d2s, d2);
        for (unsigned left = band; left != 0; left &= left - 1) {
          const int k = __builtin_ctz(left);
          const PixelRay& ray = *reinterpret_cast<const PixelRay*>(records + offsets[k]);
          updates += applyBand(update, block, n0 + openvdb::Index(k), ray, d2s[k], sign) ? 1 : 0;
        }
      }
    }
  }
  return updates;
}
#endif

/// A placement's frustum cull and its leaf-to-sensor mapping.
struct View {
  FrustumCull cull;
  Eigen::Matrix3d R_S_W;
  Eigen::Matrix3f A;  // sensor-frame step per voxel index
  Vec3d t_W;
  std::int64_t sign;

  View(const PixelTable& px, const CameraIntrinsics& K, const Pose3d& T_W_S, std::int64_t sign_, const TsdfConfig& tsdf)
      : cull(px, K, T_W_S, tsdf.voxel_size_m, tsdf.truncation_m()),
        R_S_W(T_W_S.linear().transpose()),
        A((R_S_W * tsdf.voxel_size_m).cast<float>()),
        t_W(T_W_S.translation()),
        sign(sign_) {}

  /// The sensor-frame position of the leaf's voxel (0, 0, 0).
  Eigen::Vector3f leafOrigin(const openvdb::Coord& origin, double voxel_size_m) const {
    return (R_S_W * (Vec3d(origin.x(), origin.y(), origin.z()) * voxel_size_m - t_W)).cast<float>();
  }
};

}  // namespace

void integrateProjective(const DepthImage& depth_m, const CameraIntrinsics& K,
                         const std::vector<ImagePlacement>& placements, const TsdfConfig& tsdf,
                         const IntegratorConfig& integrator, openvdb::Int64Grid& weight_q, openvdb::Int64Grid& wsdf_q,
                         openvdb::Int64Grid* hits, IntegrationStats& stats, VoxelFootprint* footprint) {
  checkDepthImageSize(depth_m, K);
  if (footprint) footprint->clear();
  const PixelTableLease lease;
  const PixelTable& px = *lease;
  std::vector<HitRun> hit_runs;
  classifyPixels(depth_m, K, tsdf, integrator, placements, *lease, hits ? &hit_runs : nullptr, stats);
  if (hits) applyHitRuns(hit_runs, *hits);
  if (px.max_range_m <= 0.0 || placements.empty()) return;  // no valid pixel
  // A frame marks thousands of leaves (tens of thousands at 2 cm): the index is sized from the
  // last frame's count, so that it is rarely regrown. Its capacity does not change the order.
  static std::atomic<std::size_t> last_leaves_per_placement{16384};
  KeyIndex index(last_leaves_per_placement.load(std::memory_order_relaxed) * placements.size());
  std::vector<openvdb::Coord> leaves;
  leaves.reserve(index.capacity());
  for (const ImagePlacement& p : placements) candidateLeaves(px, K, p.T_W_S, tsdf, index, leaves);
  last_leaves_per_placement.store(std::max<std::size_t>(4096, leaves.size() / placements.size() * 5 / 4),
                                  std::memory_order_relaxed);

  std::vector<View> views;
  for (const ImagePlacement& p : placements) views.emplace_back(px, K, p.T_W_S, p.sign, tsdf);
  const SdfUpdate update(tsdf);
  const double vs = tsdf.voxel_size_m;

  // Each leaf's updates are summed in a block and added at once to the map's leaves when they
  // exist (values only, so in parallel), while the block is still in cache; blocks of leaves the
  // map lacks wait for applyBlocks, which creates them serially.
  std::vector<std::unique_ptr<Block>> deferred(leaves.size());
  std::vector<std::size_t> updates(leaves.size(), 0);
  std::vector<char> emptied(leaves.size(), 0);
  [[maybe_unused]] const bool avx2 = simdLevel() == SimdLevel::Avx2;
  VoxelFootprint masks(footprint ? leaves.size() : 0);
  openvdb::Int64Tree& w_tree = weight_q.tree();
  openvdb::Int64Tree& wd_tree = wsdf_q.tree();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leaves.size(), 4), [&](const auto& r) {
    std::unique_ptr<Block> block;  // zero between leaves
    for (std::size_t l = r.begin(); l != r.end(); ++l) {
      const openvdb::Coord& origin = leaves[l];
      Int64Leaf* w_leaf = nullptr;
      Int64Leaf* wd_leaf = nullptr;
      bool probed = false;
      for (const View& view : views) {
        if (view.cull.outside(origin)) continue;
        if (!block) block = acquireBlock(origin);
        if (!probed) {
          // The map's leaves, fetched into cache while the voxel loop runs (at 2 cm they are
          // rarely there: the map is large, and the loop touches each leaf once a frame).
          probed = true;
          w_leaf = w_tree.probeLeaf(origin);
          wd_leaf = wd_tree.probeLeaf(origin);
          if (w_leaf && wd_leaf) {
            const std::int64_t* w_data = w_leaf->buffer().data();
            const std::int64_t* wd_data = wd_leaf->buffer().data();
            for (openvdb::Index n = 0; n < Int64Leaf::SIZE; n += 8) {
              __builtin_prefetch(w_data + n, 1);
              __builtin_prefetch(wd_data + n, 1);
            }
          }
        }
        std::uint64_t* mask = footprint && view.sign > 0 ? masks[l].voxels.data() : nullptr;
        const Eigen::Vector3f b = view.leafOrigin(origin, vs);
#if VDBMAP_AVX2_KERNELS
        if (avx2 && avx2LeavesFit(px, view.sign)) {
          updates[l] += integrateLeafAvx2(px, K, view.A, b, update, view.sign, *block, mask);
          continue;
        }
#endif
        updates[l] += integrateLeaf(px, K, view.A, b, update, view.sign, *block, mask);
      }
      if (updates[l] == 0) continue;  // the block is still zero
      if (w_leaf && wd_leaf) {
        emptied[l] = addBlockToLeaves(*block, *w_leaf, *wd_leaf, +1);
      } else {
        block->origin = origin;
        deferred[l] = std::move(block);
      }
    }
    if (block) releaseBlock(std::move(block));
  });
  if (footprint) {
    for (std::size_t l = 0; l < leaves.size(); ++l) {
      if (masks[l].empty()) continue;
      masks[l].origin = leaves[l];
      footprint->push_back(masks[l]);
    }
  }

  std::vector<Block*> pending;
  std::vector<openvdb::Coord> prune;
  for (std::size_t l = 0; l < leaves.size(); ++l) {
    if (updates[l] == 0) continue;
    if (deferred[l]) pending.push_back(deferred[l].get());
    if (emptied[l]) prune.push_back(leaves[l]);
    stats.voxel_updates += updates[l];
    stats.touched_voxels.expand(openvdb::CoordBBox::createCube(leaves[l], 8));
  }
  applyBlocks(pending, w_tree, wd_tree, +1);
  pruneEmptiedLeaves(w_tree, prune);
  pruneEmptiedLeaves(wd_tree, std::move(prune));
  releaseBlocks(deferred);
}

VoxelFootprint projectiveFootprint(const DepthImage& depth_m, const CameraIntrinsics& K, const Pose3d& T_W_S,
                                               const TsdfConfig& tsdf, const IntegratorConfig& integrator) {
  checkDepthImageSize(depth_m, K);
  IntegrationStats stats;
  const PixelTableLease lease;
  const PixelTable& px = *lease;
  classifyPixels(depth_m, K, tsdf, integrator, {}, *lease, nullptr, stats);
  if (px.max_range_m <= 0.0) return {};
  KeyIndex index(4096);
  std::vector<openvdb::Coord> leaves;
  candidateLeaves(px, K, T_W_S, tsdf, index, leaves);
  const View view(px, K, T_W_S, +1, tsdf);

  VoxelFootprint footprints(leaves.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leaves.size(), 4), [&](const auto& r) {
    for (std::size_t l = r.begin(); l != r.end(); ++l) {
      LeafFootprint& f = footprints[l];
      f.origin = leaves[l];
      if (view.cull.outside(f.origin)) continue;
      visitLeaf(px, K, view.A, view.leafOrigin(f.origin, tsdf.voxel_size_m),
                [&f](openvdb::Index n, const PixelRay&, float) { f.voxels[n >> 6] |= std::uint64_t(1) << (n & 63); });
    }
  });
  footprints.erase(std::remove_if(footprints.begin(), footprints.end(), [](const LeafFootprint& f) { return f.empty(); }),
                   footprints.end());
  return footprints;
}

}  // namespace vdbmap::internal
