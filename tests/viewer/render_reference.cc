// The viewer test's reference frame (tests/viewer/viewer_run.sh): a glTF
// file (the session's export) imported by importers/, every primitive placed
// at its nodes' world matrices, drawn by the viewer's own renderer
// (examples/viewer/render.h) with the view-projection the viewer used, and
// compared with the viewer's last frame.
//
//   meshstream_viewer_reference FILE.glb --size WxH --view-projection M0,...,M15
//       --out REF.ppm [--compare FRAME.ppm --max-fraction F --channel-tolerance T]
//
// Prints one JSON line: the pixels compared, those differing by more than T in
// some channel, their fraction, the largest channel difference. Exit 0 when the
// fraction is at most F (or nothing is compared), 1 otherwise or on an error.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include "codec/mesh/scene_flatten.h"
#include "importers/import.h"
#include "render.h"

namespace {

bool ReadPpm(const std::string& path, int* width, int* height, std::vector<uint8_t>* rgb) {
  std::ifstream in(path, std::ios::binary);
  std::string magic;
  int max = 0;
  if (!(in >> magic >> *width >> *height >> max) || magic != "P6" || max != 255) return false;
  in.get();
  rgb->resize(static_cast<size_t>(*width) * *height * 3);
  in.read(reinterpret_cast<char*>(rgb->data()), static_cast<std::streamsize>(rgb->size()));
  return static_cast<size_t>(in.gcount()) == rgb->size();
}

int Fail(const std::string& message) {
  std::fprintf(stderr, "meshstream_viewer_reference: %s\n", message.c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  std::string file, out, compare;
  int width = 0, height = 0;
  float view_projection[16] = {};
  bool has_vp = false;
  double max_fraction = 0;
  int channel_tolerance = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const char* next = i + 1 < argc ? argv[i + 1] : nullptr;
    if (a == "--size" && next) {
      if (std::sscanf(next, "%dx%d", &width, &height) != 2 || width < 1 || height < 1) return Fail("--size: WxH");
      ++i;
    } else if (a == "--view-projection" && next) {
      std::stringstream ss(next);
      std::string item;
      int k = 0;
      while (std::getline(ss, item, ',') && k < 16) view_projection[k++] = std::strtof(item.c_str(), nullptr);
      if (k != 16) return Fail("--view-projection: 16 numbers");
      has_vp = true;
      ++i;
    } else if (a == "--out" && next) {
      out = argv[++i];
    } else if (a == "--compare" && next) {
      compare = argv[++i];
    } else if (a == "--max-fraction" && next) {
      max_fraction = std::atof(argv[++i]);
    } else if (a == "--channel-tolerance" && next) {
      channel_tolerance = std::atoi(argv[++i]);
    } else if (a[0] != '-' && file.empty()) {
      file = a;
    } else {
      return Fail("unknown or incomplete argument " + a);
    }
  }
  if (file.empty() || out.empty() || !has_vp || width == 0) {
    return Fail("usage: FILE.glb --size WxH --view-projection M0,...,M15 --out REF.ppm [--compare FRAME.ppm ...]");
  }
  auto scene = meshstream::ImportFile(file);
  if (!scene.ok()) return Fail(file + ": " + scene.status().ToString());

  if (!glfwInit()) return Fail("no display (run under xvfb-run)");
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_RESIZABLE, GLFW_FALSE);
  GLFWwindow* window = glfwCreateWindow(width, height, "reference", nullptr, nullptr);
  if (window == nullptr) return Fail("no OpenGL 3.3 core context");
  glfwMakeContextCurrent(window);
  int fb_width = 0, fb_height = 0;
  glfwGetFramebufferSize(window, &fb_width, &fb_height);
  if (fb_width != width || fb_height != height) return Fail("the framebuffer is not the size asked for");

  vw_renderer renderer;
  const char* error = nullptr;
  if (vw_renderer_init(&renderer, &error) != 0) return Fail(std::string("shaders: ") + error);
  // One vw_primitive per glTF primitive, with every instance of its mesh.
  std::vector<std::vector<float>> instances(scene->meshes.size());
  meshstream::ForEachMeshInstance(*scene, [&](int32_t mesh, const meshstream::Mat4d& world, bool) {
    for (double x : world) instances[static_cast<size_t>(mesh)].push_back(static_cast<float>(x));
  });
  std::vector<vw_primitive> primitives;
  for (size_t m = 0; m < scene->meshes.size(); ++m) {
    for (const meshstream::Primitive& p : scene->meshes[m].primitives) {
      if (p.indices.empty()) continue;
      vw_primitive v;
      vw_primitive_init(&v);
      vw_primitive_set_instances(&v, instances[m].data(), static_cast<uint32_t>(instances[m].size() / 16));
      const uint32_t n = static_cast<uint32_t>(p.positions.size());
      const uint32_t k = static_cast<uint32_t>(p.indices.size());
      const ms_range all_vertices{0, n}, all_indices{0, k};
      vw_primitive_update(&renderer, &v, n, p.positions.data()->data(),
                          p.normals.empty() ? nullptr : p.normals.data()->data(), nullptr, &all_vertices, 1, k,
                          p.indices.data(), &all_indices, 1);
      primitives.push_back(v);
    }
  }
  vw_draw(&renderer, primitives.data(), static_cast<uint32_t>(primitives.size()), view_projection, 0, width, height);
  glFinish();
  std::vector<uint8_t> rgb(static_cast<size_t>(width) * height * 3);
  vw_read_pixels(width, height, rgb.data());
  if (vw_write_ppm(out.c_str(), width, height, rgb.data()) != 0) return Fail("cannot write " + out);
  for (vw_primitive& v : primitives) vw_primitive_free(&v);
  vw_renderer_free(&renderer);
  glfwDestroyWindow(window);
  glfwTerminate();

  if (compare.empty()) return 0;
  int cw = 0, ch = 0;
  std::vector<uint8_t> frame;
  if (!ReadPpm(compare, &cw, &ch, &frame)) return Fail("cannot read " + compare + " as a binary PPM");
  if (cw != width || ch != height) return Fail(compare + " is not " + std::to_string(width) + "x" + std::to_string(height));
  size_t differing = 0;
  int largest = 0;
  const size_t pixels = static_cast<size_t>(width) * height;
  for (size_t i = 0; i < pixels; ++i) {
    int d = 0;
    for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(int{rgb[3 * i + c]} - int{frame[3 * i + c]}));
    largest = std::max(largest, d);
    if (d > channel_tolerance) ++differing;
  }
  const double fraction = static_cast<double>(differing) / static_cast<double>(pixels);
  std::printf("{\"pixels\": %zu, \"differing\": %zu, \"fraction\": %.6f, \"largest_difference\": %d}\n", pixels,
              differing, fraction, largest);
  return fraction <= max_fraction ? 0 : 1;
}
