#include "internal/hit_counter.hpp"

#include "internal/prune_leaves.hpp"

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
#include <cmath>
#include <limits>
#include <optional>
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

/// One image row to count, and where: what every pixel kernel of countRowHits reads.
struct RowPixels {
  const float* z;  // the row's depths
  int width, v;
  const CameraIntrinsics& K;
  double inv_fx, inv_fy;
  const EndVoxels& ends;
  const std::vector<HitPose>& poses;  // one or two
  bool move;                          // two poses of opposite signs: skip points that stay in their voxel
  std::vector<HitRun>* runs;          // one list per pose
};

#if defined(__SSE2__)
/// Appends the points of lanes 0 and 1 in `surface` (bit l for lane l), keys[j][l] the voxel of
/// lane l's point at pose j, exactly as countPoint() does for each point in lane order.
inline void appendPair(const RowPixels& row, int surface, const std::uint64_t (&keys)[2][2]) {
  for (int l = 0; l < 2; ++l) {
    if (!(surface & (1 << l))) continue;
    if (row.move) {
      if (keys[0][l] == keys[1][l]) continue;
      appendHit(row.runs[0], keys[0][l], row.poses[0].sign);
      appendHit(row.runs[1], keys[1][l], row.poses[1].sign);
    } else {
      for (std::size_t j = 0; j < row.poses.size(); ++j) appendHit(row.runs[j], keys[j][l], row.poses[j].sign);
    }
  }
}

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

/// Counts pixels u, u + 1 in lanes 0 and 1 from `u` on while two remain; returns the first pixel
/// left. Each operation is the scalar path's, lane by lane: backProjectPixel's products rounded to
/// float, isSurface's (x^2 + y^2) + z^2 and key's sums. Valid pixels have finite points (max range
/// is finite, so an overflow to infinity fails the range test as allFinite would) and
/// r^2 >= z^2 > 0.
int countPixelsSse2(const RowPixels& row, int u) {
  const std::array<PoseLanes, 2> lanes{PoseLanes(row.poses[0]), PoseLanes(row.poses.back())};
  const __m128d cx = _mm_set1_pd(row.K.cx), ifx = _mm_set1_pd(row.inv_fx);
  const __m128d by = _mm_set1_pd((row.v - row.K.cy) * row.inv_fy);
  const __m128d min2 = _mm_set1_pd(row.ends.minRange2()), max2 = _mm_set1_pd(row.ends.maxRange2());
  const __m128d inv_voxel = _mm_set1_pd(row.ends.inverseVoxelSize());
  const auto roundToFloat = [](__m128d a) { return _mm_cvtps_pd(_mm_cvtpd_ps(a)); };
  const auto valid = [](float z) { return z > 0.0f && std::isfinite(z); };
  for (; u + 1 < row.width; u += 2) {
    const int ok = int(valid(row.z[u])) | int(valid(row.z[u + 1])) << 1;
    if (ok == 0) continue;
    const __m128d z = _mm_set_pd(double(row.z[u + 1]), double(row.z[u]));
    const __m128d a = _mm_mul_pd(_mm_sub_pd(_mm_set_pd(double(u + 1), double(u)), cx), ifx);
    const __m128d x = roundToFloat(_mm_mul_pd(a, z)), y = roundToFloat(_mm_mul_pd(by, z));
    const __m128d r2 = _mm_add_pd(_mm_add_pd(_mm_mul_pd(x, x), _mm_mul_pd(y, y)), _mm_mul_pd(z, z));
    const int surface = ok & _mm_movemask_pd(_mm_and_pd(_mm_cmpge_pd(r2, min2), _mm_cmple_pd(r2, max2)));
    if (surface == 0) continue;
    std::uint64_t keys[2][2];
    for (std::size_t j = 0; j < row.poses.size(); ++j) lanes[j].keys(x, y, z, inv_voxel, keys[j]);
    appendPair(row, surface, keys);
  }
  return u;
}
#endif

