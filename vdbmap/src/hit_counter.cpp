#include "internal/hit_counter.hpp"

#include <openvdb/tools/Prune.h>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace vdbmap::internal {
namespace {

/// Points are run-length coded in fixed chunks, so the work does not depend on how TBB splits it.
constexpr std::size_t kPointChunk = 4096;

inline openvdb::Coord unpackVoxel(std::uint64_t k) {
  constexpr std::int64_t bias = std::int64_t(1) << 20;
  constexpr std::uint64_t mask = (std::uint64_t(1) << 21) - 1;
  return openvdb::Coord(int(std::int64_t((k >> 42) & mask) - bias), int(std::int64_t((k >> 21) & mask) - bias),
                        int(std::int64_t(k & mask) - bias));
}

/// Calls fill(begin, end, runs) for fixed chunks of [0, n) in parallel and returns all runs, in
/// chunk order, so that the work does not depend on how TBB splits it.
template <typename Fill>
std::vector<HitRun> chunkRuns(std::size_t n, Fill&& fill) {
  const std::size_t chunks = (n + kPointChunk - 1) / kPointChunk;
  std::vector<std::vector<HitRun>> chunk_runs(chunks);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks), [&](const auto& r) {
    for (std::size_t c = r.begin(); c != r.end(); ++c) {
      fill(c * kPointChunk, std::min(n, (c + 1) * kPointChunk), chunk_runs[c]);
      compactHitRuns(chunk_runs[c]);
    }
  });
  std::vector<HitRun> runs;
  for (const std::vector<HitRun>& c : chunk_runs) runs.insert(runs.end(), c.begin(), c.end());
  return runs;
}

/// Counts one point at every pose: the scalar path of countRowHits.
inline void countPoint(const Vec3d& p_S, const EndVoxels& ends, const std::vector<HitPose>& poses, bool move,
                       std::vector<HitRun>* runs) {
  if (!ends.isSurface(p_S)) return;
  if (move) {
    const std::uint64_t from = ends.key(p_S, poses[0].R, poses[0].t), to = ends.key(p_S, poses[1].R, poses[1].t);
    if (from == to) return;
    appendHit(runs[0], from, poses[0].sign);
    appendHit(runs[1], to, poses[1].sign);
    return;
  }
  for (std::size_t j = 0; j < poses.size(); ++j)
    appendHit(runs[j], ends.key(p_S, poses[j].R, poses[j].t), poses[j].sign);
}

#if defined(__SSE2__)
/// A pose's rotation and translation, each coefficient in both lanes.
struct PoseLanes {
  __m128d r[3][3], t[3];
  explicit PoseLanes(const HitPose& pose) {
    for (int i = 0; i < 3; ++i) {
      for (int k = 0; k < 3; ++k) r[i][k] = _mm_set1_pd(pose.R(i, k));
      t[i] = _mm_set1_pd(pose.t[i]);
    }
  }
  /// The voxel keys of the points (x, y, z) in lanes 0 and 1, summed, floored and packed as
  /// EndVoxels::key does.
  void keys(__m128d x, __m128d y, __m128d z, __m128d inv_voxel, std::uint64_t out[2]) const {
    const __m128d half = _mm_set1_pd(0.5);
    __m128i field[3];
    for (int i = 0; i < 2; ++i) {
      const __m128d s = _mm_add_pd(_mm_add_pd(_mm_mul_pd(r[i][0], x), _mm_mul_pd(r[i][1], y)), _mm_mul_pd(r[i][2], z));
      field[i] = packField(floorLanes(_mm_add_pd(_mm_mul_pd(_mm_add_pd(s, t[i]), inv_voxel), half)));
    }
    const __m128d s = _mm_add_pd(_mm_mul_pd(r[2][0], x), _mm_add_pd(_mm_mul_pd(r[2][1], y), _mm_mul_pd(r[2][2], z)));
    field[2] = packField(floorLanes(_mm_add_pd(_mm_mul_pd(_mm_add_pd(s, t[2]), inv_voxel), half)));
    const __m128i key =
        _mm_or_si128(_mm_or_si128(_mm_slli_epi64(field[0], 42), _mm_slli_epi64(field[1], 21)), field[2]);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out), key);
  }

 private:
  /// fastFloor of both lanes, as 32-bit integers in lanes 0 and 1: the truncation, less one where
  /// it lies above the value.
  static __m128i floorLanes(__m128d e) {
    const __m128i truncated = _mm_cvttpd_epi32(e);
    const __m128d above = _mm_cmplt_pd(e, _mm_cvtepi32_pd(truncated));  // all ones: subtract 1
    return _mm_add_epi32(truncated, _mm_shuffle_epi32(_mm_castpd_si128(above), _MM_SHUFFLE(3, 3, 2, 0)));
  }
  /// packVoxel's field of lanes 0 and 1 (biased, 21 bits), as two 64-bit lanes. The 32-bit sum
  /// keeps the low 21 bits that the 64-bit one has.
  static __m128i packField(__m128i c) {
    const __m128i biased = _mm_add_epi32(c, _mm_set1_epi32(1 << 20));
    return _mm_unpacklo_epi32(_mm_and_si128(biased, _mm_set1_epi32((1 << 21) - 1)), _mm_setzero_si128());
  }
};
#endif

}  // namespace

