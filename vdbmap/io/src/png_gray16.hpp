// A fast decoder for the one PNG kind depth images come in: 16-bit gray, not interlaced (private to
// the io library).
//
// libpng decodes a 640 x 480 Kinect depth PNG in about 2.4 ms here, most of it in its generic
// Paeth filter (no vector path for 2-byte pixels) and in zlib's inflate: more than integrating the
// frame. This decoder inflates with libdeflate and undoes the filters with loops written for 2-byte
// pixels (about 1 ms). It decodes only files that are plainly right; for anything else it declines
// and the caller hands the file to libpng, whose diagnosis names what is wrong.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace vdbmap::io::internal {

/// Decodes a whole PNG file held in memory when it is a 16-bit gray, non-interlaced image, of
/// sides at most `max_side`, whose chunks all carry their right CRCs, with no critical chunk other
/// than IHDR, consecutive IDATs and IEND, and whose image data inflate to exactly the rows the
/// header declares (valid filter types, nothing after the zlib stream). Then `samples` holds
/// width * height values in host order and it returns true. Otherwise it returns false and leaves
/// the outputs unspecified; it never throws on bad data, and allocates no more than the header's
/// image (checked against `max_side`) and the file's size.
bool decodeGray16Png(const std::uint8_t* file, std::size_t size, std::uint32_t max_side, std::uint32_t& width,
                     std::uint32_t& height, std::vector<std::uint16_t>& samples);

}  // namespace vdbmap::io::internal