#if VDBMAP_AVX2_KERNELS
// The four-pixel kernel (internal/simd.hpp says why only these functions target AVX2).

/// A pose's rotation and translation, each coefficient in all four lanes (PoseLanes, wider).
struct PoseLanes4 {
  __m256d r[3][3], t[3];
};

VDBMAP_TARGET_AVX2 inline __m256i packField4(__m256d e) {
  const __m128i truncated = _mm256_cvttpd_epi32(e);
  const __m256d above = _mm256_cmp_pd(e, _mm256_cvtepi32_pd(truncated), _CMP_LT_OS);  // all ones: subtract 1
  // The low 32 bits of each 64-bit mask lane, as four 32-bit lanes.
  const __m128i above32 = _mm256_castsi256_si128(
      _mm256_permutevar8x32_epi32(_mm256_castpd_si256(above), _mm256_setr_epi32(0, 2, 4, 6, 0, 0, 0, 0)));
  const __m128i biased = _mm_add_epi32(_mm_add_epi32(truncated, above32), _mm_set1_epi32(1 << 20));
  return _mm256_cvtepu32_epi64(_mm_and_si128(biased, _mm_set1_epi32((1 << 21) - 1)));
}

VDBMAP_TARGET_AVX2 inline __m256i keys4(const PoseLanes4& p, __m256d x, __m256d y, __m256d z, __m256d inv_voxel) {
  const __m256d half = _mm256_set1_pd(0.5);
  __m256i field[3];
  for (int i = 0; i < 2; ++i) {
    const __m256d s = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(p.r[i][0], x), _mm256_mul_pd(p.r[i][1], y)),
                                    _mm256_mul_pd(p.r[i][2], z));
    field[i] = packField4(_mm256_add_pd(_mm256_mul_pd(_mm256_add_pd(s, p.t[i]), inv_voxel), half));
  }
  const __m256d s = _mm256_add_pd(_mm256_mul_pd(p.r[2][0], x),
                                  _mm256_add_pd(_mm256_mul_pd(p.r[2][1], y), _mm256_mul_pd(p.r[2][2], z)));
  field[2] = packField4(_mm256_add_pd(_mm256_mul_pd(_mm256_add_pd(s, p.t[2]), inv_voxel), half));
  return _mm256_or_si256(_mm256_or_si256(_mm256_slli_epi64(field[0], 42), _mm256_slli_epi64(field[1], 21)), field[2]);
}

/// Bit l set where 64-bit lanes l of a and b are equal.
VDBMAP_TARGET_AVX2 inline int equalLanes(__m256i a, __m256i b) {
  return _mm256_movemask_pd(_mm256_castsi256_pd(_mm256_cmpeq_epi64(a, b)));
}

/// Tables for appending up to four points without a branch. For a bit set s of four lanes:
/// `gather[s]`, the permutevar8x32 indices that bring the lanes in s (64-bit keys) to the front in
/// order. For the first c lanes of which those in s start a run: `before_first[c][s]`, how many
/// come before the first start (they add to the run before them), and `length[c][s]`, the lengths
/// of the runs the starts begin.
struct RunTables {
  std::int32_t gather[16][8];
  std::int64_t before_first[5][16];
  std::int64_t length[5][16][4];
};
constexpr RunTables makeRunTables() {
  RunTables t{};
  for (int s = 0; s < 16; ++s) {
    int n = 0;
    for (int l = 0; l < 4; ++l)
      if (s & (1 << l)) {
        t.gather[s][2 * n] = 2 * l;
        t.gather[s][2 * n + 1] = 2 * l + 1;
        ++n;
      }
    for (int c = 0; c <= 4; ++c) {
      if (s >> c) continue;  // starts lie among the first c lanes
      int first = c, m = 0;
      for (int l = 0; l < c; ++l) {
        if (!(s & (1 << l))) continue;
        if (first == c) first = l;
        int next = l + 1;
        while (next < c && !(s & (1 << next))) ++next;
        t.length[c][s][m++] = next - l;
      }
      t.before_first[c][s] = first;
    }
  }
  return t;
}
inline constexpr RunTables kRunTables = makeRunTables();

