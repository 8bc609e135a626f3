#include "vdbmap/keyframe_store.hpp"

#include "internal/depth_codes.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <libdeflate.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>

namespace vdbmap {
namespace {

struct DeflateDeleter {
  void operator()(libdeflate_compressor* c) const { libdeflate_free_compressor(c); }
  void operator()(libdeflate_decompressor* d) const { libdeflate_free_decompressor(d); }
};

/// A zlib stream (RFC 1950) of the bytes, as zlib's compress2 writes one, by libdeflate (level 1):
/// about 3x faster both ways here, and any zlib reads what it writes.
std::vector<std::uint8_t> deflateBytes(const void* data, std::size_t n) {
  thread_local const std::unique_ptr<libdeflate_compressor, DeflateDeleter> compressor(libdeflate_alloc_compressor(1));
  if (!compressor) throw std::bad_alloc();
  std::vector<std::uint8_t> out(libdeflate_zlib_compress_bound(compressor.get(), n));
  const std::size_t size = libdeflate_zlib_compress(compressor.get(), data, n, out.data(), out.size());
  if (size == 0) throw std::runtime_error("keyframe store: compression failed");
  out.resize(size);
  out.shrink_to_fit();
  return out;
}

std::vector<std::uint8_t> rawBytes(const void* data, std::size_t n) {
  const auto* bytes = static_cast<const std::uint8_t*>(data);
  return std::vector<std::uint8_t>(bytes, bytes + n);
}

void inflateBytes(const std::vector<std::uint8_t>& in, void* out, std::size_t n, bool compressed) {
  if (!compressed) {
    if (in.size() != n) throw std::runtime_error("keyframe store: corrupt frame");
    std::memcpy(out, in.data(), n);
    return;
  }
  thread_local const std::unique_ptr<libdeflate_decompressor, DeflateDeleter> decompressor(
      libdeflate_alloc_decompressor());
  if (!decompressor) throw std::bad_alloc();
  // Exactly n bytes, and the whole input one zlib stream.
  std::size_t used = 0, made = 0;
  if (libdeflate_zlib_decompress_ex(decompressor.get(), in.data(), in.size(), out, n, &used, &made) !=
          LIBDEFLATE_SUCCESS ||
      made != n || used != in.size())
    throw std::runtime_error("keyframe store: corrupt compressed frame");
}

constexpr std::int32_t kInvalidPoint = std::numeric_limits<std::int32_t>::min();
/// A point's codes (kInvalidPoint in all three when it is not finite or too far for 32 bits).
inline std::array<std::int32_t, 3> pointCodes(const Vec3f& p, double unit_m) {
  const double limit = double(std::numeric_limits<std::int32_t>::max()) * unit_m;
  if (!(p.allFinite() && p.cast<double>().cwiseAbs().maxCoeff() < limit))
    return {kInvalidPoint, kInvalidPoint, kInvalidPoint};
  std::array<std::int32_t, 3> q;
  for (int a = 0; a < 3; ++a) q[std::size_t(a)] = std::int32_t(std::lround(double(p[a]) / unit_m));
  return q;
}
/// The point every decode gives for codes.
inline Vec3f codesPoint(const std::int32_t* q, double unit_m) {
  if (q[0] == kInvalidPoint) return Vec3f::Constant(std::numeric_limits<float>::quiet_NaN());
  return Vec3f(float(q[0] * unit_m), float(q[1] * unit_m), float(q[2] * unit_m));
}

void checkDepthEncoding(const char* who, const DepthImage& depth, const CameraIntrinsics* K, double depth_unit_m,
                        int stride) {
  const auto fail = [who](const std::string& what) { throw std::invalid_argument(std::string(who) + ": " + what); };
  if (!K) fail("intrinsics are required");
  checkDepthImageSize(depth, *K, who);
  if (!(depth_unit_m > 0.0)) fail("depth_unit_m must be > 0");
  if (stride < 1) fail("stride must be >= 1");
}

/// Row-delta codes of a depth image (rows coded independently, so in parallel); also the decoded
/// image into *decoded when given.
std::vector<std::uint16_t> deltaCodes(const DepthImage& depth, double unit_m, DepthImage* decoded) {
  std::vector<std::uint16_t> coded(depth.depth_m.size());
  tbb::parallel_for(tbb::blocked_range<int>(0, depth.height), [&](const tbb::blocked_range<int>& rows) {
    std::vector<std::uint16_t> q(std::size_t(depth.width));
    for (int v = rows.begin(); v != rows.end(); ++v) {
      const std::size_t row = std::size_t(v) * std::size_t(depth.width);
      internal::depthCodes(depth.depth_m.data() + row, q.size(), unit_m, q.data());
      std::uint16_t prev = 0;
      for (std::size_t u = 0; u < q.size(); ++u) {
        coded[row + u] = std::uint16_t(q[u] - prev);
        prev = q[u];
      }
      if (decoded) internal::codeDepths(q.data(), q.size(), unit_m, decoded->depth_m.data() + row);
    }
  });
  return coded;
}

}  // namespace

EncodedFrame EncodedFrame::fromDepth(const DepthImage& depth, std::shared_ptr<const CameraIntrinsics> K,
                                     double depth_unit_m, int stride, bool compress) {
  return depthFrame(depth, std::move(K), depth_unit_m, stride, compress, nullptr);
}

EncodedFrame EncodedFrame::depthFrame(const DepthImage& depth, std::shared_ptr<const CameraIntrinsics> K,
                                      double depth_unit_m, int stride, bool compress, DepthImage* decoded) {
  checkDepthEncoding("EncodedFrame::fromDepth", depth, K.get(), depth_unit_m, stride);
  EncodedFrame f;
  f.kind_ = Kind::Depth;
  f.intrinsics_ = std::move(K);
  f.unit_m_ = depth_unit_m;
  f.stride_ = stride;
  f.count_ = std::uint32_t(depth.depth_m.size());
  // Row-delta coding: neighbouring depths are close, so the differences compress well.
  const std::vector<std::uint16_t> coded = deltaCodes(depth, depth_unit_m, decoded);
  f.compressed_ = compress;
  const std::size_t n = coded.size() * sizeof(std::uint16_t);
  f.payload_ = compress ? deflateBytes(coded.data(), n) : rawBytes(coded.data(), n);
  return f;
}

EncodedFrame EncodedFrame::fromPoints(const PointCloud& points_S, double unit_m, bool compress) {
  if (!(unit_m > 0.0)) throw std::invalid_argument("EncodedFrame::fromPoints: unit_m must be > 0");
  EncodedFrame f;
  f.kind_ = Kind::Points;
  f.unit_m_ = unit_m;
  f.count_ = std::uint32_t(points_S.size());
  std::vector<std::int32_t> q(points_S.size() * 3);
  for (std::size_t i = 0; i < points_S.size(); ++i) {
    const std::array<std::int32_t, 3> c = pointCodes(points_S[i], unit_m);
    std::copy(c.begin(), c.end(), q.begin() + std::ptrdiff_t(3 * i));
  }
  f.compressed_ = compress;
  const std::size_t n = q.size() * sizeof(std::int32_t);
  f.payload_ = compress ? deflateBytes(q.data(), n) : rawBytes(q.data(), n);
  return f;
}

EncodedFrame EncodedFrame::encode(const SensorFrame& frame, double unit_m, bool compress) {
  return frame.isDepth() ? fromDepth(frame.depthImage(), frame.sharedIntrinsics(), unit_m, 1, compress)
                         : fromPoints(frame.points_S(), unit_m, compress);
}

EncodedFrame EncodedFrame::encodeRaw(const SensorFrame& frame, double unit_m, SensorFrame& decoded) {
  if (!frame.isDepth()) {
    EncodedFrame f = fromPoints(frame.points_S(), unit_m, false);
    decoded = SensorFrame::points(f.decode());
    return f;
  }
  const DepthImage& depth = frame.depthImage();
  DepthImage image(depth.width, depth.height, 0.0f);
  EncodedFrame f = depthFrame(depth, frame.sharedIntrinsics(), unit_m, 1, false, &image);
  decoded = SensorFrame::depth(std::move(image), f.intrinsics_);
  return f;
}

SensorFrame EncodedFrame::quantize(const SensorFrame& frame, double unit_m) {
  if (!(unit_m > 0.0)) throw std::invalid_argument("EncodedFrame::quantize: unit_m must be > 0");
  if (!frame.isDepth()) {
    const PointCloud& in = frame.points_S();
    PointCloud points(in.size());
    for (std::size_t i = 0; i < in.size(); ++i) points[i] = codesPoint(pointCodes(in[i], unit_m).data(), unit_m);
    return SensorFrame::points(std::move(points));
  }
  const DepthImage& depth = frame.depthImage();
  checkDepthEncoding("EncodedFrame::quantize", depth, frame.sharedIntrinsics().get(), unit_m, 1);
  DepthImage image(depth.width, depth.height, 0.0f);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, depth.depth_m.size(), 16384), [&](const auto& r) {
    constexpr std::size_t kBatch = 256;
    std::uint16_t q[kBatch];
    for (std::size_t i = r.begin(); i < r.end(); i += kBatch) {
      const std::size_t n = std::min(kBatch, r.end() - i);
      internal::depthCodes(depth.depth_m.data() + i, n, unit_m, q);
      internal::codeDepths(q, n, unit_m, image.depth_m.data() + i);
    }
  });
  return SensorFrame::depth(std::move(image), frame.sharedIntrinsics());
}