void countRowHits(const DepthImage& depth_m, int v, const CameraIntrinsics& K, const EndVoxels& ends,
                  const std::vector<HitPose>& poses, std::vector<HitRun>* runs) {
  const double inv_fx = 1.0 / K.fx, inv_fy = 1.0 / K.fy;
  const bool move = poses.size() == 2 && poses[0].sign == -poses[1].sign;
  const float* z_row = depth_m.depth_m.data() + std::size_t(v) * std::size_t(depth_m.width);
  const auto valid = [](float z) { return z > 0.0f && std::isfinite(z); };
  int u = 0;
#if defined(__SSE2__)
  if (!poses.empty() && poses.size() <= 2) {
    // Pixels u and u + 1 in lanes 0 and 1. Each operation is the scalar path's, lane by lane:
    // backProjectPixel's products rounded to float, isSurface's (x^2 + y^2) + z^2 and key's sums.
    // Valid pixels have finite points (max range is finite, so an overflow to infinity fails the
    // range test as allFinite would) and r^2 >= z^2 > 0.
    const std::array<PoseLanes, 2> lanes{PoseLanes(poses[0]), PoseLanes(poses.back())};
    const __m128d cx = _mm_set1_pd(K.cx), ifx = _mm_set1_pd(inv_fx), by = _mm_set1_pd((v - K.cy) * inv_fy);
    const __m128d min2 = _mm_set1_pd(ends.minRange2()), max2 = _mm_set1_pd(ends.maxRange2());
    const __m128d inv_voxel = _mm_set1_pd(ends.inverseVoxelSize());
    const auto roundToFloat = [](__m128d a) { return _mm_cvtps_pd(_mm_cvtpd_ps(a)); };
    for (; u + 1 < depth_m.width; u += 2) {
      const int ok = int(valid(z_row[u])) | int(valid(z_row[u + 1])) << 1;
      if (ok == 0) continue;
      const __m128d z = _mm_set_pd(double(z_row[u + 1]), double(z_row[u]));
      const __m128d a = _mm_mul_pd(_mm_sub_pd(_mm_set_pd(double(u + 1), double(u)), cx), ifx);
      const __m128d x = roundToFloat(_mm_mul_pd(a, z)), y = roundToFloat(_mm_mul_pd(by, z));
      const __m128d r2 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(x, x), _mm_mul_pd(y, y)), _mm_mul_pd(z, z));
      const int surface = ok & _mm_movemask_pd(_mm_and_pd(_mm_cmpge_pd(r2, min2), _mm_cmple_pd(r2, max2)));
      if (surface == 0) continue;
      std::uint64_t keys[2][2];
      for (std::size_t j = 0; j < poses.size(); ++j) lanes[j].keys(x, y, z, inv_voxel, keys[j]);
      for (int l = 0; l < 2; ++l) {
        if (!(surface & (1 << l))) continue;
        if (move) {
          if (keys[0][l] == keys[1][l]) continue;
          appendHit(runs[0], keys[0][l], poses[0].sign);
          appendHit(runs[1], keys[1][l], poses[1].sign);
        } else {
          for (std::size_t j = 0; j < poses.size(); ++j) appendHit(runs[j], keys[j][l], poses[j].sign);
        }
      }
    }
  }
