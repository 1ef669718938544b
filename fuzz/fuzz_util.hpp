#pragma once
// Shared by the libFuzzer targets: most readers take a path, so an input is written to a
// scratch folder (one per process, emptied per input) and the real reader is called on it.
// Readers of a folder layout get a "bundle": the input split at kBundleSeparator lines, part
// i becoming the layout's i-th file (a missing part: no file), so one input covers the list
// files of a sequence together.
//
// Only locard::Error (InputError and the other documented types) is an expected outcome;
// anything else escapes LLVMFuzzerTestOneInput and libFuzzer reports it as a finding.

#include <locard/core/error.hpp>
#include <locard/io/image_io.hpp>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <string_view>
#include <unistd.h>
#include <vector>

namespace locard_fuzz {

namespace fs = std::filesystem;

inline constexpr std::string_view kBundleSeparator = "\n--8<--\n";

// A scratch folder for this process, removed at exit; clean() empties it before each input.
class Scratch {
 public:
  Scratch() {
    std::string pattern = (fs::temp_directory_path() / "locard-fuzz-XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) std::abort();
    root_ = pattern;
  }
  ~Scratch() {
    std::error_code ec;
    fs::remove_all(root_, ec);
  }
  Scratch(const Scratch&) = delete;
  Scratch& operator=(const Scratch&) = delete;
  const fs::path& root() const { return root_; }
  // An empty folder `name` inside the scratch folder (its parent holds nothing else, since
  // some layouts look one folder up too).
  fs::path fresh(const std::string& name = "input") const {
    std::error_code ec;
    for (const auto& entry : fs::directory_iterator(root_)) fs::remove_all(entry.path(), ec);
    fs::create_directories(root_ / name);
    return root_ / name;
  }

 private:
  fs::path root_;
};

inline Scratch& scratch() {
  static Scratch s;
  return s;
}

inline void write_file(const fs::path& path, std::string_view bytes) {
  fs::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out) std::abort();  // the scratch disk, not the reader: stop loudly
}

inline std::string_view as_text(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

inline std::vector<std::string_view> split_bundle(std::string_view text) {
  std::vector<std::string_view> parts;
  for (;;) {
    const auto at = text.find(kBundleSeparator);
    parts.push_back(text.substr(0, at));
    if (at == std::string_view::npos) return parts;
    text.remove_prefix(at + kBundleSeparator.size());
  }
}

// Writes part i of the input to folder/names[i] (parts beyond the names are ignored).
inline void write_bundle(const fs::path& folder, std::string_view text,
                         const std::vector<std::string>& names) {
  const auto parts = split_bundle(text);
  for (std::size_t i = 0; i < parts.size() && i < names.size(); ++i)
    write_file(folder / names[i], parts[i]);
}

// Valid 4x3 PNGs (8-bit RGB colour, 16-bit depth) for the frames a sequence layout names, made
// once with Locard's own writer and kept as bytes.
inline const std::string& tiny_png(bool depth) {
  static const auto make = [](bool is_depth) {
    const fs::path path = scratch().root() / (is_depth ? "template-depth.png" : "template-color.png");
    if (is_depth) locard::write_png(path, locard::DepthImage(4, 3, 1000));
    else locard::write_png(path, locard::ColorImage(4, 3, 128));
    std::ifstream in(path, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    fs::remove(path);
    return bytes;
  };
  static const std::string color = make(false), depth_png = make(true);
  return depth ? depth_png : color;
}

// Runs the reader; locard's documented errors are expected outcomes, nothing else is.
// LOCARD_FUZZ_VERBOSE=1 prints each error (to see what a seed or a finding reaches).
template <typename Reader>
void expect_documented_errors(Reader&& reader) {
  static const bool verbose = std::getenv("LOCARD_FUZZ_VERBOSE") != nullptr;
  try {
    reader();
    if (verbose) std::fprintf(stderr, "locard-fuzz: read\n");
  } catch (const locard::Error& e) {
    if (verbose) std::fprintf(stderr, "locard-fuzz: %s\n", e.what());
  }
}

}  // namespace locard_fuzz