/// One pose's runs of a row, written through a pointer into a scratch buffer with room for a run
/// per pixel and four more, then appended to the pose's list by finish(). Its first run is the
/// list's last, which the row may continue, or a placeholder with a key no voxel has (packVoxel
/// uses 63 bits).
class RowRuns {
 public:
  RowRuns(std::vector<HitRun>& list, std::vector<HitRun>& scratch, int width) : list_(list) {
    if (scratch.size() < std::size_t(width) + 5) scratch.resize(std::size_t(width) + 5);
    first_ = back_ = scratch.data();
    if (list.empty()) {
      *back_ = {kNoKey, 0};
    } else {
      *back_ = list.back();
      list.pop_back();
    }
  }
  RowRuns(const RowRuns&) = delete;
  RowRuns& operator=(const RowRuns&) = delete;

  /// Appends the row's runs to the list; the writer is done.
  void finish() { list_.insert(list_.end(), first_ + (first_->key == kNoKey ? 1 : 0), back_ + 1); }

  /// The points of the lanes in `lanes` (bit l: lane l), in lane order, counted with `sign` (+1
  /// or -1): what appendHit() per point does, without a branch per point. The lanes' keys are packed
  /// to the front; a packed lane starts a run where its key differs from the one before it (the
  /// first: from the last run).
  VDBMAP_TARGET_AVX2 void addLanes(__m256i key, int lanes, std::int64_t sign) {
    const RunTables& t = kRunTables;
    const int c = __builtin_popcount(unsigned(lanes));
    const __m256i packed =
        _mm256_permutevar8x32_epi32(key, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(t.gather[lanes])));
    const __m256i before = _mm256_blend_epi32(_mm256_permute4x64_epi64(packed, _MM_SHUFFLE(2, 1, 0, 0)),
                                              _mm256_set1_epi64x(std::int64_t(back_->key)), 0x03);
    const int starts = ~equalLanes(packed, before) & ((1 << c) - 1);
    back_->count += t.before_first[c][starts] * sign;
    const __m256i keys =
        _mm256_permutevar8x32_epi32(packed, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(t.gather[starts])));
    __m256i counts = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(t.length[c][starts]));
    if (sign < 0) counts = _mm256_sub_epi64(_mm256_setzero_si256(), counts);
    // (key, count) of up to four new runs, written whole; the first popcount(starts) are kept.
    const __m256i lo = _mm256_unpacklo_epi64(keys, counts), hi = _mm256_unpackhi_epi64(keys, counts);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(back_ + 1), _mm256_permute2x128_si256(lo, hi, 0x20));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(back_ + 3), _mm256_permute2x128_si256(lo, hi, 0x31));
    back_ += __builtin_popcount(unsigned(starts));
  }

 private:
  static constexpr std::uint64_t kNoKey = ~std::uint64_t(0);
  std::vector<HitRun>& list_;
  HitRun* first_;
  HitRun* back_;
};

