#pragma once
// LZF, the byte-oriented LZ77 variant PCL uses for PCD "binary_compressed" bodies.
// Stream format (Marc Lehmann's liblzf), one control byte at a time:
//   000LLLLL                 literal run: the next L+1 bytes are copied as they are
//   LLLooooo oooooooo        back reference, L in 1..6: copy L+2 bytes from o+1 bytes back
//   111ooooo LLLLLLLL oooooooo  back reference of 7+L+2 bytes (up to 264)
// Back references may overlap the bytes they produce (run-length style).

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

namespace locard::lzf {

// Always succeeds; incompressible input grows by at most 1 byte in 32 (+1).
std::vector<std::uint8_t> compress(const std::uint8_t* data, std::size_t size);

// Decodes `size` bytes into exactly `expected` bytes. Returns std::nullopt (never reads or
// writes out of bounds) when the stream is corrupt or does not produce exactly `expected`.
std::optional<std::vector<std::uint8_t>> decompress(const std::uint8_t* data, std::size_t size,
                                                    std::size_t expected);

}  // namespace locard::lzf