EncodedFrame EncodedFrame::compressed() const {
  if (compressed_) return *this;
  EncodedFrame f;
  f.kind_ = kind_;
  f.intrinsics_ = intrinsics_;
  f.unit_m_ = unit_m_;
  f.stride_ = stride_;
  f.count_ = count_;
  f.compressed_ = true;
  f.payload_ = deflateBytes(payload_.data(), payload_.size());
  return f;
}

SensorFrame EncodedFrame::decodeFrame() const {
  return isDepth() ? SensorFrame::depth(decodeDepth(), intrinsics_) : SensorFrame::points(decode());
}

DepthImage EncodedFrame::decodeDepth() const {
  if (kind_ != Kind::Depth) throw std::logic_error("EncodedFrame::decodeDepth: the frame holds points, not depth");
  std::vector<std::uint16_t> coded(count_);
  inflateBytes(payload_, coded.data(), coded.size() * sizeof(std::uint16_t), compressed_);
  DepthImage depth(intrinsics_->width, intrinsics_->height, 0.0f);
  tbb::parallel_for(tbb::blocked_range<int>(0, depth.height), [&](const tbb::blocked_range<int>& rows) {
    for (int v = rows.begin(); v != rows.end(); ++v) {
      std::uint16_t* q = coded.data() + std::size_t(v) * std::size_t(depth.width);
      for (int u = 1; u < depth.width; ++u) q[u] = std::uint16_t(q[u - 1] + q[u]);  // row deltas to codes
      internal::codeDepths(q, std::size_t(depth.width), unit_m_,
                           depth.depth_m.data() + std::size_t(v) * std::size_t(depth.width));
    }
  });
  return depth;
}