/// countPixelsSse2 four pixels at a time, lane for lane the same operations; poses' signs +1 or -1.
VDBMAP_TARGET_AVX2 int countPixelsAvx2(const RowPixels& row, int u) {
  PoseLanes4 lanes[2];
  for (std::size_t j = 0; j < row.poses.size(); ++j)
    for (int i = 0; i < 3; ++i) {
      for (int k = 0; k < 3; ++k) lanes[j].r[i][k] = _mm256_set1_pd(row.poses[j].R(i, k));
      lanes[j].t[i] = _mm256_set1_pd(row.poses[j].t[i]);
    }
  const __m256d cx = _mm256_set1_pd(row.K.cx), ifx = _mm256_set1_pd(row.inv_fx);
  const __m256d by = _mm256_set1_pd((row.v - row.K.cy) * row.inv_fy);
  const __m256d min2 = _mm256_set1_pd(row.ends.minRange2()), max2 = _mm256_set1_pd(row.ends.maxRange2());
  const __m256d inv_voxel = _mm256_set1_pd(row.ends.inverseVoxelSize());
  const __m256d lane_u = _mm256_setr_pd(0.0, 1.0, 2.0, 3.0);
  const __m128 zero = _mm_setzero_ps(), inf = _mm_set1_ps(std::numeric_limits<float>::infinity());
  thread_local std::vector<HitRun> scratch[2];
  std::optional<RowRuns> writer_storage[2];
  RowRuns* writers[2] = {nullptr, nullptr};
  for (std::size_t j = 0; j < row.poses.size(); ++j)
    writers[j] = &writer_storage[j].emplace(row.runs[j], scratch[j], row.width);
  for (; u + 3 < row.width; u += 4) {
    // Valid: above 0 and below infinity, which is finite and positive (NaN fails both).
    const __m128 zf = _mm_loadu_ps(row.z + u);
    const int ok = _mm_movemask_ps(_mm_and_ps(_mm_cmpgt_ps(zf, zero), _mm_cmplt_ps(zf, inf)));
    if (ok == 0) continue;
    const __m256d z = _mm256_cvtps_pd(zf);
    const __m256d a = _mm256_mul_pd(_mm256_sub_pd(_mm256_add_pd(_mm256_set1_pd(double(u)), lane_u), cx), ifx);
    const __m256d x = _mm256_cvtps_pd(_mm256_cvtpd_ps(_mm256_mul_pd(a, z)));
    const __m256d y = _mm256_cvtps_pd(_mm256_cvtpd_ps(_mm256_mul_pd(by, z)));
    const __m256d r2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(x, x), _mm256_mul_pd(y, y)), _mm256_mul_pd(z, z));
    int surface = ok & _mm256_movemask_pd(
                           _mm256_and_pd(_mm256_cmp_pd(r2, min2, _CMP_GE_OS), _mm256_cmp_pd(r2, max2, _CMP_LE_OS)));
    if (surface == 0) continue;
    const std::size_t P = row.poses.size();
    __m256i key[2] = {_mm256_setzero_si256(), _mm256_setzero_si256()};
    for (std::size_t j = 0; j < P; ++j) key[j] = keys4(lanes[j], x, y, z, inv_voxel);
    if (row.move) {
      surface &= ~equalLanes(key[0], key[1]);  // points that stay in their voxel are skipped
      if (surface == 0) continue;
    }
    // Points that stay are already dropped from `surface`, so a move adds like two placements.
    for (std::size_t j = 0; j < P; ++j) writers[j]->addLanes(key[j], surface, row.poses[j].sign);
  }
  for (std::size_t j = 0; j < row.poses.size(); ++j) writers[j]->finish();
  return u;
}
#endif

}  // namespace

void countRowHits(const DepthImage& depth_m, int v, const CameraIntrinsics& K, const EndVoxels& ends,
                  const std::vector<HitPose>& poses, std::vector<HitRun>* runs, SimdLevel level) {
  RowPixels row{depth_m.depth_m.data() + std::size_t(v) * std::size_t(depth_m.width),
                depth_m.width,
                v,
                K,
                1.0 / K.fx,
                1.0 / K.fy,
                ends,
                poses,
                poses.size() == 2 && poses[0].sign == -poses[1].sign,
                runs};
  int u = 0;
  if (!poses.empty() && poses.size() <= 2) {
#if VDBMAP_AVX2_KERNELS
    // The four-pixel kernel negates counts rather than multiplying them: signs of +1 or -1 (every
    // placement the integrator counts with).
    const bool unit_signs =
        std::all_of(poses.begin(), poses.end(), [](const HitPose& p) { return p.sign == 1 || p.sign == -1; });
    if (level == SimdLevel::Avx2 && unit_signs) u = countPixelsAvx2(row, u);
#endif
#if defined(__SSE2__)
    if (level != SimdLevel::Scalar) u = countPixelsSse2(row, u);
#endif
  }
  const auto valid = [](float z) { return z > 0.0f && std::isfinite(z); };
  for (; u < row.width; ++u)
    if (valid(row.z[u]))
      countPoint(backProjectPixel(u, v, row.z[u], K, row.inv_fx, row.inv_fy).cast<double>(), ends, poses, row.move,
                 runs);
}

