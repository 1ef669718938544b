#pragma once
// A dense, row-major, interleaved image. Small and value-semantic on purpose: readers fill it,
// kernels read it through row pointers.

#include <cstddef>
#include <cstdint>
#include <vector>

namespace locard {

template <typename T, int Channels>
class Image {
 public:
  using value_type = T;
  static constexpr int channels = Channels;

  Image() = default;
  Image(int width, int height, T fill = T{})
      : width_(width), height_(height),
        data_(static_cast<std::size_t>(width) * height * Channels, fill) {}

  int width() const { return width_; }
  int height() const { return height_; }
  bool empty() const { return data_.empty(); }
  std::size_t pixel_count() const { return static_cast<std::size_t>(width_) * height_; }

  T* row(int v) { return data_.data() + static_cast<std::size_t>(v) * width_ * Channels; }
  const T* row(int v) const {
    return data_.data() + static_cast<std::size_t>(v) * width_ * Channels;
  }
  T& at(int u, int v, int c = 0) { return row(v)[u * Channels + c]; }
  const T& at(int u, int v, int c = 0) const { return row(v)[u * Channels + c]; }

  std::vector<T>& data() { return data_; }
  const std::vector<T>& data() const { return data_; }
  bool operator==(const Image&) const = default;

 private:
  int width_ = 0;
  int height_ = 0;
  std::vector<T> data_;
};

using ColorImage = Image<std::uint8_t, 3>;   // RGB8
using GrayImage = Image<std::uint8_t, 1>;    // 8-bit single channel
using DepthImage = Image<std::uint16_t, 1>;  // raw depth units, 0 = no measurement

}  // namespace locard
