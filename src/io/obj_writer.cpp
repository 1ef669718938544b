// write_obj: Wavefront OBJ + MTL + PNG. The colour goes twice: as the "v x y z r g b" extension
// (Blender, MeshLab, assimp read it) and baked into a texture atlas (texture_atlas.hpp) with a
// `vt` per triangle corner and `map_Kd` in the MTL, for the tools that read only textures
// (CloudCompare, Unity). Axes by MeshExportOptions::up (OBJ has no way to say which).
#include "mesh_export_detail.hpp"
#include "texture_atlas.hpp"

#include <locard/core/atomic_file.hpp>
#include <locard/core/error.hpp>
#include <locard/io/image_io.hpp>
#include <locard/io/mesh_export.hpp>

#include <fmt/format.h>

#include <fstream>
#include <iterator>
#include <string>

namespace locard {
namespace {

namespace fs = std::filesystem;

// Writes what it is given in 1 MiB pieces, so a large mesh never sits twice in memory.
class ChunkedWriter {
 public:
  explicit ChunkedWriter(std::ofstream& out) : out_(out) { buffer_.reserve(kChunk); }
  ~ChunkedWriter() { flush(); }
  ChunkedWriter(const ChunkedWriter&) = delete;
  ChunkedWriter& operator=(const ChunkedWriter&) = delete;
  template <typename... Args>
  void print(fmt::format_string<Args...> format, Args&&... args) {
    fmt::format_to(std::back_inserter(buffer_), format, std::forward<Args>(args)...);
    if (buffer_.size() > kChunk - 256) flush();
  }
  void flush() {
    out_.write(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
    buffer_.clear();
  }

 private:
  static constexpr std::size_t kChunk = 1 << 20;
  std::ofstream& out_;
  std::string buffer_;
};

void write_mtl_text(std::ofstream& out, const std::string& texture) {
  // Kd multiplies the texture: white keeps the observed colours, magenta tints inferred ones.
  for (const auto& [name, kd] : {std::pair{"observed", "1 1 1"}, std::pair{"inferred", "1 0 1"}})
    out << fmt::format("newmtl {}\nKa 0 0 0\nKd {}\nKs 0 0 0\nd 1\nillum 1\nmap_Kd {}\n\n", name,
                       kd, texture);
}

void write_obj_text(std::ofstream& stream, const TriangleMesh& mesh,
                    const MeshExportOptions& options, const detail::TextureAtlas& atlas,
                    const std::string& mtl_name) {
  ChunkedWriter out(stream);
  out.print("# Locard {} mesh: {} vertices, {} triangles; metres, {}-up{}; colour as a texture "
            "atlas and as vertex colours (v x y z r g b)\nmtllib {}\no locard_mesh\n",
            LOCARD_VERSION, mesh.vertices.size(), mesh.triangles.size(), to_string(options.up),
            options.up == UpAxis::Y ? " (Locard z-up turned -90 degrees about x)" : "", mtl_name);
  const std::vector<Rgb8> colors = detail::export_colors(mesh, options);
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Eigen::Vector3f p = detail::to_file_axes(mesh.vertices[i], options.up);
    const Rgb8 c = colors[i];
    out.print("v {} {} {} {} {} {}\n", p.x(), p.y(), p.z(), c.r / 255.f, c.g / 255.f, c.b / 255.f);
  }
  for (const auto& corners : atlas.uv)
    for (const Eigen::Vector2f& uv : corners) out.print("vt {} {}\n", uv.x(), uv.y());
  for (int inferred = 0; inferred < 2; ++inferred) {
    bool header = false;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      if (detail::is_inferred(options, t) != (inferred == 1)) continue;
      if (!header) {
        const char* name = inferred ? "inferred" : "observed";
        out.print("g {}\nusemtl {}\n", name, name);
        header = true;
      }
      const auto& v = mesh.triangles[t];
      const std::size_t vt = 3 * t + 1;  // 1-based, three per triangle
      out.print("f {}/{} {}/{} {}/{}\n", v[0] + 1, vt, v[1] + 1, vt + 1, v[2] + 1, vt + 2);
    }
  }
}

}  // namespace

std::vector<fs::path> write_obj(const fs::path& path, const TriangleMesh& mesh,
                                const MeshExportOptions& options) {
  detail::check_mesh_for_export(mesh, options, path);
  fs::path mtl_path = path, png_path = path;
  mtl_path.replace_extension(".mtl");
  png_path.replace_extension(".png");
  const detail::TextureAtlas atlas = detail::bake_texture_atlas(mesh, detail::export_colors(mesh, options));
  // All three finished before any replaces its target: a failure leaves the old set or none.
  AtomicFile mtl(mtl_path, false);
  write_mtl_text(mtl.stream(), png_path.filename().string());
  mtl.finish();
  AtomicFile obj(path, false);
  write_obj_text(obj.stream(), mesh, options, atlas, mtl_path.filename().string());
  obj.finish();
  write_png(png_path, atlas.image);
  mtl.commit();
  obj.commit();
  return {path, mtl_path, png_path};
}

}  // namespace locard