void compactHitRuns(std::vector<HitRun>& runs) {
  // Hashed, not sorted: a voxel's runs merge into its first one, in place (a voxel's dense index
  // never exceeds the position of its first run).
  KeyIndex index(runs.size() / 2 + 16);  // room for most runs being distinct voxels: rarely regrown
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

void applyHitRuns(const std::vector<HitRun>& runs, openvdb::Int64Grid& hits) {
  // The runs by leaf (a voxel key less its low three bits per axis: the bias is a multiple of 8).
  // Consecutive runs mostly share a leaf, so the last one is checked before the index.
  constexpr std::uint64_t kLeafKey = ~((std::uint64_t(7) << 42) | (std::uint64_t(7) << 21) | std::uint64_t(7));
  KeyIndex index(runs.size() / 16 + 16);
  std::vector<std::uint64_t> leaf_keys;
  std::vector<std::uint32_t> leaf_of(runs.size());
  std::uint64_t last_key = ~std::uint64_t(0);
  std::uint32_t last = 0;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const std::uint64_t key = runs[i].key & kLeafKey;
    if (key != last_key) {
      bool inserted = false;
      last = index.findOrInsert(key, inserted);
      if (inserted) leaf_keys.push_back(key);
      last_key = key;
    }
    leaf_of[i] = last;
  }
  // Each leaf's runs together (counting sort), and the leaves: found or, serially, created.
  std::vector<std::uint32_t> first(leaf_keys.size() + 1, 0), order(runs.size());
  for (const std::uint32_t l : leaf_of) ++first[l + 1];
  for (std::size_t l = 0; l < leaf_keys.size(); ++l) first[l + 1] += first[l];
  std::vector<std::uint32_t> next(first.begin(), first.end() - 1);
  for (std::size_t i = 0; i < runs.size(); ++i) order[next[leaf_of[i]]++] = std::uint32_t(i);
  std::vector<Int64Leaf*> leaves(leaf_keys.size());
  {
    openvdb::Int64Grid::Accessor acc = hits.getAccessor();
    for (std::size_t l = 0; l < leaf_keys.size(); ++l) leaves[l] = acc.touchLeaf(unpackVoxel(leaf_keys[l]));
  }
  // Values and active states of distinct leaves, in parallel; a voxel whose count returns to 0 is
  // switched off (value 0) and its leaf pruned if that emptied it.
  std::vector<char> emptied(leaf_keys.size(), 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leaf_keys.size(), 64), [&](const auto& r) {
    for (std::size_t l = r.begin(); l != r.end(); ++l) {
      Int64Leaf& leaf = *leaves[l];
      std::int64_t* counts = leaf.buffer().data();
      std::array<std::uint64_t, Int64Leaf::SIZE / 64> touched{};
      for (std::uint32_t k = first[l]; k != first[l + 1]; ++k) {
        const HitRun& run = runs[order[k]];
        const openvdb::Index n = Int64Leaf::coordToOffset(unpackVoxel(run.key));
        counts[n] += run.count;
        touched[n >> 6] |= std::uint64_t(1) << (n & 63);
      }
      for (std::size_t word = 0; word < touched.size(); ++word)
        for (std::uint64_t bits = touched[word]; bits != 0; bits &= bits - 1) {
          const openvdb::Index n = openvdb::Index(word * 64 + std::size_t(__builtin_ctzll(bits)));
          leaf.setActiveState(n, counts[n] != 0);
          if (counts[n] == 0) emptied[l] = 1;
        }
    }
  });
  std::vector<openvdb::Coord> prune;
  for (std::size_t l = 0; l < leaf_keys.size(); ++l)
    if (emptied[l]) prune.push_back(unpackVoxel(leaf_keys[l]));
  pruneEmptiedLeaves(hits.tree(), std::move(prune));
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