#endif
  for (; u < depth_m.width; ++u)
    if (valid(z_row[u]))
      countPoint(backProjectPixel(u, v, z_row[u], K, inv_fx, inv_fy).cast<double>(), ends, poses, move, runs);
}

void compactHitRuns(std::vector<HitRun>& runs) {
  // Hashed, not sorted: a voxel's runs merge into its first one, in place (a voxel's dense index
  // never exceeds the position of its first run).
  KeyIndex index(runs.size() / 4 + 16);
  for (std::size_t i = 0; i < runs.size(); ++i) {
    bool inserted = false;
    const std::uint32_t k = index.findOrInsert(runs[i].key, inserted);
    if (inserted)
      runs[k] = runs[i];
    else
      runs[k].count += runs[i].count;
  }
  runs.resize(index.size());
  runs.erase(std::remove_if(runs.begin(), runs.end(), [](const HitRun& r) { return r.count == 0; }), runs.end());
}

void applyHitRuns(std::vector<HitRun>& runs, openvdb::Int64Grid& hits) {
  compactHitRuns(runs);
  // Serial: few distinct voxels (the surface a frame sees), and OpenVDB trees are not thread-safe
  // for writes.
  openvdb::Int64Grid::Accessor acc = hits.getAccessor();
  bool removed = false;
  for (const HitRun& run : runs) {
    const openvdb::Coord c = unpackVoxel(run.key);
    const std::int64_t n = acc.getValue(c) + run.count;
    if (n == 0) {
      acc.setValueOff(c, 0);
      removed = true;
    } else {
      acc.setValueOn(c, n);
    }
  }
  if (removed) openvdb::tools::pruneInactive(hits.tree());
}

void countHits(const PointCloud& points_S, const Pose3d& T_W_S, const TsdfConfig& tsdf,
               const IntegratorConfig& integrator, openvdb::Int64Grid& hits, std::int64_t sign) {
  const EndVoxels ends(tsdf, integrator);
  const Eigen::Matrix3d R = T_W_S.linear();
  const Vec3d t = T_W_S.translation();
  std::vector<HitRun> runs =
      chunkRuns(points_S.size(), [&](std::size_t begin, std::size_t end, std::vector<HitRun>& out) {
        for (std::size_t i = begin; i < end; ++i) {
          const Vec3d p = points_S[i].cast<double>();
          if (ends.isSurface(p)) appendHit(out, ends.key(p, R, t), sign);
        }
      });
  applyHitRuns(runs, hits);
}

void moveHits(const PointCloud& points_S, const Pose3d& T_W_S_old, const Pose3d& T_W_S_new, const TsdfConfig& tsdf,
              const IntegratorConfig& integrator, openvdb::Int64Grid& hits) {
  const EndVoxels ends(tsdf, integrator);
  const Eigen::Matrix3d R_old = T_W_S_old.linear(), R_new = T_W_S_new.linear();
  const Vec3d t_old = T_W_S_old.translation(), t_new = T_W_S_new.translation();
  std::vector<HitRun> runs =
      chunkRuns(points_S.size(), [&](std::size_t begin, std::size_t end, std::vector<HitRun>& out) {
        std::vector<HitRun> added;  // kept apart from the removals, so that each side stays run-length coded
        for (std::size_t i = begin; i < end; ++i) {
          const Vec3d p = points_S[i].cast<double>();
          if (!ends.isSurface(p)) continue;
          const std::uint64_t from = ends.key(p, R_old, t_old), to = ends.key(p, R_new, t_new);
          if (from == to) continue;
          appendHit(out, from, -1);
          appendHit(added, to, +1);
        }
        out.insert(out.end(), added.begin(), added.end());
      });
  applyHitRuns(runs, hits);
}

}  // namespace vdbmap::internal