PointCloud EncodedFrame::decode() const {
  if (kind_ == Kind::Depth) return backProject(decodeDepth(), *intrinsics_, stride_);
  std::vector<std::int32_t> q(std::size_t(count_) * 3);
  inflateBytes(payload_, q.data(), q.size() * sizeof(std::int32_t), compressed_);
  PointCloud points(count_);
  for (std::size_t i = 0; i < count_; ++i) points[i] = codesPoint(&q[3 * i], unit_m_);
  return points;
}

Keyframe& KeyframeStore::add(Keyframe keyframe) {
  const FrameId id = keyframe.id;
  const auto [it, inserted] = frames_.emplace(id, std::move(keyframe));
  if (!inserted) throw std::invalid_argument("keyframe store: frame " + std::to_string(id) + " is already stored");
  return it->second;
}

Keyframe& KeyframeStore::at(FrameId id) {
  const auto it = frames_.find(id);
  if (it == frames_.end()) throw std::out_of_range("keyframe store: no frame " + std::to_string(id));
  return it->second;
}

const Keyframe& KeyframeStore::at(FrameId id) const { return const_cast<KeyframeStore*>(this)->at(id); }

std::size_t KeyframeStore::bytes() const {
  std::size_t total = 0;
  for (const auto& [id, kf] : frames_) total += sizeof(Keyframe) + kf.data.bytes();
  return total;
}

}  // namespace vdbmap
